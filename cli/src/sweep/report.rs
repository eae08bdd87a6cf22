//! The sweep as CSV (one row per bake and precision) and as a markdown report: the table, the
//! Pareto fronts, the error curves' monotonicity and the `k` ratio at equal error.

use std::fmt::Write as _;

use super::analysis::{self, CurveKey};
use super::row::Row;

/// CSV columns, in order (the first eight are the ones the issue asks for).
pub const COLUMNS: [&str; 26] = [
    "method",
    "n",
    "k",
    "samples",
    "precision",
    "rel_error",
    "bake_s",
    "frame_s",
    "rel_error_ref",
    "ref_samples",
    "mesh_s",
    "visibility_s",
    "formfactor_s",
    "operator_s",
    "element_size",
    "patch_size",
    "threshold",
    "exact_s",
    "condition",
    "truth_median",
    "truth_p90",
    "truth_max",
    "truth_noise",
    "truth_smooth_median",
    "truth_smooth_p90",
    "truth_smooth_max",
];

/// The rows as CSV with a header line; absent values are empty fields.
pub fn csv(rows: &[Row]) -> String {
    let mut out = COLUMNS.join(",");
    out.push('\n');
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:e}"));
    for r in rows {
        let fields = [
            r.method.to_string(),
            r.n.to_string(),
            r.k.to_string(),
            r.samples.to_string(),
            r.precision.to_string(),
            format!("{:e}", r.rel_error),
            format!("{:e}", r.bake_s),
            format!("{:e}", r.frame_s),
            opt(r.rel_error_ref),
            r.ref_samples.map_or(String::new(), |s| s.to_string()),
            format!("{:e}", r.mesh_s),
            format!("{:e}", r.visibility_s),
            format!("{:e}", r.form_factors_s),
            format!("{:e}", r.operator_s),
            format!("{:e}", r.element_size),
            opt(r.patch_size),
            opt(r.threshold),
            format!("{:e}", r.exact_s),
            format!("{:e}", r.condition),
            opt(r.truth.map(|t| t.median)),
            opt(r.truth.map(|t| t.p90)),
            opt(r.truth.map(|t| t.max)),
            opt(r.truth_noise),
            opt(r.truth_smooth.map(|t| t.median)),
            opt(r.truth_smooth.map(|t| t.p90)),
            opt(r.truth_smooth.map(|t| t.max)),
        ];
        out.push_str(&fields.join(","));
        out.push('\n');
    }
    out
}

