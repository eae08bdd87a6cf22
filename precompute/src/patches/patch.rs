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
    /// 2MSC, two meshes with spatial coherence: `k` is an output. By [`CoherenceRule::Merge`]
    /// (the default) touching elements are joined while the estimated error stays under
    /// `threshold`; by [`CoherenceRule::Split`] (the papers') patches are split while they
    /// lack coherence (measured against `threshold`) and are larger than `min_patch_area`.
    SpatialCoherence {
        /// The merge rule's estimated relative error
        /// ([`merge::DEFAULT_THRESHOLD`](super::coherence::merge::DEFAULT_THRESHOLD)), or the
        /// split rule's coherence error above which a patch is split
        /// ([`coherence::DEFAULT_THRESHOLD`](super::coherence::DEFAULT_THRESHOLD)).
        threshold: f64,
        /// Split rule only: smallest area a patch is split from, in scene units² [default:
        /// chosen by the method].
        min_patch_area: Option<f64>,
        /// How the patches are built.
        rule: CoherenceRule,
    },
}

/// How 2MSC builds its patches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CoherenceRule {
    /// Bottom-up: single elements joined while the estimated error stays under the threshold
    /// (`coherence::merge`).
    #[default]
    Merge,
    /// Top-down: the subdivision hierarchy cut with a FIFO list, as the papers describe
    /// (`coherence::two_msc`).
    Split,
}

impl PatchMethod {
    /// The name files and tables use: `2mf`, `2msc` or `2msc-split`.
    pub fn name(&self) -> &'static str {
        match self {
            PatchMethod::TwoFixed => "2mf",
            PatchMethod::SpatialCoherence {
                rule: CoherenceRule::Merge,
                ..
            } => "2msc",
            PatchMethod::SpatialCoherence {
                rule: CoherenceRule::Split,
                ..
            } => "2msc-split",
        }
    }
}
