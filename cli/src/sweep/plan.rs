//! Which bakes a sweep runs: a list of [`BakeSettings`], 2MF and 2MSC alike.
//!
//! The first element size and the first sample count are the *main* ones: there every 2MF
//! patch size and every 2MSC threshold is baked (the `k` curves). The other sample counts are
//! probed at the middle patch size and threshold only (they cost as much as the main curve
//! each), the other element sizes (fine-mesh sizes `n`) over every patch size and threshold.

use lrr_precompute::bake::BakeSettings;
use lrr_precompute::error::{Error, Result};
use lrr_precompute::patches::{CoherenceRule, PatchMethod};
use lrr_precompute::scene::Scene;

/// The axes of a sweep, in absolute units.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOptions {
    /// Fine element sizes (scene units); the first is the main one.
    pub element_sizes: Vec<f64>,
    /// 2MF patch sizes as multiples of the element size (1 gives `k = n`).
    pub patch_multiples: Vec<f64>,
    /// 2MSC thresholds (the merge rule's estimated relative error); empty: no 2MSC points.
    pub thresholds: Vec<f64>,
    /// Thresholds of 2MSC by the split rule (`2msc-split`); empty (the default): none.
    pub split_thresholds: Vec<f64>,
    /// The split rule's `A_min` (`None`: its default).
    pub min_patch_area: Option<f64>,
    /// Samples per pair; the first is the main one.
    pub samples: Vec<u32>,
    /// Samples of the high-accuracy exact reference (`rel_error_ref`); none: no such column.
    pub ref_samples: Option<u32>,
}

/// What the sweep bakes.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub points: Vec<BakeSettings>,
    pub ref_samples: Option<u32>,
}

impl PlanOptions {
    /// The default sweep: the main fine mesh at 1/12 of the scene's diagonal, a coarser one at
    /// 1/8; 16 samples per pair (the bake's default), probes at 4 and 32; a reference at 32
    /// samples. For the Cornell box: n = 936 and about 300, a few minutes on 2 cores. (The
    /// bake's default mesh, 1/20, gives n = 2 116, where each exact solve costs 5× more.)
    pub fn full(scene: &Scene, thresholds: &[f64]) -> Self {
        let d = scene.extent();
        Self {
            element_sizes: vec![d / 12.0, d / 8.0],
            patch_multiples: vec![1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0],
            thresholds: thresholds.to_vec(),
            split_thresholds: Vec::new(),
            min_patch_area: None,
            samples: vec![16, 4, 32],
            ref_samples: Some(32),
        }
    }

    /// `--quick` (CI): one coarse fine mesh (1/10 of the diagonal; n = 538 for the Cornell box),
    /// 16 samples, reference at 32.
    pub fn quick(scene: &Scene, thresholds: &[f64]) -> Self {
        let d = scene.extent();
        Self {
            element_sizes: vec![d / 10.0],
            patch_multiples: vec![1.0, 1.5, 2.0, 3.0, 4.0, 6.0],
            thresholds: thresholds.to_vec(),
            split_thresholds: Vec::new(),
            min_patch_area: None,
            samples: vec![16],
            ref_samples: Some(32),
        }
    }

    /// Checks the axes and lists the bakes.
    pub fn plan(&self) -> Result<Plan> {
        self.check()?;
        let mut points = Vec::new();
        let mid = |v: &[f64]| v.get(v.len() / 2).copied();
        for (ei, &e) in self.element_sizes.iter().enumerate() {
            for (si, &s) in self.samples.iter().enumerate() {
                let main_samples = si == 0;
                if ei > 0 && !main_samples {
                    continue;
                }
                let (multiples, thresholds, split) = if main_samples {
                    (
                        self.patch_multiples.clone(),
                        self.thresholds.clone(),
                        self.split_thresholds.clone(),
                    )
                } else {
                    let m = mid(&self.patch_multiples).into_iter().collect();
                    let t = mid(&self.thresholds).into_iter().collect();
                    let st = mid(&self.split_thresholds).into_iter().collect();
                    (m, t, st)
                };
                for m in multiples {
                    points.push(self.point(e, Some(e * m), PatchMethod::TwoFixed, s));
                }
                for threshold in thresholds {
                    let method = PatchMethod::SpatialCoherence {
                        threshold,
                        min_patch_area: None,
                        rule: CoherenceRule::Merge,
                    };
                    points.push(self.point(e, None, method, s));
                }
                for threshold in split {
                    let method = PatchMethod::SpatialCoherence {
                        threshold,
                        min_patch_area: self.min_patch_area,
                        rule: CoherenceRule::Split,
                    };
                    points.push(self.point(e, None, method, s));
                }
            }
        }
        Ok(Plan {
            points,
            ref_samples: self.ref_samples,
        })
    }