/// What the report says about the rows (also printed by the command).
#[derive(Debug, Clone)]
pub struct Summary {
    /// Worst `error(k_next)/error(k)` of the main f32 curve of each method present.
    pub growth: Vec<(&'static str, f64)>,
    /// The main curve's `k = n` row (2MF): its error against the same-samples exact and the
    /// reference.
    pub full_rank: Option<(usize, f64, Option<f64>)>,
    /// `k(2MF) / k(2MSC)` at equal error on the main curves.
    pub ratio: Option<analysis::KRatio>,
    /// `k(2MF) / k(2MSC by the split rule)`, when the sweep has that curve.
    pub split_ratio: Option<analysis::KRatio>,
}

pub fn summary(rows: &[Row]) -> Summary {
    let mut growth = Vec::new();
    for method in ["2mf", "2msc", "2msc-split"] {
        if let Some(key) = analysis::main_key(rows, method) {
            let c = analysis::curve(rows, key, |r| r.rel_error);
            if c.len() >= 2 {
                growth.push((method, analysis::worst_growth(&c)));
            }
        }
    }
    let full_rank = analysis::main_key(rows, "2mf").and_then(|key| {
        rows.iter()
            .find(|r| matches_key(r, key) && r.k == r.n)
            .map(|r| (r.n, r.rel_error, r.rel_error_ref))
    });
    let ratio_of = |method: &str| match (
        analysis::main_key(rows, "2mf"),
        analysis::main_key(rows, method),
    ) {
        (Some(a), Some(b)) => {
            let mf = analysis::curve(rows, a, |r| r.rel_error);
            let msc = analysis::curve(rows, b, |r| r.rel_error);
            analysis::k_ratio(&mf, &msc, 9)
        }
        _ => None,
    };
    Summary {
        growth,
        full_rank,
        ratio: ratio_of("2msc"),
        split_ratio: ratio_of("2msc-split"),
    }
}

fn matches_key(r: &Row, key: CurveKey) -> bool {
    r.method == key.method
        && r.n == key.n
        && r.samples == key.samples
        && r.precision == key.precision
}

/// The error the plots and fronts use: against the high-sample reference when there is one
/// (what a user gets, sampling error included), else against the same-samples exact solve.
pub fn user_error(r: &Row) -> f64 {
    r.rel_error_ref.unwrap_or(r.rel_error)
}

/// The markdown report: a header line per fact, the table, the fronts, the summary.
pub fn markdown(scene: &str, machine: &str, command: &str, rows: &[Row]) -> String {
    let mut s = String::new();
    let ref_samples = rows.iter().find_map(|r| r.ref_samples);
    let _ = writeln!(
        s,
        "Scene `{scene}`, measured on {machine} by `{command}`.\n"
    );
    let _ = writeln!(
        s,
        "`error` is the relative L2 error of the runtime's radiosity against the exact solve on the \
         same fine mesh with the same samples per pair (the low-rank error alone){}. Bake seconds \
         are the whole bake (mesh, visibility, form factors, operator); frame µs the median of \
         interleaved rounds of runtime frames.\n",
        match ref_samples {
            Some(s) => format!(
                "; `error ref` against an exact solve with {s} samples per pair (sampling error \
                 included)"
            ),
            None => String::new(),
        }
    );
    if let Some(noise) = rows.iter().find_map(|r| r.truth_noise) {
        let _ = writeln!(
            s,
            "`path tracer` columns: the total error (discretisation, sampling and low-rank) at the \
             points of the `--reference` file, where an independent path tracer measured the \
             radiosity: per point ‖B − B_ref‖₁ / ‖B_ref‖₁ with B the value of the element the \
             point falls in (flat), and `smooth` through the smooth reconstruction `lrr probe` \
             uses by default; median, 90th percentile and max over the points. The reference's \
             own noise: median {:.2}% relative.\n",
            100.0 * noise
        );
    }
    table(&mut s, rows);
    fronts(&mut s, rows);
    summary_text(&mut s, &summary(rows));
    s
}

fn table(s: &mut String, rows: &[Row]) {
    let truth = rows.iter().any(|r| r.truth.is_some());
    let _ = writeln!(
        s,
        "| method | n | k | samples | prec. | setting | error | error ref | bake s | form factors s | frame µs |{}",
        if truth {
            " path tracer median | p90 | max | smooth median | p90 | max |"
        } else {
            ""
        }
    );
    let _ = writeln!(
        s,
        "|---|---:|---:|---:|---|---|---:|---:|---:|---:|---:|{}",
        if truth {
            "---:|---:|---:|---:|---:|---:|"
        } else {
            ""
        }
    );
    for r in rows {
        let setting = match (r.patch_size, r.threshold) {
            (Some(p), _) => format!("patch {p:.4}"),
            (_, Some(t)) => format!("threshold {t}"),
            _ => String::new(),
        };
        let cells = |spread: Option<super::truth::Spread>| match spread {
            Some(t) => format!(
                " {:.2}% | {:.2}% | {:.1}% |",
                100.0 * t.median,
                100.0 * t.p90,
                100.0 * t.max
            ),
            None => " | | |".into(),
        };
        let truth_cells = if truth {
            cells(r.truth) + &cells(r.truth_smooth)
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {:.2e} | {} | {:.2} | {:.2} | {:.1} |{truth_cells}",
            r.method,
            r.n,
            r.k,
            r.samples,
            r.precision,
            setting,
            r.rel_error,
            r.rel_error_ref.map_or("".into(), |e| format!("{e:.2e}")),
            r.bake_s,
            r.form_factors_s,
            r.frame_s * 1e6
        );
    }
    let _ = writeln!(s);
}

fn fronts(s: &mut String, rows: &[Row]) {
    let label = if rows.iter().any(|r| r.rel_error_ref.is_some()) {
        "error ref"
    } else {
        "error"
    };
    for (what, cost) in [
        ("bake time", (|r: &Row| r.bake_s) as fn(&Row) -> f64),
        ("frame time", |r: &Row| r.frame_s),
    ] {
        let front = analysis::main_front(rows, cost, user_error);
        let n = rows.first().map_or(0, |r| r.n);
        let _ = writeln!(
            s,
            "Pareto front of {label} against {what} (fine mesh n = {n}; rows of other fine meshes \
             are compared with the exact solve on their own mesh, so their errors leave out the \
             coarser mesh's discretisation error and do not compete):\n"
        );
        for i in front {
            let r = &rows[i];
            let _ = writeln!(
                s,
                "- {} n = {} k = {} samples = {} {}: {label} {:.2e} at {}",
                r.method,
                r.n,
                r.k,
                r.samples,
                r.precision,
                user_error(r),
                if what == "bake time" {
                    format!("{:.2} s", r.bake_s)
                } else {
                    format!("{:.1} µs", r.frame_s * 1e6)
                }
            );
        }
        let _ = writeln!(s);
    }
}

fn summary_text(s: &mut String, sum: &Summary) {
    for (method, g) in &sum.growth {
        let _ = writeln!(
            s,
            "- {method}, main curve (f32): the error {} as k grows (worst ratio of neighbours {g:.3}).",
            if *g <= 1.0 {
                "never grows"
            } else {
                "grows somewhere"
            }
        );
    }
    if let Some((n, e, r)) = sum.full_rank {
        let _ = writeln!(
            s,
            "- k = n = {n} (2MF, f32): error {e:.2e} against the same-samples exact solve{}.",
            r.map_or(String::new(), |r| format!(
                ", {r:.2e} against the reference"
            ))
        );
    }
    match &sum.ratio {
        Some(r) => {
            let _ = writeln!(
                s,
                "- At equal error, 2MF needs {:.2}× the k of 2MSC (median over {} errors from \
                 {:.1e} to {:.1e}; range {:.2}–{:.2}).",
                r.median,
                r.samples.len(),
                r.samples.first().map_or(0.0, |x| x.0),
                r.samples.last().map_or(0.0, |x| x.0),
                r.min,
                r.max
            );
        }
        None => {
            let _ = writeln!(
                s,
                "- No k ratio at equal error: the sweep lacks a 2MF or a 2MSC curve, or their errors do not overlap."
            );
        }
    }
    if let Some(r) = &sum.split_ratio {
        let _ = writeln!(
            s,
            "- At equal error, 2MF needs {:.2}× the k of 2MSC by the split rule (2msc-split; \
             range {:.2}–{:.2}).",
            r.median, r.min, r.max
        );
    }
}
