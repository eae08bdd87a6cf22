//! Occlusion queries through Embree 4 (cargo feature `embree`; scripts/setup-embree.sh fetches
//! the library).
//!
//! One triangle geometry (quads as two triangles, coordinates shifted to the scene's centre
//! before the f32 conversion, like [`super::obvhs`]), scene flag `ROBUST`, build quality `HIGH`.
//! A query is one `rtcOccluded1` over the segment extended by a small slack at both ends, so
//! that f32 rounding never drops a face crossed right next to an end point.
//!
//! The own-face rule lives in the geometry's occlusion filter, which Embree calls for every
//! candidate hit before it may end the query. The filter rejects a candidate when
//! - it is the face an end point lies on, or a coincident back face: the same plane-and-normal
//!   test as the obvhs backend (end point within [`PLANE_TOLERANCE`] of the scene extent from
//!   the triangle's plane, triangle normal parallel to the point's surface normal);
//! - otherwise, when Embree's f32 hit distance lies within the slack of an end point: there f32
//!   cannot tell a face crossed just inside the segment from one just outside, so the exact f64
//!   watertight test of [`super::watertight`] over the segment decides.
//!
//! Hits in the segment's interior are Embree's own f32 answer (its triangle test is
//! watertight: zero-thickness walls do not leak). The two backends therefore differ only on
//! rays that graze a triangle's edge, where f32 and f64 round differently; the agreement
//! tests measure how often (≈ 1 ray in 10⁶ or less).
//!
//! Why no embree4-rs: its 0.0.16 keeps the scene handle private and has no occlusion query, so
//! everything goes through embree4-sys (Embree 4.2 headers; the 4.4 library is ABI compatible
//! for what is used here: single rays, default query arguments, geometry filter functions).
//! The per-query data (f64 end points and normals) reaches the filter through a thread-local:
//! a custom ray query context would depend on the context's layout, which grew between 4.2
//! and 4.4.

use std::cell::Cell;
use std::ffi::c_void;
use std::ptr::null_mut;
use std::sync::atomic::{AtomicI64, Ordering};

use embree4_sys as sys;
use glam::DVec3;

use super::occluder::{
    Occluder, PLANE_TOLERANCE, SEGMENT_EPSILON, own_face, relative_segment, triangle_plane,
    triangles,
};
use super::watertight::ShearedRay;
use crate::error::{Error, Result};
use crate::scene::Scene;

/// Slack added at both ends of a query, relative to the segment's length and, added, to the
/// scene's extent (f32 rounding of the hit distance grows with the coordinates).
const SLACK_LENGTH: f64 = 1e-5;
const SLACK_EXTENT: f64 = 1e-5;

/// The triangles in f64 (relative to the centre), their planes and the tolerance: what the
/// filter needs, at a stable address (the geometry's user pointer).
struct Exact {
    tris: Vec<[DVec3; 3]>,
    planes: Vec<(DVec3, f64)>,
    plane_tolerance: f64,
}

/// Bytes this crate holds beside Embree while it builds over `scene`: the faces (a copy each,
/// merged into convex planar groups: about 300 bytes, `Backend::build_within`), and per
/// triangle the exact f64 triangle (72) and its plane (32) that [`Exact`] keeps for the filter.
fn kept_bytes(scene: &Scene) -> u128 {
    300 * scene.faces.len() as u128 + 104 * triangles(scene)
}

/// The query in flight on this thread, for the filter.
#[derive(Clone, Copy)]
struct Query {
    origin: DVec3,
    target: DVec3,
    from_normal: DVec3,
    to_normal: DVec3,
    length: f64,
    slack: f64,
    sheared: ShearedRay,
}

thread_local! {
    /// Points at the `Query` on the stack of this thread's `occluded` call while Embree runs
    /// it; null otherwise. (A pointer, not a copy: the filter runs once or twice per ray.)
    static QUERY: Cell<*const Query> = const { Cell::new(std::ptr::null()) };
}

