//! Albedo edits: new cores from new reflectance, checked against cores computed independently
//! (dense V, dense products, Gauss–Jordan elimination) and against the original operator.

mod common;

use common::{emission, worst_relative};
use lrr_formats::{Geometry, Layout, OperatorData, OperatorFile, Precision, StoredMatrix};
use lrr_runtime::testkit::{reference, synthetic};
use lrr_runtime::{Operator, Rgb, RgbMut, RuntimeError};

/// `(I - Vᵀ diag(ρ_c) F_k)⁻¹` the long way: dense V, dense products, Gauss–Jordan with full
/// pivoting. `rho` in file order.
fn cores_independently(file: &OperatorFile, rho: &[f32], channels: usize) -> Vec<f64> {
    let (n, k) = (file.n as usize, file.k as usize);
    let OperatorData::Factored { fk, .. } = &file.operator else {
        unreachable!()
    };
    let mut v = vec![0.0f64; n * k];
    for p in 0..k {
        for s in file.index[p] as usize..file.index[p + 1] as usize {
            v[s * k + p] = f64::from(file.weights[s]);
        }
    }
    let mut cores = Vec::new();
    for c in 0..channels {
        let mut a = vec![0.0f64; k * k];
        for p in 0..k {
            for q in 0..k {
                let vu: f64 = (0..n)
                    .map(|s| {
                        let u = f64::from(rho[3 * s + c]) * f64::from(fk.get(s * k + q).unwrap());
                        v[s * k + p] * u
                    })
                    .sum();
                a[p * k + q] = f64::from(u8::from(p == q)) - vu;
            }
        }
        cores.extend(gauss_jordan(a, k));
    }
    cores
}

fn gauss_jordan(mut a: Vec<f64>, k: usize) -> Vec<f64> {
    let mut inv: Vec<f64> = (0..k * k)
        .map(|i| f64::from(u8::from(i % (k + 1) == 0)))
        .collect();
    let (mut rows, mut cols): (Vec<usize>, Vec<usize>) = ((0..k).collect(), (0..k).collect());
    for step in 0..k {
        // Full pivoting over the remaining block.
        let (mut bi, mut bj) = (step, step);
        for i in step..k {
            for j in step..k {
                if a[rows[i] * k + cols[j]].abs() > a[rows[bi] * k + cols[bj]].abs() {
                    (bi, bj) = (i, j);
                }
            }
        }
        rows.swap(step, bi);
        cols.swap(step, bj);
        let (r, c) = (rows[step], cols[step]);
        let d = a[r * k + c];
        for j in 0..k {
            a[r * k + j] /= d;
            inv[r * k + j] /= d;
        }
        for i in (0..k).filter(|&i| i != r) {
            let f = a[i * k + c];
            for j in 0..k {
                a[i * k + j] -= f * a[r * k + j];
                inv[i * k + j] -= f * inv[r * k + j];
            }
        }
    }
    // Row r of `inv` now belongs to unknown cols[position of r]: undo the permutations.
    let mut out = vec![0.0; k * k];
    for step in 0..k {
        let (r, c) = (rows[step], cols[step]);
        out[c * k..(c + 1) * k].copy_from_slice(&inv[r * k..(r + 1) * k]);
    }
    out
}

/// A coloured reflectance per original element id, different from the synthetic one.
fn new_rho(n: usize) -> Vec<[f32; 3]> {
    (0..n)
        .map(|i| [0.2 + (i % 7) as f32 / 10.0, 0.85, (i % 3) as f32 / 4.0])
        .collect()
}

#[test]
fn edited_cores_equal_independent_f64_cores() {
    for precision in [Precision::F32, Precision::F16] {
        let mut op = synthetic::operator(400, 17, 1, precision, Layout::Factored, 3).unwrap();
        let original = op.clone();
        let rho = new_rho(op.n());
        let mut eval = op.evaluator(2).unwrap();
        eval.set_reflectance(&rho).unwrap();
        op.set_reflectance(&rho).unwrap();
        assert_eq!(op.channels(), 3, "coloured reflectance needs three cores");
        assert_eq!(op.reflectance(), rho);
        // The expected file: same F_k, independently computed cores.
        let mut expected = op.file().clone();
        let cores = cores_independently(&expected, &expected.reflectance, 3);
        let OperatorData::Factored { cores: edited, .. } = &op.file().operator else {
            unreachable!()
        };
        for (a, b) in edited.iter().zip(&cores) {
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{a} vs {b}");
        }
        if let OperatorData::Factored { cores: c, .. } = &mut expected.operator {
            *c = cores;
        }
        let e = emission(op.n(), 2);
        let want = reference::evaluate(&expected, &e).unwrap();
        let mut got = vec![[0.0; 3]; op.n()];
        eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut got))
            .unwrap();
        assert!(
            worst_relative(&got, &want) <= 1e-5,
            "evaluator after the edit"
        );
        op.evaluate(&e, &mut got).unwrap();
        assert!(
            worst_relative(&got, &want) <= 1e-5,
            "operator after the edit"
        );
        // The clone made before the edit kept the old albedo; setting it back restores it.
        op.set_reflectance(&original.reflectance()).unwrap();
        assert_eq!(op.channels(), 1);
        let before = reference::evaluate(original.file(), &e).unwrap();
        op.evaluate(&e, &mut got).unwrap();
        assert!(
            worst_relative(&got, &before) <= 1e-5,
            "original albedo set back"
        );
        assert_eq!(op.file().operator, original.file().operator);
    }
}

