//! `lrr accuracy --quick` on the Cornell box: the CSV's columns, and what its rows must show
//! (error falls with k, k = n is the exact solve, 2MSC needs fewer patches than 2MF at equal
//! error), plus the plot files.

use std::collections::HashMap;

use lrr_cli::sweep::analysis;

use crate::util::{cornell, generated_scene, lrr, root, temp_dir};

/// One CSV row by column name.
type Record = HashMap<String, String>;

fn read_csv(text: &str) -> (Vec<String>, Vec<Record>) {
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .expect("a header line")
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| {
            let fields: Vec<&str> = l.split(',').collect();
            assert_eq!(fields.len(), header.len(), "row {l}");
            header
                .iter()
                .cloned()
                .zip(fields.iter().map(|f| f.to_string()))
                .collect()
        })
        .collect();
    (header, rows)
}

fn num(r: &Record, column: &str) -> f64 {
    r[column]
        .parse()
        .unwrap_or_else(|_| panic!("{column} = '{}' is not a number", r[column]))
}

/// (k, rel_error) of one method's f32 rows, by k.
fn curve(rows: &[Record], method: &str) -> Vec<(f64, f64)> {
    let mut c: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r["method"] == method && r["precision"] == "f32")
        .map(|r| (num(r, "k"), num(r, "rel_error")))
        .collect();
    c.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    c.dedup_by(|b, a| a.0 == b.0);
    c
}