/// Embree 4's scene over the faces (one triangle geometry, quads as two triangles) with the
/// exact f64 triangles the occlusion filter tests against.
pub struct EmbreeOccluder {
    device: sys::RTCDevice,
    scene: sys::RTCScene,
    exact: Box<Exact>,
    centre: DVec3,
    extent: f64,
    /// Embree's own allocations, as its memory monitor reports them; released after the
    /// device (its user pointer).
    memory: Box<Monitor>,
    /// `--max-memory` as given (None: 80% of what is available), for a refusal's words.
    max_memory: Option<u64>,
}

/// What a device has allocated, as Embree's memory monitor callback reports it (each block
/// once: bytes > 0 allocated, < 0 freed, `post` whether it already happened), and what it may
/// allocate: a block that would go over `limit` is refused, and Embree then cancels the build
/// with `RTC_ERROR_OUT_OF_MEMORY`.
struct Monitor {
    current: AtomicI64,
    peak: AtomicI64,
    limit: i64,
}

/// Embree's memory monitor ([`Monitor`]); Embree may call it from several threads at once.
unsafe extern "C" fn memory_monitor(user: *mut c_void, bytes: isize, post: bool) -> bool {
    // SAFETY: `user` is the device's `Monitor`, which outlives the device (`EmbreeOccluder`
    // releases the device in `drop`, before its fields).
    let m = unsafe { &*(user as *const Monitor) };
    let bytes = bytes as i64;
    let now = m.current.fetch_add(bytes, Ordering::Relaxed) + bytes;
    if bytes > 0 && now > m.limit {
        if !post {
            // Refused before it happened: it never will.
            m.current.fetch_sub(bytes, Ordering::Relaxed);
        }
        return false;
    }
    m.peak.fetch_max(now, Ordering::Relaxed);
    true
}

// SAFETY: a committed Embree scene is safe to query from any number of threads at once
// (Embree's documented contract for rtcOccluded1); the handles are only released in `drop`,
// which takes `&mut self`. `exact` is read-only after construction.
unsafe impl Send for EmbreeOccluder {}
unsafe impl Sync for EmbreeOccluder {}

/// The device's last error as a message, or `Ok` when none. (The message text needs
/// `rtcGetDeviceLastErrorMessage`, which the 4.2 headers lack; the code says enough.)
fn check(device: sys::RTCDevice, what: &str) -> Result<()> {
    // SAFETY: `device` is a live device handle (or null, which Embree accepts here).
    let code = unsafe { sys::rtcGetDeviceError(device) };
    if code == sys::RTCError::NONE {
        return Ok(());
    }
    Err(Error::Settings(format!(
        "Embree: {what} failed ({code:?}); check the library installed by \
         scripts/setup-embree.sh, or bake with --visibility obvhs"
    )))
}

impl EmbreeOccluder {
    /// Builds Embree's BVH over the scene's faces (quads as two triangles), with no limit but
    /// the machine's.
    pub fn build(scene: &Scene) -> Result<Self> {
        Self::build_limited(scene, None, None)
    }

    /// [`build`](Self::build) under `max_memory` (`--max-memory`; None: 80% of what is
    /// available): Embree's own allocations (the triangle buffers and the BVH, as its memory
    /// monitor reports them) are held to what the limit leaves beside the arrays kept for the
    /// filter ([`kept_bytes`]). Over it, Embree cancels the build and this is an
    /// [`Error::Limits`] naming what to change.
    pub fn build_within(scene: &Scene, max_memory: Option<u64>) -> Result<Self> {
        let limit = crate::memory::usable(max_memory).saturating_sub(kept_bytes(scene));
        Self::build_limited(scene, Some(limit), max_memory)
    }

