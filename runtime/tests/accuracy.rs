//! The fast paths against a straightforward f64 evaluation of the same file: every layout,
//! precision, channel count, thread count and buffer form.

mod common;

use common::{emission, to_f16, worst_relative};
use lrr_formats::{Layout, OperatorFile, Precision};
use lrr_runtime::testkit::baseline::DenseV;
use lrr_runtime::testkit::{reference, synthetic};
use lrr_runtime::{Evaluator, Operator, Rgb, RgbMut, SimdLevel};

/// The bound the crate documents for f32 storage (tests demand it with margin: 1e-5).
const F32_BOUND: f64 = 1e-5;

/// Evaluates with every input and output form and checks each against `want`.
fn check_forms(eval: &mut Evaluator, e: &[[f32; 3]], want: &[[f64; 3]], bound: f64, what: &str) {
    let n = e.len();
    let planes: [Vec<f32>; 3] = std::array::from_fn(|c| e.iter().map(|v| v[c]).collect());
    for planar_in in [false, true] {
        for planar_out in [false, true] {
            let input = if planar_in {
                Rgb::Planar(planes.each_ref().map(|p| &p[..]))
            } else {
                Rgb::triples(e)
            };
            let mut got = vec![[f32::NAN; 3]; n];
            if planar_out {
                let mut out: [Vec<f32>; 3] = std::array::from_fn(|_| vec![f32::NAN; n]);
                let [r, g, b] = &mut out;
                eval.evaluate(input, RgbMut::Planar([r, g, b])).unwrap();
                for (i, v) in got.iter_mut().enumerate() {
                    *v = [out[0][i], out[1][i], out[2][i]];
                }
            } else {
                eval.evaluate(input, RgbMut::triples(&mut got)).unwrap();
            }
            let worst = worst_relative(&got, want);
            assert!(
                worst <= bound,
                "{what}, planar in {planar_in}, out {planar_out}: relative error {worst:e}"
            );
        }
    }
}

/// `file` with its original ids shuffled: every run of consecutive ids has length 1.
fn shuffled(mut file: OperatorFile) -> OperatorFile {
    let n = file.order.len();
    let mut perm: Vec<u32> = (0..n as u32).collect();
    let mut s = 0x9E37_79B9_u64;
    for i in (1..n).rev() {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        perm.swap(i, (s >> 33) as usize % (i + 1));
    }
    file.order
        .iter_mut()
        .for_each(|id| *id = perm[*id as usize]);
    file
}

fn files() -> Vec<(String, OperatorFile)> {
    let mut files = Vec::new();
    for layout in [Layout::Factored, Layout::PlainYk] {
        let file = synthetic::file(1999, 33, 3, Precision::F32, layout, 9).unwrap();
        files.push((format!("shuffled ids {layout:?}"), shuffled(file)));
    }
    // n and k that are not multiples of 8 (tail paths); k > 256 (several f64 blocks).
    for (n, k) in [(2003, 45), (301, 300)] {
        for layout in [Layout::Factored, Layout::PlainYk] {
            for channels in [1, 3] {
                for precision in [Precision::F32, Precision::F16] {
                    let file = synthetic::file(n, k, channels, precision, layout, 5).unwrap();
                    let name = format!("n {n} k {k} {layout:?} {precision:?} channels {channels}");
                    files.push((name, file));
                }
            }
        }
    }
    files
}

#[test]
fn every_layout_precision_thread_count_and_form_matches_f64() {
    for (name, file) in files() {
        let op = Operator::from_file(file).unwrap();
        let e = emission(op.n(), 3);
        let want = reference::evaluate(op.file(), &e).unwrap();
        for threads in [1, 2, 3] {
            let levels = [SimdLevel::Avx2, SimdLevel::Scalar];
            for simd in levels.into_iter().filter(|b| b.supported()) {
                let mut eval = Evaluator::with_simd(&op, threads, simd).unwrap();
                assert_eq!(eval.threads(), threads);
                let what = format!("{name}, {threads} threads, {simd:?}");
                check_forms(&mut eval, &e, &want, F32_BOUND, &what);
            }
        }
        // The one-call form agrees too.
        let mut got = vec![[0.0; 3]; op.n()];
        op.evaluate(&e, &mut got).unwrap();
        assert!(
            worst_relative(&got, &want) <= F32_BOUND,
            "{name}: Operator::evaluate"
        );
    }
}

#[test]
fn f16_storage_stays_within_the_documented_bound() {
    // Rounding F_k to binary16 changes each entry by at most 2^-11 relative (the synthetic
    // entries are normal binary16 numbers, above 2^-14), so ρ W, and with it B, moves by at most
    // 2^-11 relative; plus the f32 evaluation error.
    let bound = 2f64.powi(-11) + F32_BOUND;
    for layout in [Layout::Factored, Layout::PlainYk] {
        let file = synthetic::file(1500, 37, 3, Precision::F32, layout, 11).unwrap();
        let e = emission(1500, 8);
        let want = reference::evaluate(&file, &e).unwrap();
        let op = Operator::from_file(to_f16(&file)).unwrap();
        let mut got = vec![[0.0; 3]; op.n()];
        op.evaluator(2)
            .unwrap()
            .evaluate(Rgb::triples(&e), RgbMut::triples(&mut got))
            .unwrap();
        let worst = worst_relative(&got, &want);
        assert!(worst <= bound, "{layout:?}: {worst:e} > {bound:e}");
        eprintln!("f16 {layout:?}: worst relative error {worst:.2e} (bound {bound:.2e})");
    }
}

