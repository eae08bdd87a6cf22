//! Embree 4's single-ray queries over a tracer's display triangles, the baseline of
//! `lrr bench render` (cargo feature `embree` only): `rtcIntersect1` closest hits and
//! `rtcOccluded1` any hits, one ray at a time on the calling thread, the way the CPU tracer
//! traces. Scene flags default (no ROBUST: Embree's fast path), build quality HIGH by default
//! (the tracer's BVH is built offline too; `--embree-quality`); no filter functions.

use std::ptr::null_mut;

use anyhow::{Result, bail};
use embree4_sys as sys;
use lrr_runtime::trace::RayBatch;

/// An Embree scene of triangles.
pub struct EmbreeScene {
    device: sys::RTCDevice,
    scene: sys::RTCScene,
}

/// The device's last error, or `Ok`.
fn check(device: sys::RTCDevice, what: &str) -> Result<()> {
    // SAFETY: `device` is a live device handle (or null, which Embree accepts here).
    let code = unsafe { sys::rtcGetDeviceError(device) };
    if code != sys::RTCError::NONE {
        bail!("Embree: {what} failed ({code:?})");
    }
    Ok(())
}

impl EmbreeScene {
    /// Embree's BVH over `tris` (v0, v1, v2 each).
    pub fn build(tris: &[[[f32; 3]; 3]], quality: sys::RTCBuildQuality) -> Result<Self> {
        // SAFETY: FFI calls on handles made here; the buffers Embree returns are written within
        // the sizes they were made with; `Drop` releases the handles on every path.
        unsafe {
            let device = sys::rtcNewDevice(null_mut());
            if device.is_null() {
                bail!("Embree: could not create a device");
            }
            let s = EmbreeScene {
                device,
                scene: sys::rtcNewScene(device),
            };
            check(device, "creating the scene")?;
            sys::rtcSetSceneBuildQuality(s.scene, quality);
            let count = tris.len();
            let geometry = sys::rtcNewGeometry(device, sys::RTCGeometryType::TRIANGLE);
            check(device, "creating the geometry")?;
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
                check(device, "allocating the buffers")?;
                bail!("Embree: could not allocate the triangle buffers");
            }
            let vertices = std::slice::from_raw_parts_mut(vertices, 9 * count);
            let indices = std::slice::from_raw_parts_mut(indices, 3 * count);
            for (i, t) in tris.iter().enumerate() {
                for (j, v) in t.iter().enumerate() {
                    vertices[9 * i + 3 * j..9 * i + 3 * j + 3].copy_from_slice(v);
                    indices[3 * i + j] = (3 * i + j) as u32;
                }
            }
            sys::rtcCommitGeometry(geometry);
            sys::rtcAttachGeometry(s.scene, geometry);
            sys::rtcReleaseGeometry(geometry);
            check(device, "committing the geometry")?;
            sys::rtcCommitScene(s.scene);
            check(device, "building the BVH")?;
            Ok(s)
        }
    }

    fn ray(rays: &RayBatch, i: usize) -> sys::RTCRay {
        let (o, d) = (rays.origins[i], rays.dirs[i]);
        sys::RTCRay {
            org_x: o[0],
            org_y: o[1],
            org_z: o[2],
            tnear: 0.0,
            dir_x: d[0],
            dir_y: d[1],
            dir_z: d[2],
            time: 0.0,
            tfar: rays.t_max[i],
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    /// The closest hit of each ray: (distance, triangle id), one `rtcIntersect1` each.
    pub fn closest_hits(&self, rays: &RayBatch) -> Vec<Option<(f32, u32)>> {
        (0..rays.len())
            .map(|i| {
                let mut rh = sys::RTCRayHit {
                    ray: Self::ray(rays, i),
                    hit: sys::RTCHit {
                        Ng_x: 0.0,
                        Ng_y: 0.0,
                        Ng_z: 0.0,
                        u: 0.0,
                        v: 0.0,
                        primID: u32::MAX,
                        geomID: u32::MAX,
                        instID: [u32::MAX],
                    },
                };
                // SAFETY: a committed scene; `rh` is a valid, 16-byte aligned RTCRayHit (the
                // type's repr); null arguments mean the defaults.
                unsafe { sys::rtcIntersect1(self.scene, &mut rh, null_mut()) };
                (rh.hit.geomID != u32::MAX).then_some((rh.ray.tfar, rh.hit.primID))
            })
            .collect()
    }

    /// Whether each ray is blocked before its far end, one `rtcOccluded1` each.
    pub fn occluded(&self, rays: &RayBatch) -> Vec<bool> {
        (0..rays.len())
            .map(|i| {
                let mut ray = Self::ray(rays, i);
                // SAFETY: as in `closest_hits`; Embree sets `tfar` to -inf on a hit.
                unsafe { sys::rtcOccluded1(self.scene, &mut ray, null_mut()) };
                ray.tfar == f32::NEG_INFINITY
            })
            .collect()
    }
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: the handles were made by `build` and are released once, here.
        unsafe {
            if !self.scene.is_null() {
                sys::rtcReleaseScene(self.scene);
            }
            sys::rtcReleaseDevice(self.device);
        }
    }
}
