//! A patch of the coarse mesh, and the methods that build them.

use crate::geometry::Region;

/// A coarse-mesh patch holding its elements: a convex polygon of one face's subdivision, or
/// (dense meshes, `cluster`) the union of several small pieces of one surface.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// Its shape: one polygon, or the union of a cluster's parts.
    pub shape: Region,
    /// The face of its (first) part.
    pub face: u32,
    /// Index of its surface in `Scene::surfaces`.
    pub surface: u32,
}

/// How the coarse mesh (the patches) is built from the fine one.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum PatchMethod {
    /// 2MF, two fixed meshes: the uniform cut at the patch size.
    #[default]
    TwoFixed,
    /// 2MSC, two meshes with spatial coherence: patches are split while they lack coherence
    /// (measured against `threshold`) and are larger than `min_patch_area`; `k` is an output.
    SpatialCoherence {
        /// Coherence error above which a patch is split ([`coherence::DEFAULT_THRESHOLD`](super::coherence::DEFAULT_THRESHOLD)).
        threshold: f64,
        /// Smallest area a patch is split from, in scene units² [default: chosen by the method].
        min_patch_area: Option<f64>,
    },
}

impl PatchMethod {
    /// The name files and tables use: `2mf` or `2msc`.
    pub fn name(&self) -> &'static str {
        match self {
            PatchMethod::TwoFixed => "2mf",
            PatchMethod::SpatialCoherence { .. } => "2msc",
        }
    }
}
