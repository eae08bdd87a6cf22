//! The operators the runtime benchmarks measure: synthetic sizes `n×k`, precisions, and the
//! bundled Cornell box baked in-process.

use anyhow::{Context, Result, bail};
use lrr_runtime::{Operator, Precision};

/// Which operators a benchmark measures.
pub struct Operators<'a> {
    /// Synthetic sizes, `n×k` each.
    pub sizes: &'a [String],
    /// `f32`, `f16`.
    pub precisions: &'a [String],
    /// Whether to bake and measure the bundled Cornell box first.
    pub cornell: bool,
}

pub(crate) fn precisions(names: &[String]) -> Result<Vec<Precision>> {
    names
        .iter()
        .map(|p| match p.as_str() {
            "f32" => Ok(Precision::F32),
            "f16" => Ok(Precision::F16),
            other => bail!("unknown precision '{other}': use f32 or f16"),
        })
        .collect()
}

pub(crate) fn parse_size(s: &str) -> Result<(usize, usize)> {
    let (n, k) = s
        .split_once('x')
        .with_context(|| format!("size '{s}' must look like 221184x216"))?;
    let n: usize = n
        .trim()
        .parse()
        .with_context(|| format!("size '{s}': n is not a number"))?;
    let k: usize = k
        .trim()
        .parse()
        .with_context(|| format!("size '{s}': k is not a number"))?;
    if k == 0 || k > n {
        bail!("size '{s}': need 1 <= k <= n");
    }
    Ok((n, k))
}

/// The bundled Cornell box, baked in-process with default settings.
pub(crate) fn cornell_operator() -> Result<Operator> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes/cornell-box/cornell-box.toml");
    let scene = lrr_precompute::scene::load(&path)?;
    let baked = lrr_precompute::bake::bake(
        &scene,
        &lrr_precompute::bake::BakeSettings::default(),
        &lrr_precompute::progress::Progress::hidden(),
    )?;
    Ok(Operator::from_file(lrr_precompute::write::operator_file(
        &baked,
    )?)?)
}

/// The same operator with F_k stored in another precision.
pub(crate) fn recast(op: &Operator, p: Precision) -> Result<Operator> {
    let mut file = op.file().clone();
    lrr_precompute::write::store_matrix_as(&mut file, p);
    Ok(Operator::from_file(file)?)
}
