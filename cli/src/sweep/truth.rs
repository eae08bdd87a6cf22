//! The total error against an independent path tracer (`lrr accuracy --reference FILE`).
//!
//! `FILE` holds points on every surface of the scene with the radiosity an unbiased path
//! tracer measured there and its standard error (`tests/data/reference/*.json`, made by
//! `scripts/reference/run.py`). A bake is evaluated at each point twice: flat, the value of the
//! element the point falls in ([`Operator::locate`]), and smooth, through the file's smooth
//! reconstruction ([`Reconstruction`], `lrr probe`'s default). Error of
//! a point: `‖B − B_ref‖₁ / ‖B_ref‖₁` over the channels; a row gets the median, 90th percentile
//! and max over the points. Unlike the errors against the exact solve, this one includes the
//! fine mesh's discretisation error, so rows of different `n` compare. The reference's own
//! noise is the same ratio for its standard error.

use std::path::Path;

use lrr_precompute::error::{Error, Result};
use lrr_precompute::scene::Scene;
use lrr_runtime::{Operator, Reconstruction};
use serde::Deserialize;

/// The part of a reference file the sweep reads (other fields are ignored).
#[derive(Debug, Deserialize)]
struct File {
    points: Vec<Point>,
}

#[derive(Debug, Deserialize)]
struct Point {
    surface: String,
    position: [f64; 3],
    normal: [f64; 3],
    radiosity: [f64; 3],
    stderr: [f64; 3],
}

/// Median, 90th percentile and max of a relative error over the reference points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    pub median: f64,
    pub p90: f64,
    pub max: f64,
}

impl Spread {
    fn of(values: &[f64]) -> Self {
        let mut s = values.to_vec();
        s.sort_by(f64::total_cmp);
        let at = |q: f64| s[((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)];
        Self {
            median: at(0.5),
            p90: at(0.9),
            max: at(1.0),
        }
    }
}

/// The reference points of one scene, checked against that scene.
#[derive(Debug)]
pub struct Truth {
    points: Vec<Point>,
    /// The reference's relative standard error over its points.
    pub noise: Spread,
}

fn l1(v: [f64; 3]) -> f64 {
    v.iter().map(|x| x.abs()).sum()
}

impl Truth {
    /// Reads `path` and checks that every point lies on a face of its surface in `scene`.
    pub fn load(path: &Path, scene: &Scene) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let bad = |what: String| {
            Error::Settings(format!(
                "--reference {}: {what} (expected a file of tests/data/reference/, made by \
                 scripts/reference/run.py)",
                path.display()
            ))
        };
        let file: File = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        if file.points.is_empty() {
            return Err(bad("no points".into()));
        }
        for (i, p) in file.points.iter().enumerate() {
            let values = p.position.iter().chain(&p.normal).chain(&p.radiosity);
            if values.chain(&p.stderr).any(|x| !x.is_finite()) || l1(p.radiosity) <= 0.0 {
                return Err(bad(format!(
                    "point {i} has a non-finite number or no radiosity"
                )));
            }
            if !on_surface(scene, p) {
                return Err(bad(format!(
                    "point {i} ({:?}) lies on no face of surface '{}' of scene '{}': the \
                     reference is of another scene, or the scene changed since it was made",
                    p.position, p.surface, scene.name
                )));
            }
        }
        let noise: Vec<f64> = file
            .points
            .iter()
            .map(|p| l1(p.stderr) / l1(p.radiosity))
            .collect();
        Ok(Self {
            noise: Spread::of(&noise),
            points: file.points,
        })
    }

    /// The error of `b` (radiosity per element, original ids, of `op`) at the points, flat:
    /// the value of the element each point falls in.
    pub fn error(&self, op: &Operator, b: &[[f64; 3]]) -> Spread {
        let faces = op.file().faces();
        self.spread(op, |f, _| b[op.file().order[faces.element(f)] as usize])
    }

    /// The error of `b` at the points through the smooth reconstruction (`lrr probe`'s
    /// default); `None` when the file has no smooth weights.
    pub fn smooth_error(&self, op: &Operator, b: &[[f64; 3]]) -> Option<Spread> {
        let r = Reconstruction::new(op.file()).ok()?;
        let b32: Vec<[f32; 3]> = b.iter().map(|v| v.map(|x| x as f32)).collect();
        let mut vertices = vec![[0.0f32; 3]; r.vertex_count()];
        r.vertex_values(&b32, &mut vertices).ok()?;
        Some(self.spread(op, |f, p| {
            r.at(&vertices, f, p.position.map(|x| x as f32))
                .map(f64::from)
        }))
    }

    /// The spread of the relative error of `value(display face, point)` over the points (the
    /// face each point lies on: `Operator::locate_face`).
    fn spread(&self, op: &Operator, value: impl Fn(usize, &Point) -> [f64; 3]) -> Spread {
        let rel: Vec<f64> = self
            .points
            .iter()
            .map(|p| {
                let s = op
                    .locate_face(p.position.map(|x| x as f32), p.normal.map(|x| x as f32))
                    .expect("an operator has at least one element");
                let v = value(s, p);
                let d = [0, 1, 2].map(|c| v[c] - p.radiosity[c]);
                l1(d) / l1(p.radiosity)
            })
            .collect();
        Spread::of(&rel)
    }
}

/// Whether the point lies on the front of a face of its surface (within 1e-6 of the scene's
/// size).
fn on_surface(scene: &Scene, p: &Point) -> bool {
    let tol = 1e-6 * scene.extent();
    let x = glam::DVec3::from_array(p.position);
    let n = glam::DVec3::from_array(p.normal);
    scene.faces.iter().any(|f| {
        let poly = &f.polygon;
        let v = poly.vertices();
        scene.surfaces[f.surface] == p.surface
            && poly.normal.dot(n) > 1.0 - 1e-6
            && poly.normal.dot(x - v[0]).abs() <= tol
            && (0..v.len()).all(|j| {
                let e = v[(j + 1) % v.len()] - v[j];
                e.cross(x - v[j]).dot(poly.normal) >= -tol * e.length()
            })
    })
}