    /// The build, Embree's own allocations held to `limit` bytes (None: not held).
    fn build_limited(scene: &Scene, limit: Option<u128>, max_memory: Option<u64>) -> Result<Self> {
        let (lo, hi) = scene.bounds();
        let centre = (lo + hi) * 0.5;
        let extent = (hi - lo).length();
        let mut tris = Vec::with_capacity(scene.faces.len() * 2);
        for f in &scene.faces {
            let v = f.polygon.vertices();
            for i in 1..v.len() - 1 {
                tris.push([v[0] - centre, v[i] - centre, v[i + 1] - centre]);
            }
        }
        let planes = tris.iter().map(triangle_plane).collect();
        let exact = Box::new(Exact {
            tris,
            planes,
            plane_tolerance: PLANE_TOLERANCE * extent,
        });
        // SAFETY: plain FFI calls on handles created here; every buffer Embree hands out is
        // written within the sizes it was created with. On error the handles made so far
        // are released by `Drop` (the struct is built before the first fallible step).
        unsafe {
            let device = sys::rtcNewDevice(null_mut());
            if device.is_null() {
                check(null_mut(), "creating the device")?;
                return Err(Error::Settings(
                    "Embree: could not create a device (unsupported CPU?); bake with \
                     --visibility obvhs"
                        .into(),
                ));
            }
            let memory = Box::new(Monitor {
                current: AtomicI64::new(0),
                peak: AtomicI64::new(0),
                limit: limit.map_or(i64::MAX, |l| l.min(i64::MAX as u128) as i64),
            });
            let user = &*memory as *const Monitor as *mut c_void;
            sys::rtcSetDeviceMemoryMonitorFunction(device, Some(memory_monitor), user);
            let scene_handle = sys::rtcNewScene(device);
            let occ = Self {
                device,
                scene: scene_handle,
                exact,
                centre,
                extent,
                memory,
                max_memory,
            };
            check(device, "creating the scene")?;
            sys::rtcSetSceneFlags(occ.scene, sys::RTCSceneFlags::ROBUST);
            sys::rtcSetSceneBuildQuality(occ.scene, sys::RTCBuildQuality::HIGH);
            check(device, "setting the scene flags")?;
            let count = occ.exact.tris.len();
            let geometry = sys::rtcNewGeometry(device, sys::RTCGeometryType::TRIANGLE);
            check(device, "creating the triangle geometry")?;
            let vertices = sys::rtcSetNewGeometryBuffer(
                geometry,
                sys::RTCBufferType::VERTEX,
                0,
                sys::RTCFormat::FLOAT3,
                3 * size_of::<f32>(),
                3 * count,
            ) as *mut f32;
            let indices = sys::rtcSetNewGeometryBuffer(
                geometry,
                sys::RTCBufferType::INDEX,
                0,
                sys::RTCFormat::UINT3,
                3 * size_of::<u32>(),
                count,
            ) as *mut u32;
            if vertices.is_null() || indices.is_null() {
                sys::rtcReleaseGeometry(geometry);
                occ.within_limit("allocating the triangle buffers")?;
                return Err(Error::Settings(
                    "Embree: could not allocate the triangle buffers".into(),
                ));
            }
            let vertices = std::slice::from_raw_parts_mut(vertices, 9 * count);
            let indices = std::slice::from_raw_parts_mut(indices, 3 * count);
            for (i, t) in occ.exact.tris.iter().enumerate() {
                for (j, v) in t.iter().enumerate() {
                    let v = v.as_vec3();
                    vertices[9 * i + 3 * j..9 * i + 3 * j + 3].copy_from_slice(&[v.x, v.y, v.z]);
                    indices[3 * i + j] = (3 * i + j) as u32;
                }
            }
            sys::rtcSetGeometryUserData(geometry, &*occ.exact as *const Exact as *mut c_void);
            sys::rtcSetGeometryOccludedFilterFunction(geometry, Some(occlusion_filter));
            sys::rtcCommitGeometry(geometry);
            sys::rtcAttachGeometry(occ.scene, geometry);
            sys::rtcReleaseGeometry(geometry); // the scene holds it now
            check(device, "committing the triangle geometry")?;
            sys::rtcCommitScene(occ.scene);
            occ.within_limit("building the BVH")?;
            Ok(occ)
        }
    }

    /// Triangles in the scene (quads count two).
    pub fn triangle_count(&self) -> usize {
        self.exact.tris.len()
    }

