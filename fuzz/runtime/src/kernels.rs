//! The body of the `kernels` fuzz target, shared with the replay test
//! (`tests/tests/e2e/fuzz_replay.rs` includes this file with `#[path]`).
//!
//! A frame's arithmetic runs in two kernels chosen at run time, the AVX2 one where the CPU has
//! it and a safe scalar twin: the segment sums `X = Vᵀ E` (interleaved and planar emission) and
//! the gather `W = F_k Z` (or `Y_k X`), in f32 or binary16, over blocks of rows split between
//! threads. This target feeds them operators and emissions no bake writes: a valid synthetic
//! operator (`lrr_runtime::testkit::synthetic`, every shape, layout, precision and channel
//! count, `k` past the 256-column block) with values overwritten by the fuzzer (raw bits, zero,
//! binary16 extremes, subnormals, values near `f32::MAX`), then emissions of every kind (raw
//! bits, subnormal, huge, the operator's own). It asserts:
//!
//! 1. the loader accepts or refuses the edited operator without panicking;
//! 2. every evaluator (scalar and AVX2, 1 and 2–3 threads) gives the same outcome, `Ok` or the
//!    same error, for [`Evaluator::evaluate`] and [`Evaluator::evaluate_groups`];
//! 3. where every intermediate magnitude lies in `[1e-30, 1e30]` (or is zero), so that neither
//!    f32 overflow nor subnormal rounding is in play, each radiosity value is within
//!    [`BOUND`] × its *scale* of an f64 evaluation of the same stored values
//!    (`testkit::reference`); the scale is the same expression with every term's absolute
//!    value, `|E| + |ρ| Σ_q |F_k| Σ_p |M| Σ_s |w| |E|` (plain: `|E| + Σ_q |Y_k| Σ_s |w| |E|`),
//!    which bounds the rounding of a sum whatever the signs. The kernels' own analysis gives
//!    about 2.2e-6 for the gather and 1.9e-6 for the segment sums (`runtime/src/kernel`).
//!    Values near the subnormal range get an absolute slack of `(k + 2)` times the least f32
//!    (the f32 products of a row, then the last sum, each rounded to that spacing).
//!    Group frames are held to each other (the scalar against the AVX2 one) with the same
//!    bound, their `Vᵀ E` coming from the file's stored group sums.
//!
//! Returns whether the operator loaded.

use lrr_formats::{Layout, OperatorData, OperatorFile, Precision, StoredMatrix};
use lrr_runtime::{Evaluator, Operator, Rgb, RgbMut, SimdLevel, testkit};

use super::reader::Reader;

/// The largest error allowed, relative to a value's scale (see the module docs).
pub const BOUND: f64 = 1e-5;
/// Magnitudes outside `[TINY, HUGE]` (other than zero) leave the range where the bound holds.
const TINY: f64 = 1e-30;
const HUGE: f64 = 1e30;

/// A value of one of the kinds that break arithmetic.
fn value(r: &mut Reader) -> f32 {
    let b = r.byte();
    let x = f32::from(r.byte());
    match b % 9 {
        0 => f32::from_bits(r.u32()),
        1 => 0.0,
        2 => x / 8.0,
        3 => 1e30 * (1.0 + x),
        4 => f32::from_bits(1 + u32::from(r.u16())),
        5 => 65504.0,
        6 => -x / 8.0,
        7 => f32::MAX / (1.0 + x),
        _ => 1.0 / (1.0 + x),
    }
}

