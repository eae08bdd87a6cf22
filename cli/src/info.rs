//! `lrr info`.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use lrr_formats::Precision;
use lrr_runtime::Operator;

use crate::summary;

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Operator file.
    pub file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: &InfoArgs, out: &mut dyn Write) -> Result<()> {
    let bytes = std::fs::read(&a.file).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let op =
        Operator::from_bytes(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let f = op.file();
    let layout = match op.layout() {
        lrr_formats::Layout::Factored => "factored",
        lrr_formats::Layout::PlainYk => "plain",
    };
    let precision = match f.precision {
        Precision::F32 => "f32",
        Precision::F16 => "f16",
    };
    let metadata: serde_json::Value =
        serde_json::from_str(op.metadata_json()).unwrap_or(serde_json::Value::Null);
    let radiosity = op.evaluate_baked();
    let surfaces = summary::summarise(&op, &radiosity);
    if a.json {
        let v = serde_json::json!({
            "file": a.file.display().to_string(),
            "bytes": bytes.len(),
            "n": op.n(),
            "k": op.k(),
            "channels": op.channels(),
            "precision": precision,
            "layout": layout,
            "light_groups": op.light_groups().collect::<Vec<_>>(),
            "metadata": metadata,
            "surfaces": surfaces,
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    writeln!(out, "{}: {} bytes", a.file.display(), bytes.len())?;
    writeln!(
        out,
        "n = {} elements, k = {} patches, {} channel(s), {layout} layout in {precision}",
        op.n(),
        op.k(),
        op.channels()
    )?;
    if let serde_json::Value::Object(m) = &metadata {
        for key in [
            "generator",
            "scene",
            "method",
            "threshold",
            "min_patch_area",
            "element_size",
            "patch_size",
            "samples",
            "visibility",
            "condition",
        ] {
            if let Some(v) = m.get(key) {
                writeln!(out, "{key}: {v}")?;
            }
        }
    }
    summary::print_surfaces(&op, out)
}
