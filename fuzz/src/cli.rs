//! The bodies of the targets for the files only the command line reads (`probe_points`,
//! `emission_json`, `reference_json`, `animation_toml`), shared with the replay test like
//! [`super::harness`]. They run the command line's own code through lrr-cli's library: `lrr
//! probe` and `lrr relight` in-process (`lrr_cli::run`, as the CLI's tests do), and the
//! accuracy sweep's reference reader (`lrr_cli::sweep::Truth`, public), against a bake of
//! [`super::shards::SCENE`] made once per process. Each input is written to a file of the
//! scratch folder and named on the command line; every run must give Ok or an error, never a
//! panic.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use lrr_cli::relight::animation::Animation;
use lrr_cli::sweep::Truth;
use lrr_precompute::bake::bake;
use lrr_precompute::progress::Progress;
use lrr_runtime::Operator;

use super::shards::{scene, settings};

/// The bake of [`super::shards::SCENE`] (light group `lamp`, a point light, a sun, smooth
/// weights, a BVH) as file bytes, made once.
pub fn base_operator() -> &'static [u8] {
    static OP: OnceLock<Vec<u8>> = OnceLock::new();
    OP.get_or_init(|| {
        let baked = bake(scene(), &settings(None), &Progress::hidden()).expect("the base bake");
        let file = lrr_precompute::write::operator_file(&baked).expect("a valid file");
        file.to_bytes().expect("a valid file")
    })
}

/// [`base_operator`] written in `dir` (once per folder).
fn operator_path(dir: &Path) -> PathBuf {
    let path = dir.join("fuzz-base.lrr");
    if !path.exists() {
        std::fs::write(&path, base_operator()).expect("cannot write the fuzz operator");
    }
    path
}

/// Runs the command line on `args` (`lrr` first); `true` when it succeeded.
fn lrr(args: &[&str]) -> bool {
    let mut out = Vec::new();
    lrr_cli::run(args, &mut out).is_ok()
}

fn text(path: &Path) -> &str {
    path.to_str().expect("a UTF-8 scratch folder")
}

/// `probe_points`: the input as `lrr probe --points P.json` (JSON: an array of `{"position",
/// "normal"}`), probed on the base bake with its file lights, smooth.
pub fn probe_points(data: &[u8], dir: &Path) -> bool {
    let op = operator_path(dir);
    let points = dir.join("points.json");
    std::fs::write(&points, data).expect("cannot write the fuzz points");
    lrr(&[
        "lrr",
        "probe",
        text(&op),
        "--points",
        text(&points),
        "--json",
    ])
}

/// Points on every surface of the base bake, for `emission_json`.
const POINTS: &str = r#"[
  {"position": [0.5, 0.5, 0.0], "normal": [0, 0, 1]},
  {"position": [0.4, 0.4, 0.5], "normal": [0, 0, -1]},
  {"position": [0.4, 0.4, 0.5], "normal": [0, 0, 1]},
  {"position": [0.5, 0.5, 1.0], "normal": [0, 0, -1]}
]"#;

/// `emission_json`: the input as `lrr probe --emission E.json` (JSON: n `[r, g, b]`), probed
/// at [`POINTS`] flat and smooth in turn (by the input's length).
pub fn emission_json(data: &[u8], dir: &Path) -> bool {
    let op = operator_path(dir);
    let points = dir.join("emission-points.json");
    if !points.exists() {
        std::fs::write(&points, POINTS).expect("cannot write the fuzz points");
    }
    let emission = dir.join("emission.json");
    std::fs::write(&emission, data).expect("cannot write the fuzz emission");
    let reconstruct = if data.len().is_multiple_of(2) {
        "smooth"
    } else {
        "flat"
    };
    lrr(&[
        "lrr",
        "probe",
        text(&op),
        "--points",
        text(&points),
        "--emission",
        text(&emission),
        "--reconstruct",
        reconstruct,
    ])
}

/// `reference_json`: the input as `lrr accuracy --reference FILE` of the scene: read and checked
/// against it ([`Truth::load`]), then the base bake's error at its points, flat and smooth
/// (what the sweep computes for every bake).
pub fn reference_json(data: &[u8], dir: &Path) -> bool {
    let path = dir.join("reference.json");
    std::fs::write(&path, data).expect("cannot write the fuzz reference");
    let Ok(truth) = Truth::load(&path, scene()) else {
        return false;
    };
    let op = Operator::from_bytes(base_operator()).expect("the base bake loads");
    let mut b = vec![[0.0f32; 3]; op.n()];
    op.evaluate(&op.baked_emission(), &mut b)
        .expect("the base bake evaluates");
    let b: Vec<[f64; 3]> = b.iter().map(|v| v.map(f64::from)).collect();
    let flat = truth.error(&op, &b);
    let smooth = truth
        .smooth_error(&op, &b)
        .expect("the base bake is smooth");
    for s in [flat, smooth] {
        assert!(
            s.median <= s.p90 && s.p90 <= s.max || s.max.is_nan(),
            "spread out of order: {s:?}"
        );
    }
    true
}

/// Frames `animation_toml` renders at most (an animation of more is read and checked, and its
/// lights sampled, but not relit: each frame traces an image and writes a file).
pub const MAX_RELIT_FRAMES: usize = 8;

/// `animation_toml`: the input as `lrr relight --animation ANIM.toml`: read and checked
/// ([`Animation::read`]), its tracks matched with the base bake's groups, its lights sampled at
/// 17 times over the sequence (each must be a light the direct pass accepts); then, when it
/// has at most [`MAX_RELIT_FRAMES`] frames, relit into 4 × 3 EXR images (a camera
/// from the side: the bake has none).
pub fn animation_toml(data: &[u8], dir: &Path) -> bool {
    let path = dir.join("animation.toml");
    std::fs::write(&path, data).expect("cannot write the fuzz animation");
    let Ok(anim) = Animation::read(&path) else {
        return false;
    };
    let frames = anim.frames();
    let op = Operator::from_bytes(base_operator()).expect("the base bake loads");
    if anim.tracks(&op, &path).is_err() {
        return false;
    }
    let duration = anim.duration();
    for i in 0..=16 {
        let t = duration * f64::from(i) / 16.0;
        for track in &anim.group {
            let v = track.at(t);
            assert!(
                v.iter().all(|c| c.is_finite() && *c >= 0.0),
                "group '{}' at {t}: {v:?}",
                track.name
            );
        }
        for track in &anim.light {
            let light = track.at(t);
            if let Err(e) = light.check() {
                panic!("light '{}' at {t} s: {light:?}: {e}", track.name);
            }
        }
    }
    if frames > MAX_RELIT_FRAMES {
        return true;
    }
    let op = operator_path(dir);
    let out = dir.join("relit");
    lrr(&[
        "lrr",
        "relight",
        text(&op),
        "--animation",
        text(&path),
        "-o",
        text(&out),
        "--images",
        "exr",
        "--eye",
        "0.5,-1.5,0.5",
        "--target",
        "0.5,0.5,0.25",
        "--image-size",
        "4x3",
        "--threads",
        "1",
        "--quiet",
    ])
}
