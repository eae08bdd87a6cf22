//! The animation file of `lrr relight`: light-group intensities and colours keyframed over
//! time, interpolated linearly, held before the first key and after the last.
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

use std::path::Path;

use anyhow::{Context, Result, bail};
use lrr_runtime::Operator;
use serde::Deserialize;

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

    /// Per light group of `op`, its track (`None`: constant 1); names the animation (`path`)
    /// gives that the file lacks are errors listing the file's groups.
    pub fn tracks(&self, op: &Operator, path: &Path) -> Result<Vec<Option<&Track>>> {
        for t in &self.group {
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
            .map(|name| self.group.iter().find(|t| t.name == name))
            .collect())
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
