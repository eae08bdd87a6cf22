//! `lrr relight OUT.lrr --animation ANIM.toml -o DIR`: light-group intensities and colours
//! keyframed over time, interpolated linearly, evaluated frame by frame with one persistent
//! evaluator, each frame's radiosity written as an EXR lightmap (`DIR/frame-00000.exr`, …; the
//! atlas of `lrr export`, laid out once). A progress bar shows frames per second; the end line
//! gives the achieved rates of the evaluation alone and of the whole loop.
//!
//! ```toml
//! fps = 24.0          # frames per second of the sequence
//! duration = 4.0      # seconds [default: the last keyframe's time]
//! [[group]]
//! name = "light"      # a light group of the file (`lrr info`); groups not named stay at 1
//! keys = [
//!   { time = 0.0, intensity = 1.0 },
//!   { time = 2.0, intensity = 0.2, colour = [1.0, 0.6, 0.3] },   # colour default [1, 1, 1]
//! ]
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_runtime::{Operator, Rgb, RgbMut};
use serde::Deserialize;

use crate::emission::{Reconstruct, reconstruction};
use crate::export::atlas::{self, Sizing};
use crate::export::field::Field;
use crate::export::{charts, radiance_atlas};
use crate::exr_image::{self, ExrSamples, RgbLayer};

#[derive(Debug, Args)]
pub struct RelightArgs {
    /// Operator file.
    pub file: PathBuf,
    /// The animation: keyframes of light-group intensities and colours (TOML).
    #[arg(long, value_name = "ANIM.toml")]
    pub animation: PathBuf,
    /// Output folder (created); frames are `frame-00000.exr`, ….
    #[arg(long, short, value_name = "DIR")]
    pub output: PathBuf,
    /// Lightmap: a square atlas of N×N texels [default: 1024 unless --texel-density is given].
    #[arg(long, value_name = "N", conflicts_with = "texel_density")]
    pub size: Option<usize>,
    /// Lightmap: texels per scene unit.
    #[arg(long, value_name = "T")]
    pub texel_density: Option<f64>,
    /// Lightmap: texels of dilated border around each chart.
    #[arg(long, value_name = "P", default_value_t = 2)]
    pub padding: usize,
    /// EXR sample type: `half` or `float`.
    #[arg(long, value_enum, default_value_t = ExrSamples::Half)]
    pub samples: ExrSamples,
    /// Evaluator threads [default: all cores].
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// How values inside elements come from the element values: `smooth` (the default when
    /// the file has smooth weights) or `flat`.
    #[arg(long, value_enum)]
    pub reconstruct: Option<Reconstruct>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The animation file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Animation {
    pub fps: f64,
    pub duration: Option<f64>,
    #[serde(default)]
    pub group: Vec<Track>,
}

/// One light group's keyframes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Track {
    pub name: String,
    pub keys: Vec<Key>,
}

/// A keyframe: at `time` seconds, intensity × colour scales the group's baked emission.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Key {
    pub time: f64,
    pub intensity: f32,
    #[serde(default = "white")]
    pub colour: [f32; 3],
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

impl Animation {
    /// Reads and checks `path` (fps, times increasing, values finite and non-negative).
    pub fn read(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let a: Animation = toml::from_str(&text)
            .with_context(|| format!("{}: not an animation", path.display()))?;
        let at = |what: String| format!("{}: {what}", path.display());
        if !(a.fps.is_finite() && a.fps > 0.0) {
            bail!(at(format!("fps = {} must be a finite number > 0", a.fps)));
        }
        for t in &a.group {
            if t.keys.is_empty() {
                bail!(at(format!("group '{}' has no keys", t.name)));
            }
            for (i, k) in t.keys.iter().enumerate() {
                let ok = k.time.is_finite()
                    && k.intensity.is_finite()
                    && k.intensity >= 0.0
                    && k.colour.iter().all(|c| c.is_finite() && *c >= 0.0);
                if !ok {
                    bail!(at(format!(
                        "group '{}' key {i}: time, intensity and colour must be finite, intensity and colour >= 0",
                        t.name
                    )));
                }
                if i > 0 && k.time <= t.keys[i - 1].time {
                    bail!(at(format!(
                        "group '{}' key {i}: times must increase",
                        t.name
                    )));
                }
            }
        }
        if let Some(d) = a.duration
            && !(d.is_finite() && d >= 0.0)
        {
            bail!(at(format!("duration = {d} must be a finite number >= 0")));
        }
        Ok(a)
    }

    /// The sequence's length in seconds.
    pub fn duration(&self) -> f64 {
        self.duration.unwrap_or_else(|| {
            self.group
                .iter()
                .filter_map(|t| t.keys.last().map(|k| k.time))
                .fold(0.0, f64::max)
        })
    }

    /// Number of frames: `floor(duration × fps) + 1` (time 0 included).
    pub fn frames(&self) -> usize {
        (self.duration() * self.fps + 1e-9).floor() as usize + 1
    }
}

impl Track {
    /// Intensity × colour at time `t`, interpolated linearly; held before the first key and
    /// after the last.
    pub fn at(&self, t: f64) -> [f32; 3] {
        let keys = &self.keys;
        let scaled = |k: &Key| k.colour.map(|c| c * k.intensity);
        let i = keys.partition_point(|k| k.time <= t);
        if i == 0 {
            return scaled(&keys[0]);
        }
        if i == keys.len() {
            return scaled(&keys[i - 1]);
        }
        let (a, b) = (&keys[i - 1], &keys[i]);
        let f = ((t - a.time) / (b.time - a.time)) as f32;
        let (va, vb) = (scaled(a), scaled(b));
        [0, 1, 2].map(|c| va[c] + f * (vb[c] - va[c]))
    }
}

