//! Rasterising a field over the scene's own lightmap coordinates (section LIGHTMAP, from glTF
//! `TEXCOORD_1`): the atlas the user's engine already samples, `[0, 1]²` mapped onto
//! `width × height` texels (texel `(i, j)` covers `[i, i+1) × [j, j+1)`, rows top to bottom,
//! `v = 0` the top row, as glTF's UVs).
//!
//! The coordinates are those of the file's display faces (`OperatorFile::faces`; "element"
//! below means a display face). Each element's corners map to a convex polygon of the atlas (the coordinates are an affine
//! map of its face's plane, so its image is the affine image of a convex polygon; it may be
//! mirrored). A texel whose centre lies inside that polygon takes the field at the point of the
//! element with the same barycentric coordinates (elements in file order; a centre on an edge
//! shared by two elements goes to the first). An element too small to hold a texel centre
//! writes its centroid's value into the texel under its centroid, if that texel is still
//! empty. Then empty texels are dilated, ring by ring, `padding` rings deep, each taking the
//! mean of its filled 8-neighbours: the gutters the scene's unwrap left between charts stop
//! bilinear filtering from reading black at a chart's edge.

use glam::{DVec2, DVec3};
use lrr_formats::Geometry;

use super::charts::corners;
use super::raster::{Atlas, Texel, dilate_rings};

/// The element's corners in texel coordinates of a `width × height` atlas.
fn texel_corners(uv: &[f32], s: usize, count: usize, width: usize, height: usize) -> Vec<DVec2> {
    (0..count)
        .map(|c| {
            let at = 8 * s + 2 * c;
            DVec2::new(
                f64::from(uv[at]) * width as f64,
                f64::from(uv[at + 1]) * height as f64,
            )
        })
        .collect()
}

/// Barycentric coordinates of `p` in triangle `t`, None when it is degenerate.
fn barycentric(t: [DVec2; 3], p: DVec2) -> Option<[f64; 3]> {
    let d = (t[1] - t[0]).perp_dot(t[2] - t[0]);
    if d.abs()
        <= 1e-12
            * (t[1] - t[0])
                .length_squared()
                .max((t[2] - t[0]).length_squared())
    {
        return None;
    }
    let b1 = (p - t[0]).perp_dot(t[2] - t[0]) / d;
    let b2 = (t[1] - t[0]).perp_dot(p - t[0]) / d;
    Some([1.0 - b1 - b2, b1, b2])
}

/// The point of the element at atlas position `p`: the affine map of the element's first
/// non-degenerate corner triangle in the atlas onto the same corners in space.
fn lift(t: &[DVec2], pts: &[DVec3], p: DVec2) -> Option<DVec3> {
    (1..t.len() - 1).find_map(|i| {
        let w = barycentric([t[0], t[i], t[i + 1]], p)?;
        Some(w[0] * pts[0] + w[1] * pts[i] + w[2] * pts[i + 1])
    })
}

/// Whether `p` lies in the convex polygon `t` (either orientation), within 1e-9 texels.
fn inside(t: &[DVec2], p: DVec2) -> bool {
    let side = |k: usize| {
        let (a, b) = (t[k], t[(k + 1) % t.len()]);
        (b - a).perp_dot(p - a) / (b - a).length().max(f64::MIN_POSITIVE)
    };
    let tolerance = 1e-9;
    (0..t.len()).all(|k| side(k) >= -tolerance) || (0..t.len()).all(|k| side(k) <= tolerance)
}

/// Rasterises `value(display face, point)` (`None`: no value, dilate) over the coordinates
/// `uv` (section LIGHTMAP) into a `width × height` atlas with `padding` rings of dilation.
pub fn rasterise(
    g: &Geometry,
    uv: &[f32],
    width: usize,
    height: usize,
    padding: usize,
    value: &dyn Fn(usize, DVec3) -> Option<[f32; 3]>,
) -> Atlas {
    let mut atlas = Atlas {
        width,
        height,
        pixels: vec![[0.0; 3]; width * height],
        state: vec![Texel::Empty; width * height],
    };
    let mut unfilled = Vec::new();
    for s in 0..g.vertex_count.len() {
        if !fill_element(&mut atlas, g, uv, s, value) {
            unfilled.push(s);
        }
    }
    for s in unfilled {
        seed_centroid(&mut atlas, g, uv, s, value);
    }
    dilate_rings(&mut atlas, [0, 0, width, height], padding);
    atlas
}