    /// The device's last error (taken: it is cleared), as [`check`] would give it, but
    /// `RTC_ERROR_OUT_OF_MEMORY` as a refusal: the memory monitor refused a block over the
    /// limit, or the system had none left.
    fn within_limit(&self, what: &str) -> Result<()> {
        // SAFETY: `self.device` is a live device handle.
        let code = unsafe { sys::rtcGetDeviceError(self.device) };
        let triangles = self.exact.tris.len();
        let advice = "simplify the model (fewer triangles), or raise --max-memory";
        match code {
            sys::RTCError::NONE => Ok(()),
            sys::RTCError::OUT_OF_MEMORY if self.memory.limit == i64::MAX => Err(Error::Limits(
                format!("Embree ran out of memory {what} over {triangles} triangles; {advice}"),
            )),
            sys::RTCError::OUT_OF_MEMORY => Err(Error::Limits(format!(
                "Embree's BVH over {triangles} triangles needs more than the {} it may take \
                 beside the rest of the bake, but only {} can be used{}; {advice}",
                crate::memory::size(self.memory.limit as u128),
                crate::memory::size(crate::memory::usable(self.max_memory)),
                crate::memory::whence(self.max_memory),
            ))),
            code => Err(Error::Settings(format!(
                "Embree: {what} failed ({code:?}); check the library installed by \
                 scripts/setup-embree.sh, or bake with --visibility obvhs"
            ))),
        }
    }

    /// The most Embree's own allocations have held at once (its memory monitor's figure: the
    /// triangle buffers and the BVH, not the exact triangles kept beside them).
    pub fn embree_peak_bytes(&self) -> u64 {
        self.memory.peak.load(Ordering::Relaxed).max(0) as u64
    }
}

impl Drop for EmbreeOccluder {
    fn drop(&mut self) {
        // SAFETY: the handles were created by `build` and are released once, here.
        unsafe {
            if !self.scene.is_null() {
                sys::rtcReleaseScene(self.scene);
            }
            sys::rtcReleaseDevice(self.device);
        }
    }
}

/// Whether a candidate hit of Embree blocks the query: the own-face rule, then, near the end
/// points, the exact test (see the module documentation).
fn accept(exact: &Exact, q: &Query, prim: usize, t_hit: f64) -> bool {
    let (Some(&plane), Some(&[a, b, c])) = (exact.planes.get(prim), exact.tris.get(prim)) else {
        return false;
    };
    let tol = exact.plane_tolerance;
    if own_face(plane, tol, q.origin, q.from_normal) || own_face(plane, tol, q.target, q.to_normal)
    {
        return false;
    }
    if t_hit > q.slack && t_hit < q.length - q.slack {
        return true;
    }
    q.sheared.hit(a, b, c).is_some()
}

/// Embree's occlusion filter: clears `valid` for candidates that do not block.
unsafe extern "C" fn occlusion_filter(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments for `N` rays: `valid` has N entries, the ray and
    // hit are SoA blocks of N lanes (RTCRayN: tfar is the 9th float block; RTCHitN: primID the
    // 6th u32 block), and the user pointer is the `Exact` set in `build`, alive as long as
    // the scene. A non-null QUERY points at the live `Query` of the `occluded` call that is
    // running Embree on this very thread (filters run on the calling thread).
    unsafe {
        let args = &*args;
        let n = args.N as usize;
        let exact = &*(args.geometryUserPtr as *const Exact);
        let q = QUERY.with(Cell::get);
        if q.is_null() {
            return; // not one of our queries: leave Embree's answer
        }
        let q = &*q;
        for i in 0..n {
            let valid = args.valid.add(i);
            if *valid == 0 {
                continue;
            }
            let tfar = *(args.ray as *const f32).add(8 * n + i);
            let prim = *(args.hit as *const u32).add(5 * n + i) as usize;
            if !accept(exact, q, prim, f64::from(tfar)) {
                *valid = 0;
            }
        }
    }
}

