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
            "display": display_json(f),
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
    writeln!(out, "display: {}", display_line(f))?;
    if let serde_json::Value::Object(m) = &metadata {
        for key in [
            "generator",
            "scene",
            "method",
            "threshold",
            "min_patch_area",
            "refine",
            "refined_elements",
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

/// What the file holds for display (format 1.2 to 1.4 sections), as JSON; `faces`: the number
/// of display faces when the file has section FACES (elements drawn as other polygons than
/// their GEOMETRY), else null.
fn display_json(f: &lrr_formats::OperatorFile) -> serde_json::Value {
    let d = &f.display;
    serde_json::json!({
        "smooth_vertices": d.smooth.as_ref().map(|s| s.vertex_count()),
        "materials": d.materials.as_ref().map(|m| m.materials.len()),
        "point_lights": d.point_lights.iter().map(|l| l.name.as_str()).collect::<Vec<_>>(),
        "sky_transfer": d.sky_transfer.is_some(),
        "direct_lights": d.direct_lights.iter().map(|l| serde_json::json!({
            "name": l.name,
            "kind": kind_name(l.kind),
        })).collect::<Vec<_>>(),
        "cameras": d.cameras.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(),
        "bvh_nodes": d.bvh.as_ref().map(|b| b.nodes.len()),
        "lightmap_uv": d.lightmap.is_some(),
        "lightmap_atlas": d.lightmap.as_ref().and_then(|l| l.atlas).map(|a| serde_json::json!({
            "width": a.width,
            "height": a.height,
            "padding": a.padding,
            "source": match a.source {
                lrr_formats::LightmapSource::Scene => "scene",
                lrr_formats::LightmapSource::Generated => "generated",
            },
            "density": a.density,
        })),
        "faces": d.faces.as_ref().map(|faces| faces.element.len()),
    })
}

/// The same in one line: which sections are there and what a command needs them for.
fn display_line(f: &lrr_formats::OperatorFile) -> String {
    let d = &f.display;
    let mut parts = Vec::new();
    if let Some(s) = &d.smooth {
        parts.push(format!("smooth weights ({} vertices)", s.vertex_count()));
    }
    if let Some(m) = &d.materials {
        parts.push(format!("{} materials", m.materials.len()));
    }
    for kind in [
        lrr_formats::DirectLightKind::Spot,
        lrr_formats::DirectLightKind::Directional,
        lrr_formats::DirectLightKind::UniformSky,
        lrr_formats::DirectLightKind::GradientSky,
    ] {
        let count = d.direct_lights.iter().filter(|l| l.kind == kind).count();
        if count > 0 {
            parts.push(format!("{count} {}", kind_name(kind)));
        }
    }
    if d.sky_transfer.is_some() {
        parts.push("the sky's transfer per element".to_string());
    }
    if !d.point_lights.is_empty() {
        parts.push(format!("{} point light(s)", d.point_lights.len()));
    }
    if !d.cameras.is_empty() {
        let names: Vec<&str> = d.cameras.iter().map(|c| c.name.as_str()).collect();
        parts.push(format!("cameras {}", names.join(", ")));
    }
    if let Some(b) = &d.bvh {
        parts.push(format!("BVH ({} nodes; lrr render)", b.nodes.len()));
    }
    if let Some(l) = &d.lightmap {
        parts.push(match l.atlas {
            Some(a) => match a.source {
                lrr_formats::LightmapSource::Scene => format!(
                    "the scene's lightmap coordinates in a {}×{} atlas, padding {} (lrr export)",
                    a.width, a.height, a.padding
                ),
                lrr_formats::LightmapSource::Generated => format!(
                    "a {}×{} lightmap atlas of generated charts, {:.4} texels per unit, padding \
                     {} (lrr export)",
                    a.width, a.height, a.density, a.padding
                ),
            },
            None => "the scene's lightmap coordinates (lrr export --uv scene)".into(),
        });
    }
    if let Some(faces) = &d.faces {
        parts.push(format!(
            "{} display faces for the {} elements (format 1.4)",
            faces.element.len(),
            f.n
        ));
    }
    if parts.is_empty() {
        "none (a file of format 1.1: lrr render and smooth exports need a re-bake)".into()
    } else {
        parts.join(", ")
    }
}

/// What `lrr info` calls a kind of light.
fn kind_name(kind: lrr_formats::DirectLightKind) -> &'static str {
    match kind {
        lrr_formats::DirectLightKind::Spot => "spot light(s)",
        lrr_formats::DirectLightKind::Directional => "directional light(s)",
        lrr_formats::DirectLightKind::UniformSky => "uniform sky",
        lrr_formats::DirectLightKind::GradientSky => "gradient sky",
    }
}