#[test]
fn quick_accuracy_sweep_on_the_cornell_box() {
    let dir = temp_dir("accuracy");
    let csv = dir.join("accuracy.csv");
    let md = dir.join("accuracy.md");
    let plot = dir.join("accuracy");
    let scene = cornell();
    let reference = root().join("tests/data/reference/cornell-box.json");
    let out = lrr(&[
        "accuracy",
        scene.to_str().unwrap(),
        "--quick",
        "--quiet",
        "--reference",
        reference.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
        "--markdown",
        md.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
    ])
    .unwrap_or_else(|e| panic!("lrr accuracy --quick failed: {e}"));
    println!("{out}");
    assert_eq!(std::fs::read_to_string(&md).unwrap(), out);

    let (header, rows) = read_csv(&std::fs::read_to_string(&csv).unwrap());
    for c in [
        "method",
        "n",
        "k",
        "samples",
        "precision",
        "rel_error",
        "bake_s",
        "frame_s",
        "rel_error_ref",
        "formfactor_s",
        "truth_median",
        "truth_p90",
        "truth_max",
        "truth_noise",
    ] {
        assert!(
            header.iter().any(|h| h == c),
            "column {c} missing: {header:?}"
        );
    }
    // One fine mesh in quick mode; every bake at f32 and f16; times measured, errors finite.
    let n = num(&rows[0], "n");
    for r in &rows {
        assert_eq!(num(r, "n"), n);
        assert!(["2mf", "2msc"].contains(&r["method"].as_str()));
        assert!(["f32", "f16"].contains(&r["precision"].as_str()));
        for c in ["bake_s", "frame_s", "formfactor_s"] {
            assert!(num(r, c) > 0.0 && num(r, c).is_finite(), "{c} of {r:?}");
        }
        assert!(num(r, "k") >= 1.0 && num(r, "k") <= n);
        assert!(num(r, "rel_error").is_finite() && num(r, "rel_error_ref").is_finite());
        let (median, p90, max) = (
            num(r, "truth_median"),
            num(r, "truth_p90"),
            num(r, "truth_max"),
        );
        assert!(num(r, "truth_noise") > 0.0 && num(r, "truth_noise") < 0.01);
        assert!(median > 0.0 && median <= p90 && p90 <= max, "{r:?}");
    }
    assert!(out.contains("path tracer median"), "{out}");
    for precision in ["f32", "f16"] {
        let count = |m: &str| {
            rows.iter()
                .filter(|r| r["method"] == m && r["precision"] == precision)
                .count()
        };
        assert!(count("2mf") >= 4 && count("2msc") >= 4, "{precision}");
    }

    // Error falls as k grows. The errors are deterministic (seeded samples), but a coarser cut
    // is not nested in a finer one for every patch size, so neighbours may swap a little:
    // allow 10%. Measured worst ratios: 2MF 0.86, 2MSC 0.85 (both never grow).
    for method in ["2mf", "2msc"] {
        let c = curve(&rows, method);
        let growth = analysis::worst_growth(&c);
        println!("{method}: (k, error) {c:?}, worst growth {growth:.3}");
        assert!(growth <= 1.10, "{method}: error grows with k: {c:?}");
        assert!(
            c.last().unwrap().1 < c.first().unwrap().1 / 2.0,
            "{method}: {c:?}"
        );
    }

    // k = n (2MF, patches = elements): F_k is F pair for pair, so the low-rank answer is the
    // exact solve up to f32 rounding (measured 3e-8); f16 storage adds its rounding (6.6e-6).
    let full: Vec<&Record> = rows
        .iter()
        .filter(|r| r["method"] == "2mf" && num(r, "k") == n)
        .collect();
    assert_eq!(full.len(), 2, "one k = n bake at f32 and f16");
    for r in full {
        let (e, bound) = if r["precision"] == "f32" {
            (num(r, "rel_error"), 1e-6)
        } else {
            (num(r, "rel_error"), 1e-4)
        };
        assert!(e < bound, "k = n, {}: error {e:e}", r["precision"]);
        // Against the 32-sample exact solve only the form-factor sampling error remains
        // (measured 1.3e-3): small, and the smallest of all 2MF f32 rows.
        let reference = num(r, "rel_error_ref");
        assert!(reference < 5e-3, "k = n vs reference: {reference:e}");
        // Against the path tracer the coarse quick mesh's discretisation error remains:
        // measured median 5.64%, p90 19.5% (f32 and f16 alike); a regression beyond 1.25×
        // fails, and the coarsest 2MF cut (k = 20: 12.3%, 47.7%) must be worse.
        let (median, p90) = (num(r, "truth_median"), num(r, "truth_p90"));
        assert!(
            median <= 1.25 * 0.0565 && p90 <= 1.25 * 0.1953,
            "k = n: {r:?}"
        );
        let coarsest = rows
            .iter()
            .filter(|c| c["method"] == "2mf" && c["precision"] == r["precision"])
            .min_by(|a, b| num(a, "k").total_cmp(&num(b, "k")))
            .unwrap();
        assert!(num(coarsest, "truth_median") > 1.5 * median, "{coarsest:?}");
    }

    // 2MSC needs fewer patches than 2MF at equal error (interpolated on the curves). The
    // issue's goal is 0.6× the k (a ratio of 1.67); on this mesh the measured median ratio
    // is 2.76 (range 1.66–2.99 over 7 errors from 6.8e-3 to 2.1e-3; 1.24 by the split rule
    // before the merge rule, docs/MESHING.md): asserted within 1.15× of that, so that a
    // change of the rule that moves it either way is seen, and above the goal.
    let ratio = analysis::k_ratio(&curve(&rows, "2mf"), &curve(&rows, "2msc"), 9)
        .expect("the 2MF and 2MSC curves overlap in error");
    println!("k(2MF)/k(2MSC) at equal error: {ratio:?}");
    let measured = 2.76;
    assert!(
        ratio.median > measured / 1.15 && ratio.median < measured * 1.15,
        "median ratio {} moved from the measured {measured}: {ratio:?}",
        ratio.median
    );
    assert!(ratio.median >= 1.0 / 0.6, "{ratio:?}");
    assert!(out.contains("At equal error, 2MF needs"), "{out}");

    // The plots: a PNG and an SVG with both methods in the legend.
    let png = std::fs::read(dir.join("accuracy.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let svg = std::fs::read_to_string(dir.join("accuracy.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("2MF") && svg.contains("2MSC"));
    assert!(svg.contains("Pareto front"));
}

/// The equal-error `k` ratio on a clustered scene (the dense sphere): pins what 2MSC achieves
/// there, so a change of the rule that moves it either way is seen. Measured median
/// k(2MF)/k(2MSC) = 3.22 (range 1.09–4.94) on the quick mesh since issue #31 groups the
/// sphere's small faces into elements of about the element size; on the former quick mesh
/// (n = 1 684, each sphere face an element) it was 2.15 (range 0.64–2.52; by the split rule
/// 0.77, docs/MESHING.md). At `--element-sizes 0.0866` (n = 1 744, about the former n) the
/// grouped mesh gives 4.51. Bisection on quantized positions (scale invariance, the same
/// session) moved it to 3.06 (range 1.11–4.73), within the 1.15× this test allows, so the
/// value is left at 3.22. Above the goal (a ratio of 1/0.6 = 1.67) either way;
/// asserted within 1.15× of the measured value.
#[test]
fn equal_error_k_ratio_on_the_dense_sphere() {
    let dir = temp_dir("accuracy-sphere");
    let scene = generated_scene(&dir, "sphere", &["dense-sphere"]);
    let csv = dir.join("sphere.csv");
    lrr(&[
        "accuracy",
        scene.to_str().unwrap(),
        "--quick",
        "--quiet",
        "--no-ref",
        "--rounds",
        "1",
        "--thresholds",
        "1e-2,3e-3,1e-3,3e-4,1e-4",
        "--csv",
        csv.to_str().unwrap(),
    ])
    .unwrap_or_else(|e| panic!("lrr accuracy --quick failed: {e}"));
    let (_, rows) = read_csv(&std::fs::read_to_string(&csv).unwrap());
    let ratio = analysis::k_ratio(&curve(&rows, "2mf"), &curve(&rows, "2msc"), 9)
        .expect("the 2MF and 2MSC curves overlap in error");
    println!("dense sphere, k(2MF)/k(2MSC) at equal error: {ratio:?}");
    let measured = 3.22;
    assert!(
        ratio.median > measured / 1.15 && ratio.median < measured * 1.15,
        "median ratio {} moved from the measured {measured}: {ratio:?}",
        ratio.median
    );
    assert!(ratio.median >= 1.0 / 0.6, "{ratio:?}");
}

#[test]
fn accuracy_refuses_bad_axes_with_the_flag_to_fix() {
    let scene = cornell();
    let e = lrr(&[
        "accuracy",
        scene.to_str().unwrap(),
        "--quick",
        "--patch-multiples",
        "0.5",
    ])
    .unwrap_err();
    assert!(e.contains("--patch-multiples"), "{e}");
    let e = lrr(&["accuracy", scene.to_str().unwrap(), "--samples", "0"]).unwrap_err();
    assert!(e.contains("--samples"), "{e}");
}

#[test]
fn accuracy_refuses_a_reference_of_another_scene() {
    let scene = cornell();
    let other = root().join("tests/data/reference/dense-sphere.json");
    let e = lrr(&[
        "accuracy",
        scene.to_str().unwrap(),
        "--quick",
        "--reference",
        other.to_str().unwrap(),
    ])
    .unwrap_err();
    assert!(
        e.contains("--reference") && e.contains("lies on no face of surface"),
        "{e}"
    );
    let e = lrr(&[
        "accuracy",
        scene.to_str().unwrap(),
        "--quick",
        "--reference",
        scene.to_str().unwrap(),
    ])
    .unwrap_err();
    assert!(
        e.contains("--reference") && e.contains("expected a file of"),
        "{e}"
    );
}