/// Texels whose centres lie in element `s`'s atlas polygon that no earlier element took;
/// false when it holds no texel centre.
fn fill_element(
    atlas: &mut Atlas,
    g: &Geometry,
    uv: &[f32],
    s: usize,
    value: &dyn Fn(usize, DVec3) -> Option<[f32; 3]>,
) -> bool {
    let pts = corners(g, s);
    let t = texel_corners(uv, s, pts.len(), atlas.width, atlas.height);
    let lo = t.iter().fold(DVec2::INFINITY, |a, b| a.min(*b));
    let hi = t.iter().fold(DVec2::NEG_INFINITY, |a, b| a.max(*b));
    // Texel centres x + 0.5 within [lo, hi], clipped to the atlas (coordinates outside [0, 1]
    // have no texel here).
    let span = |lo: f64, hi: f64, n: usize| {
        let first = (lo - 0.5).ceil().max(0.0);
        let last = (hi - 0.5).floor().min(n as f64 - 1.0);
        (first as i64)..(last as i64 + 1)
    };
    let (xs, ys) = (
        span(lo.x, hi.x, atlas.width),
        span(lo.y, hi.y, atlas.height),
    );
    let mut any = false;
    for y in ys.map(|y| y as usize) {
        for x in xs.clone().map(|x| x as usize) {
            let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            if !inside(&t, p) {
                continue;
            }
            any = true;
            let i = y * atlas.width + x;
            if atlas.state[i] != Texel::Empty {
                continue;
            }
            if let Some(v) = lift(&t, &pts, p).and_then(|q| value(s, q)) {
                atlas.pixels[i] = v;
                atlas.state[i] = Texel::Inside;
            }
        }
    }
    any
}

/// An element that holds no texel centre: its centroid's value in the texel under its
/// centroid, if that texel is in the atlas and still empty.
fn seed_centroid(
    atlas: &mut Atlas,
    g: &Geometry,
    uv: &[f32],
    s: usize,
    value: &dyn Fn(usize, DVec3) -> Option<[f32; 3]>,
) {
    let pts = corners(g, s);
    let t = texel_corners(uv, s, pts.len(), atlas.width, atlas.height);
    let c = t.iter().sum::<DVec2>() / t.len() as f64;
    if !(c.x >= 0.0 && c.y >= 0.0 && c.x < atlas.width as f64 && c.y < atlas.height as f64) {
        return;
    }
    let i = c.y as usize * atlas.width + c.x as usize;
    if atlas.state[i] != Texel::Empty {
        return;
    }
    let centroid = pts.iter().sum::<DVec3>() / pts.len() as f64;
    if let Some(v) = value(s, centroid) {
        atlas.pixels[i] = v;
        atlas.state[i] = Texel::Dilated;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One quad element, the unit square at z = 0, whose lightmap coordinates put it in the
    /// left half of the atlas, mirrored in u.
    fn quad() -> (Geometry, Vec<f32>) {
        let g = Geometry {
            vertex_count: vec![4],
            vertices: vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
            normals: vec![0.0, 0.0, 1.0],
        };
        // x → u = 0.5 − x/2 (mirrored), y → v = 1 − y.
        let uv = vec![0.5, 1.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0];
        (g, uv)
    }

    #[test]
    fn texels_take_the_value_at_the_point_they_cover() {
        let (g, uv) = quad();
        // The value is the point's x: texel column i of 8 covers u in [i/8, (i+1)/8), whose
        // centre is x = 1 − 2 (i + 0.5) / 8.
        let atlas = rasterise(&g, &uv, 8, 4, 1, &|_, p| {
            Some([p.x as f32, p.y as f32, 0.0])
        });
        for y in 0..4 {
            for x in 0..4 {
                let i = y * 8 + x;
                assert_eq!(atlas.state[i], Texel::Inside, "({x}, {y})");
                let want_x = 1.0 - 2.0 * (x as f32 + 0.5) / 8.0;
                let want_y = 1.0 - (y as f32 + 0.5) / 4.0;
                assert!(
                    (atlas.pixels[i][0] - want_x).abs() < 1e-6,
                    "{:?}",
                    atlas.pixels[i]
                );
                assert!(
                    (atlas.pixels[i][1] - want_y).abs() < 1e-6,
                    "{:?}",
                    atlas.pixels[i]
                );
            }
            // One ring of dilation: the mean of the filled neighbours (the edge column, whose
            // x is one value); the rest stays empty.
            assert_eq!(atlas.state[y * 8 + 4], Texel::Dilated);
            assert_eq!(atlas.pixels[y * 8 + 4][0], atlas.pixels[y * 8 + 3][0]);
            assert_eq!(atlas.state[y * 8 + 5], Texel::Empty);
        }
    }

    #[test]
    fn an_element_smaller_than_a_texel_still_writes_its_texel() {
        let (g, mut uv) = quad();
        // Squeeze the quad into [0.15, 0.2]² of a 4 × 4 atlas: no texel centre (at 0.125,
        // 0.375, …) inside.
        for c in uv.iter_mut() {
            *c = if *c > 0.0 { 0.2 } else { 0.15 };
        }
        let atlas = rasterise(&g, &uv, 4, 4, 0, &|_, _| Some([1.0, 2.0, 3.0]));
        assert_eq!(atlas.state[0], Texel::Dilated);
        assert_eq!(atlas.pixels[0], [1.0, 2.0, 3.0]);
        assert_eq!(
            atlas.state.iter().filter(|s| **s != Texel::Empty).count(),
            1
        );
    }
}
