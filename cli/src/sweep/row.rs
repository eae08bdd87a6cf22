//! One measured point of the sweep (a row of the CSV and the markdown table).

use super::truth::Spread;

/// One measured point of the sweep: one bake stored at one precision.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// `2mf` or `2msc`.
    pub method: &'static str,
    pub n: usize,
    pub k: usize,
    pub samples: u32,
    /// `f32` or `f16` (storage of `F_k`).
    pub precision: &'static str,
    /// Against the exact solve with the same samples (the low-rank error alone).
    pub rel_error: f64,
    /// Against the exact solve with `ref_samples` samples (low-rank plus sampling error).
    pub rel_error_ref: Option<f64>,
    pub ref_samples: Option<u32>,
    /// Against the path-traced reference points (`--reference`): total error, discretisation
    /// included; and the reference's own noise (median relative standard error).
    pub truth: Option<Spread>,
    /// The same through the smooth reconstruction.
    pub truth_smooth: Option<Spread>,
    pub truth_noise: Option<f64>,
    /// Wall time of the whole bake (meshing to cores), and per stage.
    pub bake_s: f64,
    pub mesh_s: f64,
    pub visibility_s: f64,
    pub form_factors_s: f64,
    pub operator_s: f64,
    /// Median seconds per runtime frame (factored layout, this precision).
    pub frame_s: f64,
    pub element_size: f64,
    /// 2MF: the patch size; 2MSC: none.
    pub patch_size: Option<f64>,
    /// 2MSC: the coherence threshold; 2MF: none.
    pub threshold: Option<f64>,
    /// Seconds the same-samples exact solve took (shared by the rows of one fine mesh).
    pub exact_s: f64,
    /// Largest per-channel condition number of `I - Vᵀ diag(ρ) F_k`.
    pub condition: f64,
}