/// `kernels`: see the module docs.
pub fn kernels(data: &[u8]) -> bool {
    let mut r = Reader(data);
    let shape = r.byte();
    let layout = if shape & 1 == 0 {
        Layout::Factored
    } else {
        Layout::PlainYk
    };
    let precision = if shape & 2 == 0 {
        Precision::F32
    } else {
        Precision::F16
    };
    let channels = if shape & 4 == 0 { 3 } else { 1 };
    // Plain operators are converted in O(n k²) per channel and factored ones cost an O(k³) LU:
    // sizes that keep an input within milliseconds, k past the 256-column block when asked.
    let plain = layout == Layout::PlainYk;
    let n = 1 + usize::from(r.u16()) % if plain { 200 } else { 600 };
    let wide = shape & 8 != 0 && !plain;
    let k = 1 + usize::from(r.u16()) % if wide { 270 } else { 40 }.min(n);
    let seed = u64::from(r.u32());
    let Ok(mut file) = testkit::synthetic::file(n, k, channels, precision, layout, seed) else {
        return false;
    };
    for _ in 0..r.byte() % 16 {
        edit(&mut file, &mut r);
    }
    let Ok(op) = Operator::from_file(file) else {
        return false;
    };

    let mode = r.byte();
    let threads = 2 + usize::from(mode >> 6) % 2;
    let emission = emission(&op, mode >> 2, &mut r);
    let intensities: Vec<f32> = (0..op.light_groups().len() + usize::from(mode & 32 != 0))
        .map(|_| value(&mut r))
        .collect();
    let planar_in = mode & 1 != 0;
    let planar_out = mode & 2 != 0;

    let mut levels = vec![SimdLevel::Scalar];
    if SimdLevel::Avx2.supported() {
        levels.push(SimdLevel::Avx2);
    }
    let mut frames = Vec::new();
    let mut groups = Vec::new();
    for &simd in &levels {
        for t in [1, threads] {
            let mut ev = match Evaluator::with_simd(&op, t, simd) {
                Ok(ev) => ev,
                Err(e) => panic!("no {simd:?} evaluator on {t} threads for a valid operator: {e}"),
            };
            frames.push(frame(&mut ev, &emission, planar_in, planar_out));
            let n = op.n();
            groups.push(output(n, planar_out, |out| {
                ev.evaluate_groups(&intensities, out)
            }));
        }
    }
    same_outcomes("evaluate", &frames);
    same_outcomes("evaluate_groups", &groups);

    if let (Ok(_), Some(scale)) = (&frames[0], scales(op.file(), &emission)) {
        let exact = testkit::reference::evaluate(op.file(), &emission)
            .expect("the emission has one value per element");
        for out in frames.iter().map(|f| f.as_ref().expect("same outcomes")) {
            within("evaluate against f64", op.k(), out, |i| exact[i], &scale);
        }
    }
    if let Ok(first) = &groups[0] {
        let emission = group_emission(op.file(), &intensities);
        if let Some(scale) = scales(op.file(), &emission) {
            for out in groups.iter().map(|f| f.as_ref().expect("same outcomes")) {
                within(
                    "evaluate_groups, scalar against AVX2",
                    op.k(),
                    out,
                    |i| first[i].map(f64::from),
                    &scale,
                );
            }
        }
    }
    true
}

/// Overwrites one stored value of the operator as the fuzzer says.
fn edit(file: &mut OperatorFile, r: &mut Reader<'_>) {
    let op = r.byte();
    let at = r.u32() as usize;
    match op % 6 {
        0 | 1 => {
            let m = match &mut file.operator {
                OperatorData::Factored { fk, .. } => fk,
                OperatorData::PlainYk { yk } => yk,
            };
            let row = if op % 6 == 1 { file.k as usize } else { 1 };
            let len = m.len();
            let start = at % len;
            match m {
                StoredMatrix::F32(v) => {
                    let x = value(r);
                    v[start..(start + row).min(len)].fill(x);
                }
                StoredMatrix::F16(v) => {
                    let bits = r.u16();
                    v[start..(start + row).min(len)].fill(bits);
                }
            }
        }
        2 => {
            if let OperatorData::Factored { cores, .. } = &mut file.operator {
                let len = cores.len();
                cores[at % len] = f64::from(value(r));
            }
        }
        3 => {
            let len = file.weights.len();
            file.weights[at % len] = value(r);
        }
        4 => {
            let len = file.reflectance.len();
            if len > 0 {
                file.reflectance[at % len] = value(r);
            }
        }
        _ => {
            let len = file.emission.len();
            file.emission[at % len] = value(r);
        }
    }
}

/// One RGB value per element (original ids): the operator's own, bytes read as values, or small
/// non-negative ones; the rest of the input, cycled.
fn emission(op: &Operator, mode: u8, r: &mut Reader<'_>) -> Vec<[f32; 3]> {
    let n = op.n();
    let baked = op.baked_emission();
    match mode % 4 {
        0 => baked,
        1 => (0..n).map(|_| [value(r), value(r), value(r)]).collect(),
        2 => (0..n)
            .map(|_| [r.byte(), r.byte(), r.byte()].map(|b| f32::from(b) / 16.0))
            .collect(),
        _ => {
            let s = value(r);
            baked.iter().map(|e| e.map(|v| v * s)).collect()
        }
    }
}

/// Planes of triples.
fn planes(v: &[[f32; 3]]) -> [Vec<f32>; 3] {
    std::array::from_fn(|c| v.iter().map(|e| e[c]).collect())
}

