//! Packing charts into a lightmap atlas with etagere's shelf allocator: each chart gets a
//! rectangle of `ceil(size × density)` texels plus `padding` on every side. etagere numbers its
//! shelves and items in 16 bits, so past [`ETAGERE_CHARTS`] charts (a curved surface of 10⁵
//! triangles is 10⁵ charts) they go on shelves of our own instead ([`shelves`]: tallest first,
//! left to right, a new shelf when a row is full). Either the atlas
//! size is given (the largest density that packs, by bisection) or the density is (the
//! smallest square atlas, a multiple of 4 texels, that packs). Errors are messages without
//! flag names: the bake and `lrr export` say which of their flags set the size.

use etagere::{AllocatorOptions, AtlasAllocator, size2};
use glam::DVec2;

use super::charts::Chart;

/// The largest atlas side tried for a given texel density.
pub const MAX_SIZE: usize = 16384;

/// The most charts packed with etagere, whose items (allocated rectangles and the free ones
/// between them) are numbered in 16 bits: half of those numbers.
pub const ETAGERE_CHARTS: usize = 1 << 15;

/// Where the charts lie in the atlas.
#[derive(Debug, Clone)]
pub struct Layout {
    /// Atlas width in texels.
    pub width: usize,
    /// Atlas height in texels.
    pub height: usize,
    /// Texels per scene unit.
    pub density: f64,
    /// Texels of padding around each chart.
    pub padding: usize,
    /// Per chart: the texel coordinates of its origin (chart point (0, 0)), and its rectangle
    /// (padding included) as `[x0, y0, x1, y1]`, exclusive upper bounds.
    pub origins: Vec<DVec2>,
    /// See `origins`.
    pub rects: Vec<[usize; 4]>,
}

impl Layout {
    /// Texel coordinates (texel `i` spans `[i, i + 1)`) of chart point `q` of chart `c`.
    pub fn texel(&self, c: usize, q: DVec2) -> DVec2 {
        self.origins[c] + q * self.density
    }

    /// Chart coordinates of texel coordinates `t` in chart `c`.
    pub fn chart_point(&self, c: usize, t: DVec2) -> DVec2 {
        (t - self.origins[c]) / self.density
    }

    /// Normalised texture coordinates (glTF's: `(0, 0)` the top left of the first row).
    pub fn uv(&self, c: usize, q: DVec2) -> [f32; 2] {
        let t = self.texel(c, q);
        [
            (t.x / self.width as f64) as f32,
            (t.y / self.height as f64) as f32,
        ]
    }
}

/// How big the atlas is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sizing {
    /// A square atlas of this many texels a side; the density follows.
    Size(usize),
    /// Texels per scene unit; the (square) atlas size follows.
    Density(f64),
}

/// An error of [`pack`]: what does not fit and how to make it fit.
type Result<T> = std::result::Result<T, String>;

macro_rules! bail {
    ($($t:tt)*) => {
        return Err(format!($($t)*))
    };
}

/// Packs `charts` as `sizing` asks.
pub fn pack(charts: &[Chart], sizing: Sizing, padding: usize) -> Result<Layout> {
    if charts.is_empty() {
        bail!("no charts to pack (no display faces)");
    }
    match sizing {
        Sizing::Size(side) => pack_size(charts, side, padding),
        Sizing::Density(density) => pack_density(charts, density, padding),
    }
}

fn pack_size(charts: &[Chart], side: usize, padding: usize) -> Result<Layout> {
    if !(1..=MAX_SIZE).contains(&side) {
        bail!("an atlas of {side} texels a side: the side must be 1 to {MAX_SIZE} texels");
    }
    // Densities are bisected on a log scale between one that surely fits nothing larger than a
    // texel per chart and one that surely does not fit.
    let largest = charts
        .iter()
        .map(|c| c.size.max_element())
        .fold(0.0, f64::max);
    let mut lo = 1e-9 / largest.max(f64::MIN_POSITIVE);
    let Some(mut best) = try_pack(charts, side, side, lo, padding) else {
        let tiny = 1 + 2 * padding;
        bail!(
            "an atlas of {side}×{side} texels: {} charts of at least {tiny}×{tiny} texels \
             (padding {padding}) do not fit; use a larger atlas or a smaller padding",
            charts.len()
        );
    };
    let mut hi = side as f64 / largest.max(f64::MIN_POSITIVE) + 1.0;
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        match try_pack(charts, side, side, mid, padding) {
            Some(layout) => {
                lo = mid;
                best = layout;
            }
            None => hi = mid,
        }
        if hi / lo < 1.0 + 1e-4 {
            break;
        }
    }
    Ok(best)
}

