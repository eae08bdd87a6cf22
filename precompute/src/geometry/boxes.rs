//! Axis-aligned boxes indexed for overlap queries: a hierarchy of uniform grids.
//!
//! Each box goes to the level whose cells are the smallest at least as large as its longest
//! side (cells double from level to level, level 0 at the median box's longest side), so it
//! lies in at most 2 × 2 × 2 cells of its level: the index holds at most 8 entries per box,
//! whatever the boxes' sizes. A query visits the cells its box meets on every level that holds
//! boxes, or scans that level's boxes where it would meet more cells than the level has boxes
//! (a room's wall among millimetre details): a query costs at most what a scan of every box
//! would, and about the number of boxes near it where boxes are of similar size (the
//! triangles of a tessellated surface).

use glam::DVec3;
use rustc_hash::FxHashMap;

/// Whether the closed boxes `a` and `b` (lower, upper corner) meet: overlap or touch. What
/// callers test [`BoxGrid::candidates`] with.
pub(crate) fn overlaps(a: (DVec3, DVec3), b: (DVec3, DVec3)) -> bool {
    a.0.cmple(b.1).all() && b.0.cmple(a.1).all()
}

/// The index; queries answer box indices (`u32`).
pub(crate) struct BoxGrid {
    /// Corner of every level's cell (0, 0, 0).
    origin: DVec3,
    levels: Vec<Level>,
    /// Boxes in no cell (larger than the last level's cells, or not finite): every query
    /// answers them.
    unplaced: Vec<u32>,
}

/// The boxes of one cell size.
struct Level {
    cell: f64,
    /// Its boxes in increasing index (scanned when a query meets too many cells).
    boxes: Vec<u32>,
    /// Per occupied cell, its range in `entries`.
    cells: FxHashMap<[i64; 3], (u32, u32)>,
    entries: Vec<u32>,
}

/// Most levels: cells from the median box's side up to 2^60 times larger (a longer side, or a
/// box that is not finite, is in no cell).
const MAX_LEVELS: usize = 61;

impl BoxGrid {
    /// Indexes `boxes` (lower, upper corner); box `i` is answered as `i`.
    pub(crate) fn new(boxes: &[(DVec3, DVec3)]) -> Self {
        let side = |(lo, hi): &(DVec3, DVec3)| (*hi - *lo).max_element();
        let mut sides: Vec<f64> = boxes.iter().map(side).filter(|s| s.is_finite()).collect();
        sides.sort_by(f64::total_cmp);
        let median = sides.get(sides.len() / 2).copied().unwrap_or(1.0);
        let largest = sides.last().copied().unwrap_or(1.0);
        // Level 0's cells: the median side, else (points, lines) a sliver of the largest.
        let base = if median > 0.0 {
            median
        } else if largest > 0.0 {
            largest * 1e-6
        } else {
            1.0
        };
        let origin = boxes
            .iter()
            .map(|b| b.0)
            .filter(|o| o.is_finite())
            .fold(DVec3::splat(f64::INFINITY), DVec3::min);
        let origin = if origin.is_finite() {
            origin
        } else {
            DVec3::ZERO
        };
        let mut levels: Vec<Level> = Vec::new();
        let mut pairs: Vec<Vec<([i64; 3], u32)>> = Vec::new();
        let mut unplaced = Vec::new();
        for (i, b) in boxes.iter().enumerate() {
            let s = side(b);
            let Some(l) = (0..MAX_LEVELS).find(|&l| s <= base * 2f64.powi(l as i32)) else {
                unplaced.push(i as u32);
                continue;
            };
            while levels.len() <= l {
                levels.push(Level {
                    cell: base * 2f64.powi(levels.len() as i32),
                    boxes: Vec::new(),
                    cells: FxHashMap::default(),
                    entries: Vec::new(),
                });
                pairs.push(Vec::new());
            }
            let (a, z) = levels[l].range(origin, *b);
            // At most 2 × 2 × 2 cells (more only where rounding or coordinates too large for
            // the cells' integers say so: then in no cell).
            if !b.0.is_finite() || !b.1.is_finite() || cells_in(a, z) > 8.0 {
                unplaced.push(i as u32);
                continue;
            }
            levels[l].boxes.push(i as u32);
            for x in a[0]..=z[0] {
                for y in a[1]..=z[1] {
                    for w in a[2]..=z[2] {
                        pairs[l].push(([x, y, w], i as u32));
                    }
                }
            }
        }
        for (level, mut pairs) in levels.iter_mut().zip(pairs) {
            pairs.sort_unstable();
            level.entries = pairs.iter().map(|&(_, i)| i).collect();
            let mut start = 0;
            while start < pairs.len() {
                let key = pairs[start].0;
                let end = start + pairs[start..].partition_point(|p| p.0 == key);
                level.cells.insert(key, (start as u32, end as u32));
                start = end;
            }
        }
        Self {
            origin,
            levels,
            unplaced,
        }
    }