/// Writes into a fresh buffer, interleaved or planar, and returns it as triples.
fn output(
    n: usize,
    planar: bool,
    f: impl FnOnce(RgbMut<'_>) -> Result<(), lrr_runtime::RuntimeError>,
) -> Result<Vec<[f32; 3]>, String> {
    if planar {
        let [mut r, mut g, mut b] = std::array::from_fn(|_| vec![f32::NAN; n]);
        f(RgbMut::Planar([&mut r, &mut g, &mut b])).map_err(|e| e.to_string())?;
        Ok((0..n).map(|i| [r[i], g[i], b[i]]).collect())
    } else {
        let mut out = vec![[f32::NAN; 3]; n];
        f(RgbMut::triples(&mut out)).map_err(|e| e.to_string())?;
        Ok(out)
    }
}

fn frame(
    ev: &mut Evaluator,
    emission: &[[f32; 3]],
    planar_in: bool,
    planar_out: bool,
) -> Result<Vec<[f32; 3]>, String> {
    let n = emission.len();
    if planar_in {
        let [r, g, b] = planes(emission);
        output(n, planar_out, |out| {
            ev.evaluate(Rgb::Planar([&r, &g, &b]), out)
        })
    } else {
        output(n, planar_out, |out| {
            ev.evaluate(Rgb::triples(emission), out)
        })
    }
}

/// Every evaluator accepted, or every one refused with the same message.
fn same_outcomes(what: &str, outcomes: &[Result<Vec<[f32; 3]>, String>]) {
    let first = outcomes[0].as_ref().err();
    for (i, o) in outcomes.iter().enumerate() {
        assert_eq!(
            o.as_ref().err(),
            first,
            "{what}: evaluator {i} (scalar 1, scalar N, AVX2 1, AVX2 N) disagrees with the first"
        );
    }
}

/// `|out − expected| ≤ BOUND · scale + slack` for every value, `slack` = `(k + 2)` times the
/// least positive f32.
fn within(
    what: &str,
    k: usize,
    out: &[[f32; 3]],
    expected: impl Fn(usize) -> [f64; 3],
    scale: &[[f64; 3]],
) {
    let slack = (k as f64 + 2.0) * f64::from(f32::from_bits(1));
    for (i, (o, s)) in out.iter().zip(scale).enumerate() {
        let e = expected(i);
        for c in 0..3 {
            let err = (f64::from(o[c]) - e[c]).abs();
            assert!(
                err <= BOUND * s[c] + slack,
                "{what}: element {i} channel {c}: {} against {}, error {err:e} above {BOUND:e} × \
                 scale {:e} + {slack:e}",
                o[c],
                e[c],
                s[c]
            );
        }
    }
}

/// `E = Σ_g a_g E_g` (original ids).
fn group_emission(file: &OperatorFile, intensities: &[f32]) -> Vec<[f32; 3]> {
    let mut e = vec![[0.0f64; 3]; file.n as usize];
    for (g, &a) in file.lights.iter().zip(intensities) {
        for (j, &s) in g.positions.iter().enumerate() {
            let id = file.order[s as usize] as usize;
            for (v, &ge) in e[id].iter_mut().zip(&g.emission[3 * j..3 * j + 3]) {
                *v += f64::from(a) * f64::from(ge);
            }
        }
    }
    e.iter().map(|v| v.map(|x| x as f32)).collect()
}

/// The scale of every value (module docs), or `None` when a magnitude leaves `[TINY, HUGE]`.
fn scales(file: &OperatorFile, emission: &[[f32; 3]]) -> Option<Vec<[f64; 3]>> {
    let (n, k) = (file.n as usize, file.k as usize);
    let in_range = |v: f64| v == 0.0 || (TINY..=HUGE).contains(&v);
    let abs_e = |id: usize, c: usize| f64::from(emission[id][c]).abs();
    let mut x = vec![[0.0f64; 3]; k];
    for (p, xp) in x.iter_mut().enumerate() {
        for s in file.index[p] as usize..file.index[p + 1] as usize {
            let id = file.order[s] as usize;
            for (c, v) in xp.iter_mut().enumerate() {
                *v += f64::from(file.weights[s]).abs() * abs_e(id, c);
            }
        }
    }
    if !x.iter().flatten().all(|&v| in_range(v)) {
        return None;
    }
    let get = |m: &StoredMatrix, i: usize| f64::from(m.get(i).unwrap_or(f32::NAN)).abs();
    let block = |c: usize| if file.channels == 1 { 0 } else { c };
    let mut scale = vec![[0.0f64; 3]; n];
    match &file.operator {
        OperatorData::Factored { fk, cores } => {
            let mut z = vec![[0.0f64; 3]; k];
            for (q, zq) in z.iter_mut().enumerate() {
                for (c, v) in zq.iter_mut().enumerate() {
                    let m = &cores[block(c) * k * k..];
                    *v = (0..k).map(|p| m[q * k + p].abs() * x[p][c]).sum();
                }
            }
            if !z.iter().flatten().all(|&v| in_range(v)) {
                return None;
            }
            for (s, &id) in file.order.iter().enumerate() {
                for c in 0..3 {
                    let w: f64 = (0..k).map(|q| get(fk, s * k + q) * z[q][c]).sum();
                    let rho = f64::from(file.reflectance[3 * s + c]).abs();
                    scale[id as usize][c] = abs_e(id as usize, c) + rho * w;
                }
            }
        }
        OperatorData::PlainYk { yk } => {
            for (s, &id) in file.order.iter().enumerate() {
                for c in 0..3 {
                    let row = (block(c) * n + s) * k;
                    let w: f64 = (0..k).map(|q| get(yk, row + q) * x[q][c]).sum();
                    scale[id as usize][c] = abs_e(id as usize, c) + w;
                }
            }
        }
    }
    scale
        .iter()
        .flatten()
        .all(|&v| v.is_finite() && v <= HUGE)
        .then_some(scale)
}
