//! `lrr merge PART… -o OUT.lrr`: the parts of a sharded bake into one operator file, the very
//! bytes `lrr bake` writes (docs/DISTRIBUTED.md).

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use clap::Args;

use crate::bake::{LayoutArg, PrecisionArg};
use crate::parse_bytes;
use lrr_precompute::shard::{MergeSettings, merge};
use lrr_precompute::write::Storage;

#[derive(Debug, Args)]
pub struct MergeArgs {
    /// The part files of every shard (`lrr bake SCENE --shard I/N -o PART`), in any order.
    #[arg(required = true, value_name = "PART")]
    pub parts: Vec<PathBuf>,
    /// Operator file to write (replaced atomically; nothing is written when a part is wrong).
    #[arg(short, long, value_name = "OUT.lrr")]
    pub output: PathBuf,
    /// Working memory not to exceed (bytes, or with a K/M/G/T suffix): rows are streamed in
    /// buffers that fit [default: 80% of the memory available].
    #[arg(long, value_name = "BYTES", value_parser = parse_bytes)]
    pub max_memory: Option<u64>,
    /// Storage of the n×k matrix, as for `lrr bake`.
    #[arg(long, value_enum, default_value_t = PrecisionArg::F32)]
    pub precision: PrecisionArg,
    /// Operator layout, as for `lrr bake` (plain is assembled in memory).
    #[arg(long, value_enum, default_value_t = LayoutArg::Factored)]
    pub layout: LayoutArg,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
}

pub fn run(a: &MergeArgs, out: &mut dyn Write) -> Result<()> {
    use std::io::IsTerminal;
    let start = Instant::now();
    let progress =
        lrr_precompute::progress::Progress::new(!a.quiet && std::io::stderr().is_terminal());
    let settings = MergeSettings {
        max_memory: a.max_memory,
        storage: Storage {
            precision: a.precision.into(),
            layout: a.layout.into(),
        },
    };
    let merged = merge(&a.parts, &a.output, &settings, &progress)?;
    let bytes = std::fs::metadata(&a.output).map(|m| m.len()).unwrap_or(0);
    writeln!(
        out,
        "merged {} parts → {}: n = {} elements, k = {} patches, {} channel(s), condition {:.3e}, {:.1} MB",
        merged.parts,
        a.output.display(),
        merged.n,
        merged.k,
        merged.channels,
        merged.condition,
        bytes as f64 / 1e6
    )?;
    writeln!(
        out,
        "memory: planned {:.1} MiB ({} rows per buffer), peak resident {}; time {:.2}s",
        merged.planned_bytes as f64 / (1u64 << 20) as f64,
        merged.chunk_rows,
        lrr_precompute::progress::peak_resident().map_or("unknown".to_string(), |b| format!(
            "{:.1} MiB ({b} bytes)",
            b as f64 / (1u64 << 20) as f64
        )),
        start.elapsed().as_secs_f64()
    )?;
    Ok(())
}