#[test]
fn groups_equal_the_per_element_emission_they_stand_for() {
    for layout in [Layout::Factored, Layout::PlainYk] {
        let op = synthetic::operator(2000, 30, 3, Precision::F16, layout, 21).unwrap();
        let file = op.file();
        assert_eq!(
            op.light_groups().collect::<Vec<_>>(),
            ["group 0", "group 1", "group 2"]
        );
        assert_eq!(op.light_group("group 1"), Some(1));
        let a = [0.5f32, 0.0, 3.0];
        let mut e = vec![[0.0f32; 3]; op.n()];
        for (g, &a) in file.lights.iter().zip(&a) {
            for (&s, v) in g.positions.iter().zip(g.emission.chunks_exact(3)) {
                let id = file.order[s as usize] as usize;
                for c in 0..3 {
                    e[id][c] += a * v[c];
                }
            }
        }
        let want = reference::evaluate(file, &e).unwrap();
        for threads in [1, 3] {
            let mut eval = op.evaluator(threads).unwrap();
            let mut by_groups = vec![[0.0; 3]; op.n()];
            eval.evaluate_groups(&a, RgbMut::triples(&mut by_groups))
                .unwrap();
            let worst = worst_relative(&by_groups, &want);
            assert!(worst <= F32_BOUND, "{layout:?} {threads}: {worst:e}");
            let mut per_element = vec![[0.0; 3]; op.n()];
            eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut per_element))
                .unwrap();
            assert!(worst_relative(&per_element, &want) <= F32_BOUND);
        }
    }
}

#[test]
fn dense_v_baseline_matches() {
    for (layout, channels) in [(Layout::Factored, 3), (Layout::PlainYk, 1)] {
        // 1001 rows: chunks of 2 and 3 threads end off the kernels' row blocks.
        let op = synthetic::operator(1001, 19, channels, Precision::F32, layout, 4).unwrap();
        let e = emission(op.n(), 6);
        let want = reference::evaluate(op.file(), &e).unwrap();
        for threads in [1, 2, 3] {
            let mut dense = DenseV::new(&op, threads).unwrap();
            assert_eq!(dense.bytes_per_frame(), 4 * 1001 * 19 * (1 + channels));
            let mut got = vec![[0.0; 3]; op.n()];
            // Twice: the second frame reuses every buffer of the first.
            for _ in 0..2 {
                dense
                    .evaluate(Rgb::triples(&e), RgbMut::triples(&mut got))
                    .unwrap();
                // Y_k is rounded to f32 once more than the factored path's F_k.
                let worst = worst_relative(&got, &want);
                assert!(worst <= F32_BOUND, "{layout:?} {threads}: {worst:e}");
            }
        }
    }
}

#[test]
fn dense_v_baseline_in_f16_stays_within_two_roundings() {
    // V_k and Y_k in binary16: each weight and each Y_k entry within 2^-11 relative, so W
    // within about 2^-10 relative (non-negative terms); plus the f32 evaluation error.
    let bound = 2f64.powi(-10) + F32_BOUND;
    let file = synthetic::file(1500, 37, 3, Precision::F32, Layout::Factored, 11).unwrap();
    let e = emission(1500, 8);
    let want = reference::evaluate(&file, &e).unwrap();
    let op = Operator::from_file(to_f16(&file)).unwrap();
    let mut dense = DenseV::new(&op, 2).unwrap();
    assert_eq!(dense.bytes_per_frame(), 2 * 1500 * 37 * 4);
    let mut got = vec![[0.0; 3]; op.n()];
    dense
        .evaluate(Rgb::triples(&e), RgbMut::triples(&mut got))
        .unwrap();
    let worst = worst_relative(&got, &want);
    eprintln!("dense V in f16: worst relative error {worst:.2e} (bound {bound:.2e})");
    assert!(worst <= bound, "{worst:e}");
}

#[test]
fn dense_v_baseline_refuses_bad_emission_and_writes_nothing() {
    let op = synthetic::operator(300, 9, 3, Precision::F32, Layout::Factored, 2).unwrap();
    let mut dense = DenseV::new(&op, 2).unwrap();
    let mut e = emission(op.n(), 3);
    e[123][1] = f32::NAN;
    let mut out = vec![[7.0f32; 3]; op.n()];
    let err = dense
        .evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
        .unwrap_err();
    assert!(err.to_string().contains("element 123"), "{err}");
    assert!(out.iter().all(|b| *b == [7.0; 3]));
}

#[test]
fn a_million_elements_keep_f32_storage_within_1e_5_of_f64() {
    // Segment sums over ~31000 elements per patch and 10⁶ rows: the f64 sums and the blocked
    // f32 lanes keep the error at the level of a few roundings.
    let op = synthetic::operator(1_000_000, 32, 3, Precision::F32, Layout::Factored, 77).unwrap();
    let e = emission(op.n(), 99);
    let want = reference::evaluate(op.file(), &e).unwrap();
    let mut got = vec![[0.0; 3]; op.n()];
    op.evaluator(2)
        .unwrap()
        .evaluate(Rgb::triples(&e), RgbMut::triples(&mut got))
        .unwrap();
    let worst = worst_relative(&got, &want);
    eprintln!("n = 10^6: worst relative error {worst:.2e}");
    assert!(worst <= F32_BOUND, "{worst:e}");
}
