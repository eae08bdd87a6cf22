//! What the sweep's rows say: the Pareto front of cost against error, the error curve of each
//! method over `k`, and the `k` each method needs at equal error (log-log interpolation).

use super::row::Row;

pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Indices of the points on the Pareto front of (cost, error), by increasing cost: no other
/// point costs at most as much and errs at most as much while being better in one of the two.
pub fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len()).collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// Indices of the rows on the Pareto front of (`cost`, `error`) among the rows of the main
/// fine mesh (the first row's `n`), by increasing cost. Rows of other fine meshes are left out:
/// their errors are measured against the exact solve on *their* mesh, which does not include
/// the discretisation error of a coarser mesh, so they are not comparable.
pub fn main_front(
    rows: &[Row],
    cost: impl Fn(&Row) -> f64,
    error: impl Fn(&Row) -> f64,
) -> Vec<usize> {
    let Some(n) = rows.first().map(|r| r.n) else {
        return Vec::new();
    };
    let members: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].n == n).collect();
    let points: Vec<(f64, f64)> = members
        .iter()
        .map(|&i| (cost(&rows[i]), error(&rows[i])))
        .collect();
    pareto(&points).into_iter().map(|j| members[j]).collect()
}

/// Which rows make one error curve: one method on one fine mesh, one sample count, one precision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveKey<'a> {
    pub method: &'a str,
    pub n: usize,
    pub samples: u32,
    pub precision: &'a str,
}

/// The main curves: the first row's fine mesh and samples (the plan puts the main ones first).
pub fn main_key<'a>(rows: &'a [Row], method: &'a str) -> Option<CurveKey<'a>> {
    let first = rows.first()?;
    Some(CurveKey {
        method,
        n: first.n,
        samples: first.samples,
        precision: "f32",
    })
}

/// (k, error) of the rows of a curve, by increasing k (equal k: the smaller error first).
pub fn curve(rows: &[Row], key: CurveKey, error: impl Fn(&Row) -> f64) -> Vec<(f64, f64)> {
    let mut c: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| {
            r.method == key.method
                && r.n == key.n
                && r.samples == key.samples
                && r.precision == key.precision
        })
        .map(|r| (r.k as f64, error(r)))
        .collect();
    c.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    c.dedup_by(|b, a| a.0 == b.0);
    c
}

/// Largest ratio `error(k_next) / error(k)` between neighbours of a curve: 1 or less when the
/// error never grows with `k`.
pub fn worst_growth(curve: &[(f64, f64)]) -> f64 {
    curve
        .windows(2)
        .map(|w| w[1].1 / w[0].1)
        .fold(0.0, f64::max)
}

/// The `k` at which the curve reaches `error`, interpolated linearly in log k / log error on
/// the curve's running minimum (a larger `k` can always fall back to a smaller one's error).
/// None when `error` is outside what the curve spans.
pub fn k_at_error(curve: &[(f64, f64)], error: f64) -> Option<f64> {
    let ln = |x: f64| x.max(f64::MIN_POSITIVE).ln();
    let mut envelope = Vec::with_capacity(curve.len());
    let mut best = f64::INFINITY;
    for &(k, e) in curve {
        best = best.min(e);
        envelope.push((k, best));
    }
    let i = envelope.iter().position(|&(_, e)| e <= error)?;
    if i == 0 {
        return (envelope[0].1 == error).then_some(envelope[0].0);
    }
    let ((k0, e0), (k1, e1)) = (envelope[i - 1], envelope[i]);
    let t = (ln(error) - ln(e0)) / (ln(e1) - ln(e0));
    Some((ln(k0) + t * (ln(k1) - ln(k0))).exp())
}

/// `k` of 2MF over `k` of 2MSC at equal error, over errors both curves reach.
#[derive(Debug, Clone, PartialEq)]
pub struct KRatio {
    /// (error, k of 2MF, k of 2MSC) at log-spaced errors across the common range.
    pub samples: Vec<(f64, f64, f64)>,
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

/// Compares two curves at `count` log-spaced errors inside the range both reach.
pub fn k_ratio(mf: &[(f64, f64)], msc: &[(f64, f64)], count: usize) -> Option<KRatio> {
    let lowest = |c: &[(f64, f64)]| c.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let (lo, hi) = (
        lowest(mf).max(lowest(msc)),
        mf.first()?.1.min(msc.first()?.1),
    );
    if !(lo > 0.0 && lo < hi) || count < 2 {
        return None;
    }
    let mut samples = Vec::new();
    for j in 0..count {
        let t = j as f64 / (count - 1) as f64;
        let e = (hi.ln() + t * (lo.ln() - hi.ln())).exp();
        if let (Some(a), Some(b)) = (k_at_error(mf, e), k_at_error(msc, e)) {
            samples.push((e, a, b));
        }
    }
    let ratios: Vec<f64> = samples.iter().map(|s| s.1 / s.2).collect();
    if ratios.is_empty() {
        return None;
    }
    Some(KRatio {
        median: median(ratios.clone()),
        min: ratios.iter().copied().fold(f64::INFINITY, f64::min),
        max: ratios.iter().copied().fold(0.0, f64::max),
        samples,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_keeps_only_undominated_points() {
        let p = [(1.0, 0.5), (2.0, 0.6), (2.0, 0.1), (3.0, 0.1), (0.5, 0.9)];
        assert_eq!(pareto(&p), vec![4, 0, 2]);
    }

    #[test]
    fn k_at_error_interpolates_in_log_log_and_refuses_outside() {
        // error = 1/k: exact in log-log.
        let c = [(1.0, 1.0), (10.0, 0.1), (100.0, 0.01)];
        assert!((k_at_error(&c, 0.05).unwrap() - 20.0).abs() < 1e-9);
        assert_eq!(k_at_error(&c, 1.0), Some(1.0));
        assert_eq!(k_at_error(&c, 2.0), None);
        assert_eq!(k_at_error(&c, 0.001), None);
        // A bump (k = 10 worse than k = 5) uses the running minimum.
        let bumpy = [(1.0, 1.0), (5.0, 0.2), (10.0, 0.3), (100.0, 0.01)];
        assert!((k_at_error(&bumpy, 0.2).unwrap() - 5.0).abs() < 1e-9);
        assert!(
            (k_at_error(&bumpy, 0.1).unwrap()
                - 10f64.powf(1.0 + std::f64::consts::LOG10_2 / (1.0 + std::f64::consts::LOG10_2)))
            .abs()
                < 1e-6
        );
    }

    #[test]
    fn ratio_of_two_power_laws_is_constant() {
        // 2MSC reaching every error with half the k of 2MF.
        let mf: Vec<_> = [4.0, 16.0, 64.0, 256.0]
            .iter()
            .map(|&k| (k, 1.0 / k))
            .collect();
        let msc: Vec<_> = [2.0, 8.0, 32.0, 128.0]
            .iter()
            .map(|&k| (k, 0.5 / k))
            .collect();
        let r = k_ratio(&mf, &msc, 5).unwrap();
        assert!((r.median - 2.0).abs() < 1e-9, "{r:?}");
        assert!((r.min - 2.0).abs() < 1e-9 && (r.max - 2.0).abs() < 1e-9);
        assert_eq!(r.samples.len(), 5);
    }

    #[test]
    fn worst_growth_finds_the_bump() {
        assert_eq!(worst_growth(&[(1.0, 1.0), (2.0, 0.5), (3.0, 0.6)]), 1.2);
        assert!(worst_growth(&[(1.0, 1.0), (2.0, 0.5)]) <= 1.0);
    }
}