fn pack_density(charts: &[Chart], density: f64, padding: usize) -> Result<Layout> {
    if !(density.is_finite() && density > 0.0) {
        bail!("texel density {density}: must be a finite number > 0 (texels per scene unit)");
    }
    let area: f64 = charts
        .iter()
        .map(|c| {
            let [w, h] = rect_size(c.size, density, padding);
            (w * h) as f64
        })
        .sum();
    let mut side = (area.sqrt().ceil() as usize).next_multiple_of(4);
    while side <= MAX_SIZE {
        if let Some(layout) = try_pack(charts, side, side, density, padding) {
            return Ok(layout);
        }
        side = ((side as f64 * 1.05).ceil() as usize).next_multiple_of(4);
    }
    bail!(
        "texel density {density}: the charts need an atlas larger than {MAX_SIZE}² texels; \
         use a smaller density"
    )
}

/// Rectangle size in texels of a chart of `size` scene units.
fn rect_size(size: DVec2, density: f64, padding: usize) -> [usize; 2] {
    let texels = |x: f64| ((x * density).ceil() as usize).max(1) + 2 * padding;
    [texels(size.x), texels(size.y)]
}

/// The layout at `density`, if every chart fits: charts are allocated tallest first (then
/// widest, then in chart order), which suits shelf packing.
fn try_pack(
    charts: &[Chart],
    width: usize,
    height: usize,
    density: f64,
    padding: usize,
) -> Option<Layout> {
    let sizes: Vec<[usize; 2]> = charts
        .iter()
        .map(|c| rect_size(c.size, density, padding))
        .collect();
    if sizes.iter().any(|&[w, h]| w > width || h > height) {
        return None;
    }
    let mut order: Vec<usize> = (0..charts.len()).collect();
    order.sort_by_key(|&c| {
        (
            std::cmp::Reverse(sizes[c][1]),
            std::cmp::Reverse(sizes[c][0]),
            c,
        )
    });
    let rects = if charts.len() > ETAGERE_CHARTS {
        shelves(&sizes, &order, width, height)?
    } else {
        let options = AllocatorOptions {
            num_columns: 1,
            ..etagere::DEFAULT_OPTIONS
        };
        let mut atlas = AtlasAllocator::with_options(size2(width as i32, height as i32), &options);
        let mut rects = vec![[0; 4]; charts.len()];
        for c in order {
            let [w, h] = sizes[c];
            let a = atlas.allocate(size2(w as i32, h as i32))?;
            let (x0, y0) = (a.rectangle.min.x as usize, a.rectangle.min.y as usize);
            rects[c] = [x0, y0, x0 + w, y0 + h];
        }
        rects
    };
    let origins = rects
        .iter()
        .map(|r| DVec2::new((r[0] + padding) as f64, (r[1] + padding) as f64))
        .collect();
    Some(Layout {
        width,
        height,
        density,
        padding,
        origins,
        rects,
    })
}

