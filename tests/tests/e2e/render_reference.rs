//! `lrr render` of the Cornell box (lit by its lamp, and by a point light with the lamp dark)
//! against the path-traced image of the same camera
//! (`tests/data/reference/cornell-box.exr`: Mitsuba 3, 1024 paths per pixel, box filter, 256²,
//! linear radiance; `cornell-box-image.json` names the camera and how it was made).
//!
//! lrr renders at 1024² (one ray through each pixel centre) and averages 4 × 4 blocks, the box
//! filter of the reference. Two figures: the image's relative L1 error `Σ|ΔL| / Σ L_ref` over all
//! pixels and channels, and the per-pixel relative error of the luminance (mean of R, G, B) over
//! pixels brighter than 1e-3 of the median (the box's black surround is left out). The second
//! includes the reference's own per-pixel noise (1024 paths), which this test cannot separate.

use std::path::Path;

use crate::util::{bake, cornell, lrr, root, temp_dir};

/// Rows of RGB pixels of the first RGB(A) layer of an EXR file.
pub(crate) fn read_rgb(path: &Path) -> (usize, usize, Vec<[f64; 3]>) {
    use exr::prelude::{ReadChannels, ReadLayers, read};
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |resolution, _| {
                (
                    resolution.width(),
                    resolution.height(),
                    vec![[0.0f64; 3]; resolution.width() * resolution.height()],
                )
            },
            |(w, _, px): &mut (usize, usize, Vec<[f64; 3]>),
             pos,
             (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = [r as f64, g as f64, b as f64];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    image.layer_data.channel_data.pixels
}

/// `(relative L1 error, median and mean per-pixel relative luminance error)`.
fn image_errors(ours: &[[f64; 3]], reference: &[[f64; 3]]) -> (f64, f64, f64) {
    let l1: f64 = ours
        .iter()
        .zip(reference)
        .map(|(a, r)| (0..3).map(|c| (a[c] - r[c]).abs()).sum::<f64>())
        .sum::<f64>()
        / reference.iter().map(|r| r.iter().sum::<f64>()).sum::<f64>();
    let lum = |p: &[f64; 3]| (p[0] + p[1] + p[2]) / 3.0;
    let mut sorted: Vec<f64> = reference.iter().map(lum).collect();
    sorted.sort_by(f64::total_cmp);
    let floor = 1e-3 * sorted[sorted.len() / 2];
    let mut rel: Vec<f64> = ours
        .iter()
        .zip(reference)
        .filter(|(_, r)| lum(r) > floor)
        .map(|(a, r)| (lum(a) - lum(r)).abs() / lum(r))
        .collect();
    rel.sort_by(f64::total_cmp);
    let mean = rel.iter().sum::<f64>() / rel.len() as f64;
    (l1, rel[rel.len() / 2], mean)
}

/// Bakes `scene` with the default flags, renders it from the camera of reference image `name`
/// (`tests/data/reference/NAME.exr` and `NAME-image.json`) once per entry of `flags` (extra
/// `lrr render` flags) and measures [`image_errors`] of each.
fn render_against(name: &str, scene: &Path, flags: &[&[&str]]) -> Vec<(f64, f64, f64)> {
    let meta: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join(format!("tests/data/reference/{name}-image.json")))
            .unwrap(),
    )
    .unwrap();
    let camera = &meta["camera"];
    let csv = |v: &serde_json::Value| {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap().to_string())
            .collect::<Vec<_>>()
            .join(",")
    };
    let size = meta["size"].as_u64().unwrap() as usize;
    assert_eq!(meta["filter"], "box", "the reference's pixel filter");
    // Square image: the reference's horizontal field of view is also the vertical one.
    let fov = camera["fov"].as_f64().unwrap().to_string();

    let dir = temp_dir(&format!("render-reference-{name}"));
    let file = dir.join("scene.lrr");
    bake(scene, &file, &[]).unwrap();
    let image = dir.join("cornell.exr");
    let (eye, target, up) = (
        csv(&camera["origin"]),
        csv(&camera["target"]),
        csv(&camera["up"]),
    );
    let big = format!("{0}x{0}", 4 * size);
    let (rw, rh, reference) = read_rgb(&root().join(format!("tests/data/reference/{name}.exr")));
    assert_eq!((rw, rh), (size, size));
    let mut errors = Vec::new();
    for extra in flags {
        let args: Vec<&str> = [
            "render",
            file.to_str().unwrap(),
            "--eye",
            &eye,
            "--target",
            &target,
            "--up",
            &up,
            "--fov-y",
            &fov,
            "--size",
            &big,
            "-o",
            image.to_str().unwrap(),
        ]
        .into_iter()
        .chain(extra.iter().copied())
        .collect();
        let out = lrr(&args).unwrap();
        let (w, h, fine) = read_rgb(&image);
        assert_eq!((w, h), (4 * size, 4 * size), "{out}");
        // 4 x 4 box average: the reference's pixel filter.
        let mut ours = vec![[0.0f64; 3]; size * size];
        for y in 0..4 * size {
            for x in 0..4 * size {
                let p = &mut ours[(y / 4) * size + x / 4];
                for c in 0..3 {
                    p[c] += fine[y * w + x][c] / 16.0;
                }
            }
        }
        let (l1, median, mean) = image_errors(&ours, &reference);
        eprintln!(
            "{name} {extra:?}: render against the path-traced image: relative L1 {:.2}%, \
             per-pixel median {:.2}%, mean {:.2}%",
            100.0 * l1,
            100.0 * median,
            100.0 * mean
        );
        errors.push((l1, median, mean));
    }
    errors
}

/// The Cornell box rendered smooth (the default) and flat from the reference image's camera:
/// each within issue #15's goal of a 5 % per-pixel mean error (and 5 % relative L1 and
/// median, the point-lit test's ceilings); measured in the same run, the smooth image beats
/// the flat one on all three figures (measured 2026-11-28: smooth 1.94%, 2.35%, 4.54%; flat
/// 2.54%, 3.36%, 5.95%, its mean beyond the goal: why smooth shading is the default).
#[test]
fn cornell_render_against_the_path_traced_image() {
    let errors = render_against(
        "cornell-box",
        &cornell(),
        &[&[], &["--reconstruct", "flat"]],
    );
    let [(l1, median, mean), (flat_l1, flat_median, flat_mean)] = errors[..] else {
        unreachable!()
    };
    assert!(mean <= 0.05, "per-pixel mean error {mean} (goal 5%)");
    assert!(
        l1 <= 0.05 && median <= 0.05,
        "relative L1 {l1}, median {median}"
    );
    assert!(
        l1 < flat_l1 && median < flat_median && mean < flat_mean,
        "smooth {:?} against flat {:?}",
        (l1, median, mean),
        (flat_l1, flat_median, flat_mean)
    );
}

/// Issue #32's goal for a rendered frame of the Cornell box lit by a point light (its lamp
/// dark): per-pixel mean relative error ≤ 5 % against the path-traced image. The direct light
/// is shaded at each hit point behind its own shadow ray, so the hard shadows of the blocks
/// are as sharp as the pixels.
#[test]
fn point_lit_cornell_render_against_the_path_traced_image() {
    let scene = root().join("tests/data/reference/scenes/cornell-point.toml");
    let [(l1, median, mean)] = render_against("cornell-point", &scene, &[&[]])[..] else {
        unreachable!()
    };
    assert!(mean <= 0.05, "per-pixel mean error {mean} (goal 5%)");
    assert!(
        l1 <= 0.05 && median <= 0.05,
        "relative L1 {l1}, median {median}"
    );
}
