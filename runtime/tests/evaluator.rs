//! The evaluator's contract: errors before any write, thread counts, the read pass, snapshots.

mod common;

use common::{emission, worst_relative};
use lrr_formats::{Layout, Precision, StoredMatrix};
use lrr_runtime::testkit::{reference, synthetic};
use lrr_runtime::{Operator, Rgb, RgbMut, RuntimeError};

fn op() -> Operator {
    synthetic::operator(600, 20, 3, Precision::F32, Layout::Factored, 2).unwrap()
}

#[test]
fn bad_input_is_an_error_and_writes_nothing() {
    let op = op();
    let n = op.n();
    let mut eval = op.evaluator(2).unwrap();
    let mut out = vec![[-7.0f32; 3]; n];
    let mut e = emission(n, 1);
    e[321] = [1.0, f32::NAN, 0.0];
    let err = eval
        .evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
        .unwrap_err();
    assert!(matches!(err, RuntimeError::Input(_)), "{err}");
    assert!(
        err.to_string()
            .starts_with("emission of element 321 is [1.0, NaN, 0.0]"),
        "{err}"
    );
    e[321] = [0.0, -1.0, 0.0];
    assert!(
        eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
            .is_err()
    );
    let short = &e[..n - 1];
    let err = eval
        .evaluate(Rgb::triples(short), RgbMut::triples(&mut out))
        .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("emission: an interleaved RGB buffer"),
        "{err}"
    );
    let (mut r, mut g, mut b) = (vec![0.0; n], vec![0.0; n], vec![0.0; n - 1]);
    let err = eval
        .evaluate(
            Rgb::triples(&emission(n, 1)),
            RgbMut::Planar([&mut r, &mut g, &mut b]),
        )
        .unwrap_err();
    assert!(err.to_string().starts_with("output: each plane"), "{err}");
    let err = eval
        .evaluate_groups(&[1.0, 2.0], RgbMut::triples(&mut out))
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("one per light group expected, the file has 3"),
        "{err}"
    );
    let err = eval
        .evaluate_groups(&[1.0, -2.0, 0.0], RgbMut::triples(&mut out))
        .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("intensity of light group 1 (\"group 1\")"),
        "{err}"
    );
    assert!(out.iter().flatten().all(|&v| v == -7.0), "nothing written");
    // The evaluator still works after errors.
    let e = emission(n, 1);
    eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
        .unwrap();
    let want = reference::evaluate(op.file(), &e).unwrap();
    assert!(worst_relative(&out, &want) <= 1e-5);
}

#[test]
fn thread_counts_are_clamped_and_zero_means_all_cores() {
    let small = synthetic::operator(5, 2, 1, Precision::F32, Layout::Factored, 0).unwrap();
    assert_eq!(small.evaluator(64).unwrap().threads(), 5);
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    assert_eq!(op().evaluator(0).unwrap().threads(), cores.min(600));
}

#[test]
fn the_read_pass_reads_every_stored_word_whatever_the_threads() {
    for layout in [Layout::Factored, Layout::PlainYk] {
        for precision in [Precision::F32, Precision::F16] {
            let op = synthetic::operator(333, 21, 3, precision, layout, 5).unwrap();
            // The lanes wrap at the word size: the sum modulo 2^32 (f32) or 2^16 (f16) is the
            // same for any split.
            let (expected, modulus) = match op.file().operator.matrix() {
                StoredMatrix::F32(v) => (
                    v.iter().fold(0u64, |a, x| a + u64::from(x.to_bits())),
                    1u64 << 32,
                ),
                StoredMatrix::F16(v) => (v.iter().fold(0u64, |a, &h| a + u64::from(h)), 1 << 16),
            };
            for threads in [1, 2, 3] {
                let sum = op.evaluator(threads).unwrap().read_pass().unwrap();
                assert_eq!(
                    sum % modulus,
                    expected % modulus,
                    "{layout:?} {precision:?} {threads}"
                );
            }
            let blocks = if layout == Layout::PlainYk { 3 } else { 1 };
            assert_eq!(op.matrix_bytes(), 333 * 21 * precision.size() * blocks);
        }
    }
}

#[test]
fn evaluators_keep_the_albedo_they_were_made_with() {
    let mut op = op();
    let e = emission(op.n(), 4);
    let before = reference::evaluate(op.file(), &e).unwrap();
    let mut old = op.evaluator(2).unwrap();
    op.set_reflectance(&vec![[0.3, 0.2, 0.1]; op.n()]).unwrap();
    let after = reference::evaluate(op.file(), &e).unwrap();
    let mut out = vec![[0.0; 3]; op.n()];
    old.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
        .unwrap();
    assert!(
        worst_relative(&out, &before) <= 1e-5,
        "old evaluator, old albedo"
    );
    let mut new = op.evaluator(2).unwrap();
    new.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
        .unwrap();
    assert!(
        worst_relative(&out, &after) <= 1e-5,
        "new evaluator, new albedo"
    );
    old.set_reflectance(&op.reflectance()).unwrap();
    old.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))
        .unwrap();
    assert!(
        worst_relative(&out, &after) <= 1e-5,
        "old evaluator, edited"
    );
}

#[test]
fn dropping_an_evaluator_stops_its_threads() {
    let op = op();
    for _ in 0..50 {
        let mut eval = op.evaluator(3).unwrap();
        eval.read_pass().unwrap();
    }
}

/// A frame is the same bits at every thread count: the chunks a thread count cuts the rows into
/// do not change the order of any sum. Before, the segment sums `X = Vᵀ E` walked runs that
/// a chunk boundary cut in two, summing a patch in pieces; `lrr relight` at 2 threads then
/// differed from `lrr render` (one thread) by 1 ulp in a pixel.
#[test]
fn a_frame_is_the_same_bits_at_every_thread_count() {
    let bits = |b: &[[f32; 3]]| -> Vec<u32> { b.iter().flatten().map(|v| v.to_bits()).collect() };
    for layout in [Layout::Factored, Layout::PlainYk] {
        let op = synthetic::operator(4001, 7, 3, Precision::F32, layout, 3).unwrap();
        let mut evals: Vec<_> = [2, 3, 4, 7]
            .into_iter()
            .map(|t| op.evaluator(t).unwrap())
            .collect();
        for seed in 1..=8 {
            let e = emission(op.n(), seed);
            let mut one = vec![[0.0f32; 3]; op.n()];
            op.evaluate(&e, &mut one).unwrap();
            for eval in &mut evals {
                let mut got = vec![[0.0f32; 3]; op.n()];
                eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut got))
                    .unwrap();
                assert!(
                    bits(&got) == bits(&one),
                    "{layout:?}, emission {seed}: {} threads differ from one",
                    eval.threads()
                );
            }
        }
    }
}