    fn point(&self, e: f64, patch: Option<f64>, method: PatchMethod, samples: u32) -> BakeSettings {
        BakeSettings {
            element_size: Some(e),
            patch_size: patch,
            method,
            samples,
            ..BakeSettings::default()
        }
    }

    fn check(&self) -> Result<()> {
        let bad = |what: &str, fix: &str| Err(Error::Settings(format!("{what}; {fix}")));
        if self.element_sizes.is_empty() || self.samples.is_empty() {
            return bad(
                "the sweep needs at least one element size and one sample count",
                "pass --element-sizes and --samples with one value or more",
            );
        }
        if self.patch_multiples.is_empty()
            && self.thresholds.is_empty()
            && self.split_thresholds.is_empty()
        {
            return bad(
                "the sweep has no 2MF patch size and no 2MSC threshold",
                "pass --patch-multiples, --thresholds or --split-thresholds",
            );
        }
        if let Some(e) = self
            .element_sizes
            .iter()
            .find(|e| !(e.is_finite() && **e > 0.0))
        {
            return bad(
                &format!("element size {e} is not a positive length"),
                "fix --element-sizes",
            );
        }
        if let Some(m) = self
            .patch_multiples
            .iter()
            .find(|m| !(m.is_finite() && **m >= 1.0))
        {
            return bad(
                &format!(
                    "patch multiple {m} is below 1 (a patch cannot be smaller than its elements)"
                ),
                "fix --patch-multiples (1 gives k = n)",
            );
        }
        for (flag, list) in [
            ("--thresholds", &self.thresholds),
            ("--split-thresholds", &self.split_thresholds),
        ] {
            if let Some(t) = list.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
                return bad(
                    &format!("2MSC threshold {t} is not positive"),
                    &format!("fix {flag}"),
                );
            }
        }
        if self.samples.contains(&0) || self.ref_samples == Some(0) {
            return bad(
                "samples per pair must be at least 1",
                "fix --samples / --ref-samples (--no-ref drops the reference)",
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options() -> PlanOptions {
        PlanOptions {
            element_sizes: vec![1.0, 2.0],
            patch_multiples: vec![1.0, 2.0, 4.0],
            thresholds: vec![0.2, 0.1],
            split_thresholds: Vec::new(),
            min_patch_area: None,
            samples: vec![16, 4],
            ref_samples: Some(64),
        }
    }

    #[test]
    fn main_curves_everywhere_probes_in_the_middle() {
        let plan = options().plan().unwrap();
        // main n, main samples: 3 + 2; main n, 4 samples: 1 + 1; second n: 3 + 2.
        assert_eq!(plan.points.len(), 12);
        let probes: Vec<_> = plan.points.iter().filter(|p| p.samples == 4).collect();
        assert_eq!(probes.len(), 2);
        assert_eq!(probes[0].patch_size, Some(2.0));
        assert!(matches!(
            probes[1].method,
            PatchMethod::SpatialCoherence { threshold, .. } if threshold == 0.1
        ));
        assert!(
            plan.points
                .iter()
                .filter(|p| p.element_size == Some(2.0))
                .all(|p| p.samples == 16)
        );
    }

    #[test]
    fn bad_axes_are_refused_with_the_flag_to_fix() {
        let mut o = options();
        o.patch_multiples = vec![0.5];
        let e = o.plan().unwrap_err().to_string();
        assert!(e.contains("--patch-multiples"), "{e}");
        let mut o = options();
        o.samples = vec![];
        assert!(o.plan().unwrap_err().to_string().contains("--samples"));
        let mut o = options();
        o.ref_samples = Some(0);
        assert!(o.plan().unwrap_err().to_string().contains("--ref-samples"));
    }
}