#[test]
fn bad_edits_are_refused_and_change_nothing() {
    let mut op = synthetic::operator(50, 5, 3, Precision::F32, Layout::Factored, 8).unwrap();
    let before = op.file().clone();
    let n = op.n();
    let mut rho = vec![[0.5f32; 3]; n];
    rho[7] = [0.5, 1.0, 0.5];
    let e = op.set_reflectance(&rho).unwrap_err();
    assert!(matches!(e, RuntimeError::Input(_)), "{e}");
    assert!(
        e.to_string()
            .starts_with("reflectance of element 7 is [0.5, 1.0, 0.5]"),
        "{e}"
    );
    rho[7] = [f32::NAN; 3];
    assert!(op.set_reflectance(&rho).is_err());
    let e = op.set_reflectance(&rho[1..]).unwrap_err();
    assert!(e.to_string().contains("n = 50"), "{e}");
    assert_eq!(op.file(), &before);
    let mut plain = synthetic::operator(50, 5, 3, Precision::F32, Layout::PlainYk, 8).unwrap();
    let e = plain.set_reflectance(&vec![[0.5; 3]; n]).unwrap_err();
    assert!(matches!(e, RuntimeError::Input(_)), "{e}");
    assert!(e.to_string().contains("factored layout"), "{e}");
    let e = plain
        .evaluator(1)
        .unwrap()
        .set_reflectance(&vec![[0.5; 3]; n]);
    assert!(matches!(e, Err(RuntimeError::Input(_))));
}

/// Element 0 alone in patch 0 and seeing nothing; elements 1 and 2 in patch 1 (w = 0.5 each)
/// with form factors `f` to patch 1. So `A = diag(1, 1 - Σ w ρ F)`, condition `1 / A₁₁`.
fn two_patches(f: [f32; 2]) -> Operator {
    let square = |x: f32| {
        [
            x,
            0.0,
            0.0,
            x + 1.0,
            0.0,
            0.0,
            x + 1.0,
            1.0,
            0.0,
            x,
            1.0,
            0.0,
        ]
    };
    let file = OperatorFile {
        metadata_json: "{}".into(),
        n: 3,
        k: 2,
        channels: 1,
        precision: Precision::F32,
        order: vec![0, 1, 2],
        index: vec![0, 1, 3],
        weights: vec![1.0, 0.5, 0.5],
        operator: OperatorData::Factored {
            fk: StoredMatrix::F32(vec![0.0, 0.0, 0.0, f[0], 0.0, f[1]]),
            cores: vec![1.0, 0.0, 0.0, 1.0],
        },
        reflectance: vec![0.0; 9],
        emission: vec![0.0; 9],
        geometry: Geometry {
            vertex_count: vec![4; 3],
            vertices: [square(0.0), square(1.0), square(2.0)].concat(),
            normals: [0.0, 0.0, 1.0].repeat(3),
        },
        lights: Vec::new(),
        display: Default::default(),
    };
    Operator::from_file(file).unwrap()
}

#[test]
fn singular_systems_are_refused_with_their_condition() {
    // A₁₁ = 1 - 0.5·0.5·2 - 0.5·0.5·2 = 0: exactly singular.
    let mut op = two_patches([2.0, 2.0]);
    let e = op.set_reflectance(&[[0.5; 3]; 3]).unwrap_err();
    assert!(matches!(e, RuntimeError::Input(_)), "{e}");
    assert!(e.to_string().contains("exactly singular"), "{e}");
    // A₁₁ = 1 - 0.5 - 0.5 (1 - 2⁻²⁰)(1 + 2⁻²⁰) = 2⁻⁴¹: condition 2.2e12.
    let t = 2f32.powi(-20);
    let mut op = two_patches([2.0, 1.0 + t]);
    let e = op
        .set_reflectance(&[[0.5; 3], [0.5; 3], [1.0 - t; 3]])
        .unwrap_err();
    assert!(matches!(e, RuntimeError::Input(_)), "{e}");
    assert!(
        e.to_string().contains("condition number 2.199e12 > 1e12"),
        "{e}"
    );
    // Less reflective: accepted, and evaluates without NaNs.
    op.set_reflectance(&[[0.5; 3], [0.5; 3], [0.25; 3]])
        .unwrap();
    let mut out = [[0.0; 3]; 3];
    op.evaluate(&[[1.0; 3], [1.0; 3], [0.0; 3]], &mut out)
        .unwrap();
    assert!(
        out.iter().flatten().all(|v| v.is_finite() && *v > 0.0),
        "{out:?}"
    );
}
