//! The animation file of `lrr relight`: light-group intensities and colours, and lights that
//! are not surfaces (their place, direction and strength), keyframed over time, interpolated
//! linearly (a direction component by component; the light normalises it), held before the
//! first key and after the last.
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
//! [[light]]           # a light of the animation's own, added to the file's lights
//! name = "torch"
//! kind = "point"      # "point", "spot" (inner_cone_deg, outer_cone_deg) or "sun"
//! keys = [            # position (point, spot), direction (spot, sun), intensity [r, g, b]
//!   { time = 0.0, position = [1.0, 1.2, 0.5], intensity = [5.0, 4.0, 3.0] },   # (W/sr; sun: W/m²)
//!   { time = 4.0, position = [6.0, 1.2, 0.5], intensity = [5.0, 4.0, 3.0] },
//! ]
//! ```

use std::path::Path;

use anyhow::{Context, Result, bail};
use lrr_runtime::Operator;
use lrr_runtime::lights::Light;
use serde::Deserialize;

/// The most frames an animation may have (11.6 hours at 24 fps): each frame is evaluated and
/// written as files of its own.
pub const MAX_FRAMES: usize = 1_000_000;

/// The animation file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Animation {
    pub fps: f64,
    pub duration: Option<f64>,
    #[serde(default)]
    pub group: Vec<Track>,
    #[serde(default)]
    pub light: Vec<LightTrack>,
}

/// What kind of light a [`LightTrack`] moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LightKind {
    Point,
    Spot,
    Sun,
}

/// One light's keyframes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightTrack {
    pub name: String,
    pub kind: LightKind,
    /// Spot: the full-intensity cone's half-angle (default 0).
    #[serde(default)]
    pub inner_cone_deg: f32,
    /// Spot: where the light ends (default 45).
    #[serde(default = "forty_five")]
    pub outer_cone_deg: f32,
    pub keys: Vec<LightKey>,
}

fn forty_five() -> f32 {
    45.0
}