    /// A superset of the boxes that meet the box `query` (lower, upper corner), in no
    /// particular order and possibly with repeats: the caller tests each and drops repeats.
    pub(crate) fn candidates(&self, query: (DVec3, DVec3)) -> Vec<u32> {
        let mut out = self.unplaced.clone();
        for level in &self.levels {
            if level.boxes.is_empty() {
                continue;
            }
            let (a, z) = level.range(self.origin, query);
            if cells_in(a, z) > level.boxes.len() as f64 {
                out.extend_from_slice(&level.boxes);
                continue;
            }
            for x in a[0]..=z[0] {
                for y in a[1]..=z[1] {
                    for w in a[2]..=z[2] {
                        if let Some(&(s, e)) = level.cells.get(&[x, y, w]) {
                            out.extend_from_slice(&level.entries[s as usize..e as usize]);
                        }
                    }
                }
            }
        }
        out
    }
}

impl Level {
    /// The first and last cell a box meets on this level.
    fn range(&self, origin: DVec3, (lo, hi): (DVec3, DVec3)) -> ([i64; 3], [i64; 3]) {
        let at = |x: DVec3| ((x - origin) / self.cell).floor().as_i64vec3().to_array();
        (at(lo), at(hi))
    }
}

/// How many cells lie from `a` to `z` (0 when the range is empty), in f64 (no overflow).
fn cells_in(a: [i64; 3], z: [i64; 3]) -> f64 {
    (0..3)
        .map(|i| (z[i] as f64 - a[i] as f64 + 1.0).max(0.0))
        .product()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a scan of every box: boxes of sizes over six orders of magnitude, points and
    /// lines among them, queries small and large.
    #[test]
    fn finds_every_box_a_scan_finds() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut boxes = Vec::new();
        for i in 0..3000 {
            let lo = DVec3::new(next(), next(), next()) * 100.0;
            let size = match i % 5 {
                0 => 0.0,
                1 => 1e-4,
                2 => 0.1,
                3 => 3.0,
                _ => 80.0,
            };
            let d = DVec3::new(next(), next(), next()) * size;
            let d = if i % 7 == 0 {
                DVec3::new(d.x, 0.0, 0.0)
            } else {
                d
            };
            boxes.push((lo, lo + d));
        }
        let grid = BoxGrid::new(&boxes);
        for q in 0..400 {
            let lo = DVec3::new(next(), next(), next()) * 100.0;
            let size = [0.0, 0.01, 1.0, 20.0, 200.0][q % 5];
            let query = (lo, lo + DVec3::new(next(), next(), next()) * size);
            let mut found: Vec<u32> = grid
                .candidates(query)
                .into_iter()
                .filter(|&i| overlaps(query, boxes[i as usize]))
                .collect();
            found.sort_unstable();
            found.dedup();
            let all: Vec<u32> = (0..boxes.len() as u32)
                .filter(|&i| overlaps(query, boxes[i as usize]))
                .collect();
            assert_eq!(found, all, "query {q}");
        }
    }

    #[test]
    fn no_boxes_and_one_point() {
        assert!(
            BoxGrid::new(&[])
                .candidates((DVec3::ZERO, DVec3::ONE))
                .is_empty()
        );
        let p = DVec3::splat(2.0);
        let grid = BoxGrid::new(&[(p, p)]);
        assert_eq!(grid.candidates((p, p)), vec![0]);
    }
}