impl Occluder for EmbreeOccluder {
    fn occluded(&self, from: DVec3, from_normal: DVec3, to: DVec3, to_normal: DVec3) -> bool {
        let Some((origin, target, direction, length)) = relative_segment(self.centre, from, to)
        else {
            return false; // a point does not block itself
        };
        let slack = SLACK_LENGTH * length + SLACK_EXTENT * self.extent;
        let eps = f64::from(SEGMENT_EPSILON) * length;
        let query = Query {
            origin,
            target,
            from_normal,
            to_normal,
            length,
            slack,
            sheared: ShearedRay::new(origin, direction, eps, length - eps),
        };
        let (o, dir) = (origin.as_vec3(), direction.as_vec3());
        let mut ray = sys::RTCRay {
            org_x: o.x,
            org_y: o.y,
            org_z: o.z,
            tnear: -(slack as f32),
            dir_x: dir.x,
            dir_y: dir.y,
            dir_z: dir.z,
            time: 0.0,
            tfar: (length + slack) as f32,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        };
        QUERY.with(|c| c.set(&query));
        // SAFETY: the scene is committed and lives as long as `self`; a null argument pointer
        // asks for Embree's default query arguments (the geometry filter still runs).
        unsafe { sys::rtcOccluded1(self.scene, &mut ray, null_mut()) };
        QUERY.with(|c| c.set(std::ptr::null()));
        // Embree marks an occluded ray by setting tfar to -inf.
        ray.tfar == f32::NEG_INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::visibility::fixtures;
    use crate::visibility::obvhs::ObvhsOccluder;

    #[test]
    fn embree_block_in_a_room_casts_a_shadow() {
        let scene = fixtures::block_in_a_room();
        let occ = EmbreeOccluder::build(&scene).unwrap();
        assert_eq!(occ.triangle_count(), 2 * scene.faces.len());
        fixtures::assert_block_casts_a_shadow(&occ);
    }

    #[test]
    fn embree_builds_within_its_memory_limit_or_says_it_cannot() {
        let scene = fixtures::two_rooms([1, 1, 0]);
        let occ = EmbreeOccluder::build(&scene).unwrap();
        let used = occ.embree_peak_bytes();
        assert!(used > 0, "the memory monitor saw no allocation");
        // Embree's own blocks are the triangle buffers (48 bytes a triangle) and the BVH.
        assert!(
            used >= 48 * occ.triangle_count() as u64,
            "{used} bytes for {} triangles",
            occ.triangle_count()
        );
        drop(occ);
        for limit in [0, used as u128 / 2] {
            let err = EmbreeOccluder::build_limited(&scene, Some(limit), Some(1 << 30))
                .err()
                .expect("refused");
            let text = err.to_string();
            assert!(
                matches!(err, Error::Limits(_))
                    && text.contains("Embree's BVH over")
                    && text.contains("but only 1.00 GiB can be used; simplify the model"),
                "{text}"
            );
        }
        // What it used is enough.
        EmbreeOccluder::build_limited(&scene, Some(used as u128), None).unwrap();
        // Under --max-memory, what the limit leaves beside the kept arrays.
        let kept = kept_bytes(&scene);
        let max = |extra: u128| Some(u64::try_from(kept + extra).unwrap());
        EmbreeOccluder::build_within(&scene, max(used as u128)).unwrap();
        let err = EmbreeOccluder::build_within(&scene, max(used as u128 / 2)).err();
        assert!(matches!(err, Some(Error::Limits(_))), "{err:?}");
    }

    #[test]
    fn embree_blocks_walls_crossed_next_to_an_end_point() {
        // A zero-thickness wall at x = 1 between two rooms; segments from points 1e-9 .. 1e-3
        // away from the wall's foot to the other room: every one crosses the wall, most of
        // them within f32 rounding of their start.
        let scene = fixtures::two_rooms([1, 0, 0]);
        let occ = EmbreeOccluder::build(&scene).unwrap();
        let reference = ObvhsOccluder::build(&scene);
        for k in 3..=9 {
            let gap = 10f64.powi(-k);
            let from = DVec3::new(1.0 - gap, 0.37, 0.0);
            let to = DVec3::new(1.6, 0.52, 1.0);
            assert!(reference.occluded(from, DVec3::Z, to, -DVec3::Z));
            assert!(
                occ.occluded(from, DVec3::Z, to, -DVec3::Z),
                "leak at gap {gap}"
            );
            // The same segment reversed.
            assert!(
                occ.occluded(to, -DVec3::Z, from, DVec3::Z),
                "leak at gap {gap}"
            );
        }
    }

    #[test]
    fn embree_agrees_with_obvhs_near_walls_and_corners() {
        // The obvhs unit test's two rooms sharing walls at a corner, with random segments:
        // every segment crosses a wall.
        let scene = fixtures::two_rooms([1, 1, 0]);
        let occ = EmbreeOccluder::build(&scene).unwrap();
        for (from, to) in fixtures::corner_segments(100_000) {
            assert!(occ.occluded(from, DVec3::Z, to, DVec3::Z), "{from} → {to}");
        }
    }
}
