//! Finding the element under a surface point (for probes): the nearest display face
//! ([`OperatorFile::faces`](lrr_formats::OperatorFile::faces): what is drawn, section FACES or
//! GEOMETRY's elements), and its element.

use crate::operator::Operator;

impl Operator {
    /// The original id of the element whose surface holds `point`: the element of the display
    /// face [`locate_face`](Self::locate_face) finds.
    pub fn locate(&self, point: [f32; 3], normal: [f32; 3]) -> Option<u32> {
        self.locate_position(point, normal)
            .map(|s| self.file().order[s])
    }

    /// The file position of the element [`locate`](Self::locate) finds.
    pub fn locate_position(&self, point: [f32; 3], normal: [f32; 3]) -> Option<usize> {
        self.locate_face(point, normal)
            .map(|f| self.file().faces().element(f))
    }

    /// The display face holding `point` (what [`Reconstruction::at`](crate::Reconstruction::at)
    /// takes; the file position of its element when the file has no section FACES): the
    /// closest face among those whose normal agrees with `normal` (dot > 0), or among all when
    /// none agrees. Linear in the number of faces (a probe is not a per-frame operation).
    pub fn locate_face(&self, point: [f32; 3], normal: [f32; 3]) -> Option<usize> {
        let g = self.file().faces().geometry;
        let mut best: Option<(bool, f64, usize)> = None;
        for s in 0..g.len() {
            let count = usize::from(g.vertex_count[s]);
            let verts: Vec<[f64; 3]> = (0..count).map(|i| g.vertex(s, i).map(f64::from)).collect();
            let nrm = g.normal(s).map(f64::from);
            let agrees = dot(nrm, normal.map(f64::from)) > 0.0;
            let d = distance_to_polygon(point.map(f64::from), &verts, nrm);
            let better = match best {
                None => true,
                Some((ba, bd, _)) => (agrees && !ba) || (agrees == ba && d < bd),
            };
            if better {
                best = Some((agrees, d, s));
            }
        }
        best.map(|(_, _, s)| s)
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Distance from `p` to a planar convex polygon with unit normal `n`.
fn distance_to_polygon(p: [f64; 3], v: &[[f64; 3]], n: [f64; 3]) -> f64 {
    let height = dot(sub(p, v[0]), n);
    let inside = (0..v.len()).all(|i| {
        let a = v[i];
        let b = v[(i + 1) % v.len()];
        dot(cross(sub(b, a), sub(p, a)), n) >= 0.0
    });
    if inside {
        return height.abs();
    }
    (0..v.len())
        .map(|i| segment_distance(p, v[i], v[(i + 1) % v.len()]))
        .fold(f64::INFINITY, f64::min)
}

fn segment_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    let t = if len2 > 0.0 {
        (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]];
    let d = sub(p, q);
    dot(d, d).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances() {
        let sq = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let n = [0.0, 0.0, 1.0];
        assert!((distance_to_polygon([0.5, 0.5, 0.25], &sq, n) - 0.25).abs() < 1e-12);
        assert!((distance_to_polygon([2.0, 0.5, 0.0], &sq, n) - 1.0).abs() < 1e-12);
    }

    /// With display faces, a point is located on the face that holds it, and its element is
    /// that face's (not the GEOMETRY proxy's under the point).
    #[test]
    fn points_are_located_on_the_display_faces() {
        use crate::testkit::faces::{ORDER, element_at, face_at, interleaved};
        let op = Operator::from_file(interleaved()).unwrap();
        let up = [0.0, 0.0, 1.0];
        for (x, y) in [
            (0.2f32, 0.4f32),
            (0.9, 0.2),
            (1.3, 0.8),
            (1.8, 0.1),
            (0.5, 0.9),
        ] {
            let p = [x, y, 0.0];
            assert_eq!(op.locate_face(p, up), Some(face_at(x, y)), "({x}, {y})");
            assert_eq!(op.locate_position(p, up), Some(element_at(x, y)));
            assert_eq!(op.locate(p, up), Some(ORDER[element_at(x, y)]));
        }
        // (0.2, 0.4) lies on the proxy of element 0 but is drawn by element 1.
        assert_eq!(op.locate_position([0.2, 0.4, 0.0], up), Some(1));
    }
}
