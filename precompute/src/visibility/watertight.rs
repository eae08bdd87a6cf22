//! Watertight ray/triangle intersection (Woop, Benthin, Wald: "Watertight Ray/Triangle
//! Intersection", JCGT 2013).
//!
//! Why not obvhs' Möller–Trumbore: a zero-thickness wall (two coincident faces back to back)
//! split into triangles along the same diagonal let about one ray in 10⁷ through the shared
//! edge: a light leak of 5e-5 of the lit room's radiosity into a closed dark room. The
//! watertight test shears the triangle into ray space and evaluates the three edge functions
//! so that two triangles sharing an edge give exactly opposite values for it: a ray through
//! an edge hits at least one of them. It runs in f64: segments sampled within 1e-8 of a wall
//! must still hit it, which f32 distances (ulp 6e-8 at 1) cannot tell from the end point.

use glam::DVec3;

/// A ray prepared for watertight tests: the permutation and shear of ray space.
#[derive(Debug, Clone, Copy)]
pub(super) struct ShearedRay {
    origin: DVec3,
    k: [usize; 3],
    shear: [f64; 3],
    tmin: f64,
    tmax: f64,
}

impl ShearedRay {
    pub(super) fn new(origin: DVec3, direction: DVec3, tmin: f64, tmax: f64) -> Self {
        let a = direction.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if direction[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky); // keep the winding of ray space
        }
        let dz = direction[kz];
        Self {
            origin,
            k: [kx, ky, kz],
            shear: [direction[kx] / dz, direction[ky] / dz, 1.0 / dz],
            tmin,
            tmax,
        }
    }

    /// Distance to the hit within `[tmin, tmax]`, or `None`.
    pub(super) fn hit(&self, v0: DVec3, v1: DVec3, v2: DVec3) -> Option<f64> {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.shear;
        let (a, b, c) = (v0 - self.origin, v1 - self.origin, v2 - self.origin);
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None; // the ray lies in the triangle's plane
        }
        let t_scaled = u * (sz * a[kz]) + v * (sz * b[kz]) + w * (sz * c[kz]);
        let (t_scaled, det) = if det < 0.0 {
            (-t_scaled, -det)
        } else {
            (t_scaled, det)
        };
        if t_scaled < self.tmin * det || t_scaled > self.tmax * det {
            return None;
        }
        Some(t_scaled / det)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3 as V;
    fn vec3a(x: f64, y: f64, z: f64) -> V {
        V::new(x, y, z)
    }

    #[test]
    fn hits_inside_misses_outside_and_respects_the_range() {
        let (a, b, c) = (
            vec3a(0.0, 0.0, 1.0),
            vec3a(1.0, 0.0, 1.0),
            vec3a(0.0, 1.0, 1.0),
        );
        let r = ShearedRay::new(vec3a(0.2, 0.2, 0.0), vec3a(0.0, 0.0, 1.0), 0.0, 10.0);
        assert!((r.hit(a, b, c).unwrap() - 1.0).abs() < 1e-6);
        assert!(
            (r.hit(a, c, b).unwrap() - 1.0).abs() < 1e-6,
            "both windings"
        );
        let miss = ShearedRay::new(vec3a(0.8, 0.8, 0.0), vec3a(0.0, 0.0, 1.0), 0.0, 10.0);
        assert!(miss.hit(a, b, c).is_none());
        let short = ShearedRay::new(vec3a(0.2, 0.2, 0.0), vec3a(0.0, 0.0, 1.0), 0.0, 0.5);
        assert!(short.hit(a, b, c).is_none());
    }

    #[test]
    fn rays_through_a_shared_diagonal_always_hit() {
        // A unit quad split along its diagonal; rays aimed exactly at points of the diagonal,
        // from many directions: each must hit at least one of the two triangles.
        let q = [
            vec3a(1.0, 0.0, 0.0),
            vec3a(1.0, 1.0, 0.0),
            vec3a(1.0, 1.0, 1.0),
            vec3a(1.0, 0.0, 1.0),
        ];
        let mut state = 0x1234_5678u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            f64::from(state) / f64::from(u32::MAX)
        };
        for _ in 0..200_000 {
            let s = next();
            let target = q[0] + (q[2] - q[0]) * s;
            let origin = vec3a(next() * 0.9 + 0.05, next() * 3.0 - 1.0, next() * 3.0 - 1.0);
            let d = target - origin;
            let len = d.length();
            let r = ShearedRay::new(origin, d / len, 1e-4 * len, 2.0 * len);
            let hit = r.hit(q[0], q[1], q[2]).is_some() || r.hit(q[0], q[2], q[3]).is_some();
            assert!(hit, "leak at {target:?} from {origin:?}");
        }
    }
}