/// Rectangles of `sizes` (`[w, h]` texels, each at most `width × height`) placed in `order`
/// (tallest first) on shelves: left to right along the current shelf, whose height is its
/// first rectangle's, and a new shelf above it when the next does not fit in the row. `None`
/// when the shelves outgrow `height`.
fn shelves(
    sizes: &[[usize; 2]],
    order: &[usize],
    width: usize,
    height: usize,
) -> Option<Vec<[usize; 4]>> {
    let mut rects = vec![[0; 4]; sizes.len()];
    let (mut x, mut y, mut shelf) = (0usize, 0usize, 0usize);
    for &c in order {
        let [w, h] = sizes[c];
        if x + w > width {
            y += shelf;
            (x, shelf) = (0, 0);
        }
        if shelf == 0 {
            shelf = h;
        }
        if y + h > height {
            return None;
        }
        rects[c] = [x, y, x + w, y + h];
        x += w;
    }
    Some(rects)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn chart(w: f64, h: f64) -> Chart {
        Chart {
            faces: vec![0],
            origin: DVec3::ZERO,
            u: DVec3::X,
            v: DVec3::Y,
            size: DVec2::new(w, h),
        }
    }

    fn disjoint(l: &Layout) -> bool {
        l.rects.iter().enumerate().all(|(i, a)| {
            a[2] <= l.width
                && a[3] <= l.height
                && l.rects[i + 1..]
                    .iter()
                    .all(|b| a[2] <= b[0] || b[2] <= a[0] || a[3] <= b[1] || b[3] <= a[1])
        })
    }

    #[test]
    fn a_given_size_packs_disjoint_rectangles_near_the_largest_density() {
        let charts: Vec<Chart> = (0..20).map(|i| chart(1.0 + i as f64 * 0.1, 0.5)).collect();
        let l = pack(&charts, Sizing::Size(256), 2).unwrap();
        assert!(disjoint(&l));
        // A few percent more density no longer fits.
        assert!(try_pack(&charts, 256, 256, l.density * 1.05, 2).is_none());
        // The chart's corners map inside its rectangle, padding kept.
        let r = l.rects[3];
        let t = l.texel(3, charts[3].size);
        assert!(t.x <= (r[2] - 2) as f64 && t.y <= (r[3] - 2) as f64);
    }

    #[test]
    fn a_given_density_picks_a_size_that_fits() {
        let charts: Vec<Chart> = (0..10).map(|_| chart(3.0, 2.0)).collect();
        let l = pack(&charts, Sizing::Density(10.0), 1).unwrap();
        assert_eq!(l.density, 10.0);
        assert!(disjoint(&l));
        assert_eq!(l.rects[0][2] - l.rects[0][0], 32);
        // 10 charts of 32×22 texels: at least 7040 texels.
        assert!(l.width * l.height >= 7040 && l.width <= 128, "{}", l.width);
    }

    /// More charts than etagere numbers (a curved surface of 10⁵ triangles): shelves of our
    /// own, disjoint, near the largest density, as many texels as the rectangles need within a
    /// shelf's waste.
    #[test]
    fn more_charts_than_etagere_holds_go_on_shelves() {
        let charts: Vec<Chart> = (0..100_000)
            .map(|i| chart(0.01 + (i % 7) as f64 * 0.002, 0.01 + (i % 5) as f64 * 0.003))
            .collect();
        let l = pack(&charts, Sizing::Size(2048), 1).unwrap();
        assert_eq!(l.rects.len(), 100_000);
        assert!(disjoint_sorted(&l));
        assert!(try_pack(&charts, 2048, 2048, l.density * 1.05, 1).is_none());
        let used: usize = l.rects.iter().map(|r| (r[2] - r[0]) * (r[3] - r[1])).sum();
        assert!(
            used as f64 > 0.8 * (2048.0 * 2048.0),
            "{used} texels of 2048²"
        );
    }

    /// [`disjoint`] for many rectangles: sorted by row band, neighbours only.
    fn disjoint_sorted(l: &Layout) -> bool {
        let mut r = l.rects.clone();
        if r.iter().any(|a| a[2] > l.width || a[3] > l.height) {
            return false;
        }
        r.sort();
        // Each rectangle against those that start before it ends, left to right.
        (0..r.len()).all(|i| {
            r[i + 1..]
                .iter()
                .take_while(|b| b[0] < r[i][2])
                .all(|b| r[i][3] <= b[1] || b[3] <= r[i][1])
        })
    }

    #[test]
    fn too_small_an_atlas_is_an_error_naming_the_flags() {
        let charts: Vec<Chart> = (0..100).map(|_| chart(1.0, 1.0)).collect();
        let e = pack(&charts, Sizing::Size(8), 2).unwrap_err().to_string();
        assert!(e.contains("8×8 texels") && e.contains("100 charts"), "{e}");
        let e = pack(&charts, Sizing::Density(f64::NAN), 2)
            .unwrap_err()
            .to_string();
        assert!(e.contains("texel density NaN"), "{e}");
    }
}