/// A light's keyframe: at `time` seconds, its place, direction and strength.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightKey {
    pub time: f64,
    #[serde(default)]
    pub position: Option<[f32; 3]>,
    #[serde(default)]
    pub direction: Option<[f32; 3]>,
    pub intensity: [f32; 3],
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
        for t in &a.light {
            t.check()
                .map_err(|e| anyhow::anyhow!(at(format!("light '{}': {e}", t.name))))?;
        }
        if let Some(d) = a.duration
            && !(d.is_finite() && d >= 0.0)
        {
            bail!(at(format!("duration = {d} must be a finite number >= 0")));
        }
        // Without this, fps = 1e300 made `frames` overflow (a panic in debug builds, 0 frames
        // in release) and fps = 1e9 asked for 1e18 frames.
        // Finite or +∞, never NaN: the duration is finite and >= 0, fps finite and > 0.
        let frames = a.duration() * a.fps;
        if frames >= MAX_FRAMES as f64 {
            bail!(at(format!(
                "duration {} s × fps {} = {frames} frames; at most {MAX_FRAMES}: shorten the \
                 duration or lower fps",
                a.duration(),
                a.fps
            )));
        }
        Ok(a)
    }

    /// The sequence's length in seconds.
    pub fn duration(&self) -> f64 {
        self.duration.unwrap_or_else(|| {
            let groups = self
                .group
                .iter()
                .filter_map(|t| t.keys.last().map(|k| k.time));
            let lights = self
                .light
                .iter()
                .filter_map(|t| t.keys.last().map(|k| k.time));
            groups.chain(lights).fold(0.0, f64::max)
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

impl LightTrack {
    /// Keys present, times increasing, each key holding what its kind needs, finite values,
    /// intensities >= 0, cones in order.
    fn check(&self) -> Result<()> {
        if self.keys.is_empty() {
            bail!("no keys");
        }
        let (inner, outer) = (self.inner_cone_deg, self.outer_cone_deg);
        if self.kind == LightKind::Spot && !(inner >= 0.0 && inner <= outer && outer <= 90.0) {
            bail!("need 0 <= inner_cone_deg <= outer_cone_deg <= 90, got {inner} and {outer}");
        }
        let needs_position = matches!(self.kind, LightKind::Point | LightKind::Spot);
        let needs_direction = matches!(self.kind, LightKind::Spot | LightKind::Sun);
        for (i, k) in self.keys.iter().enumerate() {
            let finite = |v: [f32; 3]| v.iter().all(|c| c.is_finite());
            if k.position.is_some() != needs_position || k.direction.is_some() != needs_direction {
                bail!(
                    "key {i}: a {:?} light's key gives {} (and intensity)",
                    self.kind,
                    match self.kind {
                        LightKind::Point => "position",
                        LightKind::Spot => "position and direction",
                        LightKind::Sun => "direction",
                    }
                );
            }
            let ok = k.time.is_finite()
                && k.position.is_none_or(finite)
                && k.direction
                    .is_none_or(|d| finite(d) && d.iter().any(|&c| c != 0.0))
                && k.intensity.iter().all(|c| c.is_finite() && *c >= 0.0);
            if !ok {
                bail!(
                    "key {i}: time, position and direction must be finite, a direction not \
                     zero, the intensity >= 0"
                );
            }
            if i > 0 && k.time <= self.keys[i - 1].time {
                bail!("key {i}: times must increase");
            }
        }
        Ok(())
    }

    /// The light at time `t`, interpolated linearly (a direction component by component: a light
    /// normalises its direction), held before the
    /// first key and after the last.
    pub fn at(&self, t: f64) -> Light {
        let keys = &self.keys;
        let i = keys.partition_point(|k| k.time <= t);
        let (a, b, f) = if i == 0 {
            (&keys[0], &keys[0], 0.0)
        } else if i == keys.len() {
            (&keys[i - 1], &keys[i - 1], 0.0)
        } else {
            let (a, b) = (&keys[i - 1], &keys[i]);
            (a, b, ((t - a.time) / (b.time - a.time)) as f32)
        };
        let lerp = |x: [f32; 3], y: [f32; 3]| [0, 1, 2].map(|c| x[c] + f * (y[c] - x[c]));
        let pick = |x: Option<[f32; 3]>, y: Option<[f32; 3]>| {
            lerp(x.unwrap_or_default(), y.unwrap_or_default())
        };
        let position = pick(a.position, b.position);
        let direction = pick(a.direction, b.direction);
        let direction = if direction.iter().all(|&c| c == 0.0) {
            a.direction.unwrap_or_default()
        } else {
            direction
        };
        let intensity = lerp(a.intensity, b.intensity);
        match self.kind {
            LightKind::Point => Light::Point {
                position,
                intensity,
            },
            LightKind::Spot => Light::Spot {
                position,
                direction,
                intensity,
                inner: self.inner_cone_deg.to_radians(),
                outer: self.outer_cone_deg.to_radians(),
            },
            LightKind::Sun => Light::Directional {
                direction,
                irradiance: intensity,
            },
        }
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
            light: Vec::new(),
        };
        assert_eq!(a.frames(), 21);
    }

    #[test]
    fn light_tracks_interpolate_and_refuse_missing_fields() {
        let text = r#"
            fps = 2.0
            [[light]]
            name = "torch"
            kind = "point"
            keys = [
              { time = 0.0, position = [0.0, 1.0, 0.0], intensity = [2.0, 2.0, 2.0] },
              { time = 2.0, position = [4.0, 1.0, 0.0], intensity = [0.0, 2.0, 4.0] },
            ]
            [[light]]
            name = "sun"
            kind = "sun"
            keys = [
              { time = 0.0, direction = [0.0, -1.0, 0.0], intensity = [1.0, 1.0, 1.0] },
              { time = 4.0, direction = [1.0, 0.0, 0.0], intensity = [1.0, 1.0, 1.0] },
            ]
        "#;
        let dir = std::env::temp_dir().join(format!("lrr-anim-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.toml");
        std::fs::write(&path, text).unwrap();
        let a = Animation::read(&path).unwrap();
        assert_eq!(a.duration(), 4.0);
        assert_eq!(a.frames(), 9);
        assert_eq!(
            a.light[0].at(1.0),
            Light::Point {
                position: [2.0, 1.0, 0.0],
                intensity: [1.0, 2.0, 3.0]
            }
        );
        assert_eq!(
            a.light[0].at(9.0),
            Light::Point {
                position: [4.0, 1.0, 0.0],
                intensity: [0.0, 2.0, 4.0]
            }
        );
        let Light::Directional { direction, .. } = a.light[1].at(2.0) else {
            panic!("a sun");
        };
        assert_eq!(direction, [0.5, -0.5, 0.0]);
        // A sun key without a direction is refused, naming the light and the key.
        std::fs::write(
            &path,
            "fps = 1.0\n[[light]]\nname = \"s\"\nkind = \"sun\"\nkeys = [{ time = 0.0, intensity = [1.0, 1.0, 1.0] }]\n",
        )
        .unwrap();
        let e = Animation::read(&path).unwrap_err().to_string();
        assert!(
            e.contains("light 's'") && e.contains("key 0") && e.contains("direction"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
