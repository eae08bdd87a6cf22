//! Radiosity per named surface, from an operator file (used by `bake` and `info`).

use std::io::Write;

use anyhow::Result;
use serde::Serialize;

use lrr_precompute::write::SurfaceRanges;
use lrr_runtime::Operator;

#[derive(Debug, Clone, Serialize)]
pub struct SurfaceSummary {
    pub name: String,
    pub elements: usize,
    pub area: f64,
    /// Area-weighted mean radiosity (exitance, RGB) with the baked emission.
    pub mean_radiosity: [f64; 3],
}

/// Element areas from the file's geometry (GEOMETRY: each element's own polygon, the one its
/// form factors were computed on, not its display faces), by original id.
pub fn element_areas(op: &Operator) -> Vec<f64> {
    let g = &op.file().geometry;
    let mut areas = vec![0.0; op.n()];
    for (s, &id) in op.file().order.iter().enumerate() {
        let count = usize::from(g.vertex_count[s]);
        let v = |i: usize| -> [f64; 3] {
            let b = 12 * s + 3 * i;
            [
                f64::from(g.vertices[b]),
                f64::from(g.vertices[b + 1]),
                f64::from(g.vertices[b + 2]),
            ]
        };
        let mut sum = [0.0; 3];
        for i in 0..count {
            let (a, b) = (v(i), v((i + 1) % count));
            sum[0] += a[1] * b[2] - a[2] * b[1];
            sum[1] += a[2] * b[0] - a[0] * b[2];
            sum[2] += a[0] * b[1] - a[1] * b[0];
        }
        areas[id as usize] = 0.5 * (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
    }
    areas
}

/// The surfaces recorded in the file's metadata.
pub fn surfaces(op: &Operator) -> Vec<SurfaceRanges> {
    serde_json::from_str::<serde_json::Value>(op.metadata_json())
        .ok()
        .and_then(|v| v.get("surfaces").cloned())
        .and_then(|s| serde_json::from_value(s).ok())
        .unwrap_or_default()
}

/// Per-surface summary of a radiosity vector (original ids).
pub fn summarise(op: &Operator, radiosity: &[[f32; 3]]) -> Vec<SurfaceSummary> {
    let areas = element_areas(op);
    surfaces(op)
        .into_iter()
        .map(|s| {
            let mut area = 0.0;
            let mut sum = [0.0; 3];
            let mut count = 0;
            for r in &s.elements {
                for id in r[0]..r[1].min(op.n() as u32) {
                    let a = areas[id as usize];
                    area += a;
                    count += 1;
                    for c in 0..3 {
                        sum[c] += a * f64::from(radiosity[id as usize][c]);
                    }
                }
            }
            let mean = if area > 0.0 {
                sum.map(|x| x / area)
            } else {
                [0.0; 3]
            };
            SurfaceSummary {
                name: s.name,
                elements: count,
                area,
                mean_radiosity: mean,
            }
        })
        .collect()
}

/// The line `time: stage 1.23s, … (total 4.56s)` of a bake or a shard.
pub fn print_times(
    out: &mut dyn Write,
    progress: &lrr_precompute::progress::Progress,
    total_seconds: f64,
) -> Result<()> {
    let times: Vec<String> = progress
        .timings()
        .iter()
        .map(|(s, t)| format!("{s} {t:.2}s"))
        .collect();
    writeln!(
        out,
        "time: {} (total {total_seconds:.2}s)",
        times.join(", ")
    )?;
    Ok(())
}

/// Prints the per-surface table for the baked emission.
pub fn print_surfaces(op: &Operator, out: &mut dyn Write) -> Result<()> {
    let b = op.evaluate_baked();
    let rows = summarise(op, &b);
    writeln!(
        out,
        "{:<24} {:>8} {:>12}   mean radiosity (R, G, B)",
        "surface", "elements", "area"
    )?;
    for r in rows {
        let [red, green, blue] = r.mean_radiosity;
        writeln!(
            out,
            "{:<24} {:>8} {:>12.4e}   {red:>10.4} {green:>10.4} {blue:>10.4}",
            r.name, r.elements, r.area
        )?;
    }
    Ok(())
}

/// What import and meshing repaired or remeshed, for `lrr bake`'s summary and its report.
#[derive(Debug, Clone, Serialize)]
pub struct MeshingSummary {
    pub degenerate_dropped: usize,
    pub duplicates_dropped: usize,
    pub non_planar_split: usize,
    /// Largest vertex distance from its polygon's plane, relative to the longest edge.
    pub non_planar_max_deviation: f64,
    pub interpenetrations_imprinted: usize,
    pub merged_regions: usize,
    pub merged_faces: usize,
    pub grid_regions: usize,
    pub grid_faces: usize,
    pub grid_elements: usize,
    /// Faces whose contacts would have cut them into strips, meshed as grids (counted in
    /// `grid_elements`).
    pub sliver_faces: usize,
    /// Pieces of small faces and grid cells grouped into elements of about the element size
    /// (issue #31), and the elements they became.
    pub grouped_pieces: usize,
    pub grouped_elements: usize,
    pub min_element_angle_degrees: f64,
    pub grid_min_element_angle_degrees: f64,
    /// (stage, seconds) of the mesh stage: regions, grid, imprint, subdivide, group.
    pub stages: Vec<(String, f64)>,
    /// Elements split by `--refine` (0 without).
    pub refined_elements: usize,
}

impl MeshingSummary {
    pub fn new(
        repairs: &lrr_precompute::scene::Repairs,
        m: &lrr_precompute::mesh::MeshReport,
    ) -> Self {
        Self {
            degenerate_dropped: repairs.degenerate,
            duplicates_dropped: repairs.duplicates,
            non_planar_split: repairs.non_planar,
            non_planar_max_deviation: repairs.max_deviation,
            interpenetrations_imprinted: m.interpenetrations,
            merged_regions: m.regions.merged_groups,
            merged_faces: m.regions.merged_faces,
            grid_regions: m.regions.grid_groups,
            grid_faces: m.regions.grid_faces,
            grid_elements: m.grid_elements,
            sliver_faces: m.sliver_faces,
            grouped_pieces: m.grouped.faces,
            grouped_elements: m.grouped.elements,
            min_element_angle_degrees: m.min_angle,
            grid_min_element_angle_degrees: m.grid_min_angle,
            stages: m.stages.iter().map(|(s, t)| (s.to_string(), *t)).collect(),
            refined_elements: m.refined,
        }
    }

    /// Two lines: the geometry repaired, the meshing done (regions, angles, stage times).
    pub fn print(&self, out: &mut dyn Write) -> Result<()> {
        if self.refined_elements > 0 {
            writeln!(
                out,
                "refinement: {} element(s) split where light changes",
                self.refined_elements
            )?;
        }
        writeln!(
            out,
            "geometry: {} degenerate and {} duplicate face(s) dropped, {} non-planar polygon(s) split \
             (largest deviation {:.2}% of an edge), {} interpenetration(s) imprinted",
            self.degenerate_dropped,
            self.duplicates_dropped,
            self.non_planar_split,
            100.0 * self.non_planar_max_deviation,
            self.interpenetrations_imprinted
        )?;
        let times: Vec<String> = self
            .stages
            .iter()
            .map(|(s, t)| format!("{s} {t:.3}s"))
            .collect();
        writeln!(
            out,
            "meshing: {} region(s) of {} faces merged into one face, {} region(s) of {} faces \
             remeshed as grids ({} elements{}), {} small piece(s) grouped into {} element(s), \
             smallest element angle {:.1}°{}; {}",
            self.merged_regions,
            self.merged_faces,
            self.grid_regions,
            self.grid_faces,
            self.grid_elements,
            if self.sliver_faces > 0 {
                format!(
                    ", with {} face(s) under many contacts meshed as grids",
                    self.sliver_faces
                )
            } else {
                String::new()
            },
            self.grouped_pieces,
            self.grouped_elements,
            self.min_element_angle_degrees,
            if self.grid_elements > 0 {
                format!(" (grids {:.1}°)", self.grid_min_element_angle_degrees)
            } else {
                String::new()
            },
            times.join(", ")
        )?;
        Ok(())
    }
}
