//! Rasterising a field into the atlas: every texel whose centre lies inside an element (here: a
//! display face of the file, see `charts.rs`) takes the field's value at that centre (elements
//! in order; a centre on a shared edge goes to
//! the first; an element without a value, such as one hidden under a block, is left to
//! dilation like the space between charts); then each chart's rectangle is dilated, ring by ring, until every texel in it
//! (padding included) holds the mean of its filled 8-neighbours, so bilinear filtering at a
//! chart's edge never reads an empty texel. A chart too small to hold a texel centre gets its
//! first element's centroid value at the texel under that centroid.

use glam::{DVec2, DVec3};
use lrr_formats::Geometry;

use super::atlas::Layout;
use super::charts::{Chart, corners};

/// How a texel got its value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Texel {
    /// Outside every chart's rectangle.
    Empty,
    /// Its centre lies in an element: the field's value there.
    Inside,
    /// Filled by dilation from its neighbours (or, for a chart smaller than a texel, the chart's
    /// centroid value).
    Dilated,
}

/// An RGB atlas, rows top to bottom.
#[derive(Debug, Clone)]
pub struct Atlas {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[f32; 3]>,
    pub state: Vec<Texel>,
}

/// Rasterises `value(display face, point)` (`None`: no value, dilate) over `charts` laid out
/// by `layout`.
pub fn rasterise(
    g: &Geometry,
    charts: &[Chart],
    layout: &Layout,
    value: &dyn Fn(usize, DVec3) -> Option<[f32; 3]>,
) -> Atlas {
    let (w, h) = (layout.width, layout.height);
    let mut atlas = Atlas {
        width: w,
        height: h,
        pixels: vec![[0.0; 3]; w * h],
        state: vec![Texel::Empty; w * h],
    };
    for (c, chart) in charts.iter().enumerate() {
        for &s in &chart.faces {
            fill_element(&mut atlas, g, chart, layout, c, s as usize, value);
        }
        let r = layout.rects[c];
        let inside =
            (r[1]..r[3]).any(|y| (r[0]..r[2]).any(|x| atlas.state[y * w + x] == Texel::Inside));
        if !inside {
            seed_centroid(&mut atlas, g, chart, layout, c, value);
        }
        dilate(&mut atlas, r);
    }
    atlas
}

/// Texels whose centres lie in element `s` (convex, counter-clockwise around the chart's
/// normal) that no earlier element took.
fn fill_element(
    atlas: &mut Atlas,
    g: &Geometry,
    chart: &Chart,
    layout: &Layout,
    c: usize,
    s: usize,
    value: &dyn Fn(usize, DVec3) -> Option<[f32; 3]>,
) {
    let t: Vec<DVec2> = corners(g, s)
        .iter()
        .map(|p| layout.texel(c, chart.flatten(*p)))
        .collect();
    let lo = t.iter().fold(DVec2::INFINITY, |a, b| a.min(*b));
    let hi = t.iter().fold(DVec2::NEG_INFINITY, |a, b| a.max(*b));
    let r = layout.rects[c].map(|v| v as i64);
    let xs = ((lo.x - 0.5).ceil() as i64).max(r[0])..=((hi.x - 0.5).floor() as i64).min(r[2] - 1);
    let ys = ((lo.y - 0.5).ceil() as i64).max(r[1])..=((hi.y - 0.5).floor() as i64).min(r[3] - 1);
    // Edge functions, scaled by the edge length: a centre within 1e-9 texels of an edge is in.
    let tolerance = 1e-9;
    for y in ys.map(|y| y as usize) {
        for x in xs.clone().map(|x| x as usize) {
            let i = y * atlas.width + x;
            if atlas.state[i] != Texel::Empty {
                continue;
            }
            let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            let inside = (0..t.len()).all(|k| {
                let (a, b) = (t[k], t[(k + 1) % t.len()]);
                (b - a).perp_dot(p - a) / (b - a).length().max(f64::MIN_POSITIVE) >= -tolerance
            });
            if !inside {
                continue;
            }
            let point = chart.lift(layout.chart_point(c, p));
            if let Some(v) = value(s, point) {
                atlas.pixels[i] = v;
                atlas.state[i] = Texel::Inside;
            }
        }
    }
}

/// For a chart that holds no texel centre with a value: its first element's value at its
/// centroid (zero if the chart has no value anywhere), at the texel under that centroid.
fn seed_centroid(
    atlas: &mut Atlas,
    g: &Geometry,
    chart: &Chart,
    layout: &Layout,
    c: usize,
    value: &dyn Fn(usize, DVec3) -> Option<[f32; 3]>,
) {
    let s = chart.faces[0] as usize;
    let pts = corners(g, s);
    let centroid = pts.iter().sum::<DVec3>() / pts.len() as f64;
    let t = layout.texel(c, chart.flatten(centroid));
    let r = layout.rects[c];
    let x = (t.x.floor() as usize).clamp(r[0], r[2] - 1);
    let y = (t.y.floor() as usize).clamp(r[1], r[3] - 1);
    let i = y * atlas.width + x;
    atlas.pixels[i] = value(s, centroid).unwrap_or([0.0; 3]);
    atlas.state[i] = Texel::Dilated;
}

/// Fills the empty texels of rectangle `r` ring by ring from their filled 8-neighbours.
fn dilate(atlas: &mut Atlas, r: [usize; 4]) {
    dilate_rings(atlas, r, usize::MAX);
}

/// [`dilate`], at most `rings` rings deep.
pub fn dilate_rings(atlas: &mut Atlas, r: [usize; 4], rings: usize) {
    let w = atlas.width;
    for _ in 0..rings {
        let mut next = Vec::new();
        for y in r[1]..r[3] {
            for x in r[0]..r[2] {
                if atlas.state[y * w + x] != Texel::Empty {
                    continue;
                }
                let mut sum = [0.0f64; 3];
                let mut count = 0;
                for (dx, dy) in NEIGHBOURS {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx < r[0] as i64
                        || ny < r[1] as i64
                        || nx >= r[2] as i64
                        || ny >= r[3] as i64
                    {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if atlas.state[j] != Texel::Empty {
                        for k in 0..3 {
                            sum[k] += f64::from(atlas.pixels[j][k]);
                        }
                        count += 1;
                    }
                }
                if count > 0 {
                    next.push((y * w + x, sum.map(|v| (v / count as f64) as f32)));
                }
            }
        }
        if next.is_empty() {
            return;
        }
        for (i, v) in next {
            atlas.pixels[i] = v;
            atlas.state[i] = Texel::Dilated;
        }
    }
}

const NEIGHBOURS: [(i64, i64); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];