pub fn run(a: &RelightArgs, out: &mut dyn Write) -> Result<()> {
    let op = Operator::load(&a.file).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    let anim = Animation::read(&a.animation)?;
    let tracks = resolve_tracks(&op, &anim, &a.animation)?;
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("creating {}", a.output.display()))?;
    let charts = charts::charts(&op.file().geometry);
    let sizing = match (a.size, a.texel_density) {
        (_, Some(t)) => Sizing::Density(t),
        (Some(n), None) => Sizing::Size(n),
        (None, None) => Sizing::Size(1024),
    };
    let layout = atlas::pack(&charts, sizing, a.padding)?;
    let groups = group_emission(&op);
    let smooth = reconstruction(&op, a.reconstruct, &a.file)?;
    let mut eval = op.evaluator(a.threads.unwrap_or(0))?;
    let (n, frames) = (op.n(), anim.frames());
    let (mut emission, mut b) = (vec![[0.0f32; 3]; n], vec![[0.0f32; 3]; n]);
    let progress = {
        use std::io::IsTerminal;
        lrr_precompute::progress::Progress::new(!a.quiet && std::io::stderr().is_terminal())
    };
    let stage = progress.stage("relight", frames as u64);
    let (start, mut evaluating) = (Instant::now(), 0.0);
    for f in 0..frames {
        let t = f as f64 / anim.fps;
        let scale: Vec<[f32; 3]> = tracks
            .iter()
            .map(|track| track.map_or([1.0; 3], |tr| tr.at(t)))
            .collect();
        let timer = Instant::now();
        emission.iter_mut().for_each(|e| *e = [0.0; 3]);
        for (g, members) in groups.iter().enumerate() {
            for &(id, e) in members {
                for c in 0..3 {
                    emission[id][c] += scale[g][c] * e[c];
                }
            }
        }
        eval.evaluate(Rgb::triples(&emission), RgbMut::triples(&mut b))?;
        evaluating += timer.elapsed().as_secs_f64();
        let field = Field::new(op.file(), &b, smooth)?;
        let atlas = radiance_atlas(&op, &field, &charts, &layout);
        let path = a.output.join(format!("frame-{f:05}.exr"));
        let note = format!(
            "frame {f} at t = {t:.6} s of {}: exitant radiance B/pi",
            a.animation.display()
        );
        let layer = [RgbLayer {
            name: None,
            pixels: &atlas.pixels,
        }];
        exr_image::write_rgb(&path, layout.width, layout.height, &layer, a.samples, &note)?;
        stage.inc(1);
    }
    stage.finish();
    let total = start.elapsed().as_secs_f64();
    writeln!(
        out,
        "wrote {frames} frames ({}×{} texels) to {}: {:.1} frames/s in all, the evaluation alone {:.1} frames/s ({:.3} ms a frame)",
        layout.width,
        layout.height,
        a.output.display(),
        frames as f64 / total,
        frames as f64 / evaluating.max(1e-12),
        1e3 * evaluating / frames as f64
    )?;
    Ok(())
}

/// Per light group of the file, its track in the animation (`None`: constant 1); names the
/// animation gives that the file lacks are errors.
fn resolve_tracks<'a>(
    op: &Operator,
    anim: &'a Animation,
    path: &Path,
) -> Result<Vec<Option<&'a Track>>> {
    for t in &anim.group {
        if op.light_group(&t.name).is_none() {
            let names: Vec<&str> = op.light_groups().collect();
            bail!(
                "{}: group '{}' is not a light group of the file (it has: {})",
                path.display(),
                t.name,
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            );
        }
    }
    Ok(op
        .light_groups()
        .map(|name| anim.group.iter().find(|t| t.name == name))
        .collect())
}

/// Each light group's members: (original id, emission at intensity 1).
fn group_emission(op: &Operator) -> Vec<Vec<(usize, [f32; 3])>> {
    let file = op.file();
    file.lights
        .iter()
        .map(|g| {
            g.positions
                .iter()
                .enumerate()
                .map(|(i, &s)| {
                    let e = &g.emission[3 * i..3 * i + 3];
                    (file.order[s as usize] as usize, [e[0], e[1], e[2]])
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(keys: &[(f64, f32, [f32; 3])]) -> Track {
        Track {
            name: "g".into(),
            keys: keys
                .iter()
                .map(|&(time, intensity, colour)| Key {
                    time,
                    intensity,
                    colour,
                })
                .collect(),
        }
    }

    #[test]
    fn tracks_interpolate_linearly_and_hold_at_the_ends() {
        let t = track(&[(1.0, 2.0, [1.0, 1.0, 1.0]), (3.0, 1.0, [1.0, 0.0, 0.5])]);
        assert_eq!(t.at(0.0), [2.0; 3]);
        assert_eq!(t.at(1.0), [2.0; 3]);
        assert_eq!(t.at(2.0), [1.5, 1.0, 1.25]);
        assert_eq!(t.at(3.0), [1.0, 0.0, 0.5]);
        assert_eq!(t.at(9.0), [1.0, 0.0, 0.5]);
    }

    #[test]
    fn frames_count_both_ends() {
        let a = Animation {
            fps: 10.0,
            duration: None,
            group: vec![track(&[(0.0, 1.0, [1.0; 3]), (2.0, 0.0, [1.0; 3])])],
        };
        assert_eq!(a.frames(), 21);
    }
}
