//! A simple BVH builder for tests and benchmarks (the runtime itself never builds one: files
//! carry theirs). Binned SAH (16 bins on the longest centroid axis, leaves of at most 4
//! triangles), children allocated side by side as the file's [`Bvh`] requires, iterative.

use lrr_formats::{Bvh, BvhNode, Geometry};

const BINS: usize = 16;
const LEAF: usize = 4;

#[derive(Clone, Copy)]
struct Bounds {
    min: [f32; 3],
    max: [f32; 3],
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    fn grow(&mut self, p: [f32; 3]) {
        for a in 0..3 {
            self.min[a] = self.min[a].min(p[a]);
            self.max[a] = self.max[a].max(p[a]);
        }
    }

    fn join(&mut self, o: &Bounds) {
        self.grow(o.min);
        self.grow(o.max);
    }

    fn area(&self) -> f32 {
        let d = [
            (self.max[0] - self.min[0]).max(0.0),
            (self.max[1] - self.min[1]).max(0.0),
            (self.max[2] - self.min[2]).max(0.0),
        ];
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// A BVH over `geometry`'s display triangles (fan triangles in id order).
pub fn build(geometry: &Geometry) -> Bvh {
    let tris: Vec<Bounds> = geometry
        .triangles()
        .map(|(_, t)| {
            let mut b = Bounds::EMPTY;
            t.iter().for_each(|&p| b.grow(p));
            b
        })
        .collect();
    let centre = |t: u32, a: usize| {
        let b = &tris[t as usize];
        0.5 * (b.min[a] + b.max[a])
    };
    let mut ids: Vec<u32> = (0..tris.len() as u32).collect();
    if ids.is_empty() {
        return Bvh::default();
    }
    let mut nodes = vec![leaf(Bounds::EMPTY, 0, 0)];
    let mut work = vec![(0usize, 0usize, ids.len())];
    while let Some((node, start, end)) = work.pop() {
        let mut bounds = Bounds::EMPTY;
        let mut cb = Bounds::EMPTY;
        for &t in &ids[start..end] {
            bounds.join(&tris[t as usize]);
            cb.grow([centre(t, 0), centre(t, 1), centre(t, 2)]);
        }
        nodes[node] = leaf(bounds, start, end - start);
        if end - start <= LEAF {
            continue;
        }
        let extent = [0, 1, 2].map(|a| cb.max[a] - cb.min[a]);
        let axis = (0..3).fold(0, |m, a| if extent[a] > extent[m] { a } else { m });
        let mid = if extent[axis] > 0.0 {
            sah_split(
                &mut ids[start..end],
                &tris,
                axis,
                cb.min[axis],
                extent[axis],
                centre,
            )
        } else {
            (end - start) / 2
        };
        let mid = start + mid.clamp(1, end - start - 1);
        let c = nodes.len();
        nodes.push(leaf(Bounds::EMPTY, 0, 0));
        nodes.push(leaf(Bounds::EMPTY, 0, 0));
        nodes[node].first = c as u32;
        nodes[node].count = 0;
        work.push((c, start, mid));
        work.push((c + 1, mid, end));
    }
    Bvh {
        nodes,
        triangles: ids,
    }
}

fn leaf(b: Bounds, first: usize, count: usize) -> BvhNode {
    BvhNode {
        min: b.min,
        max: b.max,
        first: first as u32,
        count: count as u32,
    }
}

/// Partitions `ids` at the cheapest of the `BINS - 1` bin boundaries on `axis`; returns the
/// size of the left part (may be 0 or all when every triangle falls in one bin).
fn sah_split(
    ids: &mut [u32],
    tris: &[Bounds],
    axis: usize,
    lo: f32,
    extent: f32,
    centre: impl Fn(u32, usize) -> f32,
) -> usize {
    let bin = |t: u32| (((centre(t, axis) - lo) / extent * BINS as f32) as usize).min(BINS - 1);
    let mut boxes = [Bounds::EMPTY; BINS];
    let mut counts = [0usize; BINS];
    for &t in ids.iter() {
        boxes[bin(t)].join(&tris[t as usize]);
        counts[bin(t)] += 1;
    }
    let mut best = (f32::INFINITY, BINS / 2);
    for split in 1..BINS {
        let (mut l, mut r) = (Bounds::EMPTY, Bounds::EMPTY);
        let (mut nl, mut nr) = (0, 0);
        for b in 0..split {
            l.join(&boxes[b]);
            nl += counts[b];
        }
        for b in split..BINS {
            r.join(&boxes[b]);
            nr += counts[b];
        }
        if nl == 0 || nr == 0 {
            continue;
        }
        let cost = l.area() * nl as f32 + r.area() * nr as f32;
        if cost < best.0 {
            best = (cost, split);
        }
    }
    if best.0 == f32::INFINITY {
        return ids.len() / 2;
    }
    // Stable partition: the tree does not depend on anything but the input.
    let (left, right): (Vec<u32>, Vec<u32>) = ids.iter().partition(|&&t| bin(t) < best.1);
    let n = left.len();
    ids[..n].copy_from_slice(&left);
    ids[n..].copy_from_slice(&right);
    n
}
