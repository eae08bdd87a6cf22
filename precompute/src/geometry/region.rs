//! Regions of a surface: one convex polygon, or the union of several (a patch built by
//! clustering the small faces of a dense mesh), with area-proportional sample points.

use glam::DVec3;

use super::Polygon;
use super::sampling::{Sample, map_unit_square, r2, shift};

/// A form-factor target: one convex polygon, or the union of several (a cluster patch).
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    parts: Vec<Polygon>,
    /// Running sums of the parts' areas (`parts.len() + 1` values from 0).
    cumulative: Vec<f64>,
}

impl Region {
    /// A region from its parts (at least one; the parts must not overlap).
    pub fn new(parts: Vec<Polygon>) -> Self {
        assert!(!parts.is_empty(), "a region has at least one part");
        let mut cumulative = Vec::with_capacity(parts.len() + 1);
        cumulative.push(0.0);
        let mut sum = 0.0;
        for p in &parts {
            sum += p.area();
            cumulative.push(sum);
        }
        Self { parts, cumulative }
    }

    /// A region of one polygon.
    pub fn single(p: Polygon) -> Self {
        Self::new(vec![p])
    }

    /// The polygons the region is made of.
    pub fn parts(&self) -> &[Polygon] {
        &self.parts
    }

    /// The polygon when the region has exactly one part.
    pub fn as_single(&self) -> Option<&Polygon> {
        match self.parts.as_slice() {
            [p] => Some(p),
            _ => None,
        }
    }

    /// Total area of the parts, in scene units².
    pub fn area(&self) -> f64 {
        self.cumulative[self.parts.len()]
    }

    /// Area-weighted centroid of the parts (may lie off the surface of a curved cluster).
    pub fn centroid(&self) -> DVec3 {
        let mut sum = DVec3::ZERO;
        for p in &self.parts {
            sum += p.area() * p.centroid();
        }
        sum / self.area()
    }

    /// The part whose centroid is nearest `x` (ties: the first), for a representative point.
    pub fn nearest_part(&self, x: DVec3) -> &Polygon {
        let mut best = &self.parts[0];
        let mut best_d = f64::INFINITY;
        for p in &self.parts {
            let d = p.centroid().distance_squared(x);
            if d < best_d {
                best_d = d;
                best = p;
            }
        }
        best
    }

    /// The `i`-th pair point on the union (R2 shifted by `seed`, the first coordinate choosing
    /// the part by area): the part's index and the sample, whose weight is the area density
    /// relative to uniform over the union (1 on average, like `sampling::pair_point`).
    pub fn pair_point(&self, i: u32, seed: u64) -> (usize, Sample) {
        let (u, w) = r2(i, shift(seed));
        let a = u * self.area();
        // first part whose running sum exceeds a
        let j = self.cumulative[1..]
            .partition_point(|&c| c <= a)
            .min(self.parts.len() - 1);
        let part = &self.parts[j];
        let (lo, area) = (self.cumulative[j], part.area());
        let u = ((a - lo) / area).clamp(0.0, 1.0);
        let mut s = map_unit_square(part.vertices(), u, w);
        if part.count == 4 {
            s.weight /= area; // the bilinear Jacobian relative to the part's area
        }
        (j, s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::rectangle as square;

    #[test]
    fn pair_points_cover_parts_by_area() {
        let t = Region::new(vec![
            square(0.0, 1.0, 0.0, 1.0, 0.0, false),
            square(2.0, 5.0, 0.0, 1.0, 0.0, false),
        ]);
        let mut counts = [0usize; 2];
        let mut weight = 0.0;
        for i in 0..4000 {
            let (j, s) = t.pair_point(i, 7);
            counts[j] += 1;
            weight += s.weight;
            let p = &t.parts()[j];
            assert!(p.height(s.point).abs() < 1e-12);
        }
        let share = counts[1] as f64 / 4000.0;
        assert!((share - 0.75).abs() < 0.01, "{share}");
        assert!((weight / 4000.0 - 1.0).abs() < 1e-9, "{}", weight / 4000.0);
    }
}
