//! The boundary between solid and room air of a union of boxes, as rectangles.
//!
//! Every coordinate of every box cuts its axis; the cuts make a rectilinear grid of cells,
//! each wholly solid or wholly air (decided at its centre, exactly: coordinates are integers).
//! A face lies between a solid cell and an air cell of a room (air outside every room is the
//! outside, whose faces are left out), facing the air. Faces of one plane, side and label
//! are merged greedily into maximal rectangles, in a fixed order: the same plan gives the
//! same rectangles.

use super::plan::{Cuboid, Kind};

/// What a cell holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cell {
    /// A solid of this kind.
    Solid(Kind),
    /// The air of room `r`, or outside (`None`).
    Air(Option<usize>),
}

/// A face between a solid and the air of a room.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Face {
    /// The solid's kind.
    pub kind: Kind,
    /// The room whose air it faces.
    pub room: usize,
    /// The axis of its normal and the normal's sign along it.
    pub axis: usize,
    pub positive: bool,
}

/// A merged rectangle: its label, the axis and sign of its normal, and its box (flat along
/// `axis`), in centimetres.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect<L> {
    pub label: L,
    pub axis: usize,
    pub positive: bool,
    pub min: [i32; 3],
    pub max: [i32; 3],
}

/// The grid: cuts per axis and the cell states.
pub struct Grid {
    cuts: [Vec<i32>; 3],
    cells: Vec<Cell>,
}

fn contains(c: &Cuboid, p: [i64; 3]) -> bool {
    (0..3).all(|a| 2 * i64::from(c.min[a]) < p[a] && p[a] < 2 * i64::from(c.max[a]))
}

impl Grid {
    /// The cells of `solids` (the first that holds a point wins) with `openings` carved out
    /// of the structure, air labelled by the `rooms`' boxes, then by the openings' rooms.
    pub fn new(
        solids: &[(Kind, Cuboid)],
        openings: &[(usize, Cuboid)],
        rooms: &[Cuboid],
        marks: &[Cuboid],
    ) -> Self {
        let boxes = || {
            solids
                .iter()
                .map(|s| &s.1)
                .chain(openings.iter().map(|o| &o.1))
                .chain(rooms)
                .chain(marks)
        };
        let cuts: [Vec<i32>; 3] = [0, 1, 2].map(|a| {
            let mut c: Vec<i32> = boxes().flat_map(|b| [b.min[a], b.max[a]]).collect();
            // One layer of outside all round.
            let (lo, hi) = (c.iter().min().copied(), c.iter().max().copied());
            c.extend(lo.map(|x| x - 1).into_iter().chain(hi.map(|x| x + 1)));
            c.sort_unstable();
            c.dedup();
            c
        });
        let dims = cuts.clone().map(|c| c.len() - 1);
        let mut cells = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let centre = [(0, i), (1, j), (2, k)]
                        .map(|(a, n)| i64::from(cuts[a][n]) + i64::from(cuts[a][n + 1]));
                    cells.push(classify(centre, solids, openings, rooms));
                }
            }
        }
        Grid { cuts, cells }
    }

    fn dims(&self) -> [usize; 3] {
        [0, 1, 2].map(|a| self.cuts[a].len() - 1)
    }

    /// The cell at grid index `i`.
    pub fn cell(&self, i: [usize; 3]) -> Cell {
        let d = self.dims();
        self.cells[(i[2] * d[1] + i[1]) * d[0] + i[0]]
    }

    /// The cell holding the point `p2` (twice its coordinates, so cell centres are integers).
    #[cfg(test)]
    pub fn cell_at(&self, p2: [i64; 3]) -> Cell {
        let i = [0, 1, 2].map(|a| {
            self.cuts[a]
                .partition_point(|&c| 2 * i64::from(c) < p2[a])
                .saturating_sub(1)
                .min(self.cuts[a].len() - 2)
        });
        self.cell(i)
    }

    /// The face between cells `a` (lower along `axis`) and `b`, if one is solid and the other
    /// a room's air.
    fn face(&self, axis: usize, a: Cell, b: Cell) -> Option<Face> {
        match (a, b) {
            (Cell::Solid(kind), Cell::Air(Some(room))) => Some(Face {
                kind,
                room,
                axis,
                positive: true,
            }),
            (Cell::Air(Some(room)), Cell::Solid(kind)) => Some(Face {
                kind,
                room,
                axis,
                positive: false,
            }),
            _ => None,
        }
    }

    /// Every face, labelled by `label` (from the face and twice its centre), merged into
    /// rectangles of one label, plane by plane along x, then y, then z.
    pub fn rectangles<L: Copy + PartialEq>(
        &self,
        label: impl Fn(Face, [i64; 3]) -> L,
    ) -> Vec<Rect<L>> {
        let d = self.dims();
        let mut out = Vec::new();
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for plane in 1..d[axis] {
                // Faces of this plane by (u, v) cell.
                let mut labels = vec![None; d[u] * d[v]];
                for jv in 0..d[v] {
                    for ju in 0..d[u] {
                        let mut at = [0; 3];
                        (at[axis], at[u], at[v]) = (plane - 1, ju, jv);
                        let below = self.cell(at);
                        at[axis] = plane;
                        labels[jv * d[u] + ju] = self.face(axis, below, self.cell(at)).map(|f| {
                            let mut centre = [0i64; 3];
                            centre[axis] = 2 * i64::from(self.cuts[axis][plane]);
                            for (b, j) in [(u, ju), (v, jv)] {
                                centre[b] = i64::from(self.cuts[b][j] + self.cuts[b][j + 1]);
                            }
                            (f.axis, f.positive, label(f, centre))
                        });
                    }
                }
                for ((_, positive, l), [u0, v0, u1, v1]) in merge(&mut labels, d[u], d[v]) {
                    let (mut min, mut max) = ([0; 3], [0; 3]);
                    min[axis] = self.cuts[axis][plane];
                    max[axis] = min[axis];
                    (min[u], max[u]) = (self.cuts[u][u0], self.cuts[u][u1]);
                    (min[v], max[v]) = (self.cuts[v][v0], self.cuts[v][v1]);
                    out.push(Rect {
                        label: l,
                        axis,
                        positive,
                        min,
                        max,
                    });
                }
            }
        }
        out
    }
}

/// The state of the cell whose centre is `p2` (twice the coordinates).
fn classify(
    p2: [i64; 3],
    solids: &[(Kind, Cuboid)],
    openings: &[(usize, Cuboid)],
    rooms: &[Cuboid],
) -> Cell {
    let opening = openings.iter().find(|o| contains(&o.1, p2));
    let solid = solids
        .iter()
        .find(|(kind, c)| contains(c, p2) && !(*kind == Kind::Structure && opening.is_some()));
    if let Some((kind, _)) = solid {
        return Cell::Solid(*kind);
    }
    let room = rooms.iter().position(|r| contains(r, p2));
    Cell::Air(room.or(opening.map(|o| o.0)))
}

/// Greedy maximal rectangles of equal labels on a `nu × nv` grid (row-major by v), each as
/// `(label, [u0, v0, u1, v1])` in cell indices, end exclusive; `labels` is emptied.
fn merge<T: Copy + PartialEq>(
    labels: &mut [Option<T>],
    nu: usize,
    nv: usize,
) -> Vec<(T, [usize; 4])> {
    let mut out = Vec::new();
    for v0 in 0..nv {
        for u0 in 0..nu {
            let Some(label) = labels[v0 * nu + u0] else {
                continue;
            };
            let mut u1 = u0 + 1;
            while u1 < nu && labels[v0 * nu + u1] == Some(label) {
                u1 += 1;
            }
            let mut v1 = v0 + 1;
            while v1 < nv && (u0..u1).all(|u| labels[v1 * nu + u] == Some(label)) {
                v1 += 1;
            }
            for v in v0..v1 {
                labels[v * nu + u0..v * nu + u1].fill(None);
            }
            out.push((label, [u0, v0, u1, v1]));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cuboid(min: [i32; 3], max: [i32; 3]) -> Cuboid {
        Cuboid { min, max }
    }

    #[test]
    fn a_room_in_a_shell_has_six_inward_faces() {
        // Six slabs 2 thick around the room [2, 8)³, overlapping at the edges.
        let solid: Vec<(Kind, Cuboid)> = (0..6)
            .map(|f| {
                let (axis, hi) = (f / 2, f % 2 == 1);
                let (mut min, mut max) = ([0; 3], [10; 3]);
                if hi {
                    min[axis] = 8;
                } else {
                    max[axis] = 2;
                }
                (Kind::Structure, cuboid(min, max))
            })
            .collect();
        let room = [cuboid([2, 2, 2], [8, 8, 8])];
        let grid = Grid::new(&solid, &[], &room, &[]);
        let rects = grid.rectangles(|f, _| f);
        assert_eq!(rects.len(), 6);
        for r in &rects {
            // Each face is the whole side of the room, facing into it.
            let a = r.axis;
            assert_eq!((r.label.axis, r.label.positive), (a, r.positive));
            let at = r.min[a];
            assert_eq!(at, if r.positive { 2 } else { 8 });
            for b in (0..3).filter(|&b| b != a) {
                assert_eq!((r.min[b], r.max[b]), (2, 8));
            }
        }
    }

    #[test]
    fn an_opening_to_the_outside_keeps_its_reveals_only() {
        // A wall slab x in [0, 4) with a room on its +x side and a hole through it.
        let solid = [(Kind::Structure, cuboid([0, 0, 0], [4, 10, 10]))];
        let room = [cuboid([4, 0, 0], [10, 10, 10])];
        let hole = [(0, cuboid([0, 4, 4], [4, 6, 6]))];
        let grid = Grid::new(&solid, &hole, &room, &[]);
        let rects = grid.rectangles(|f, _| f);
        let area = |axis: usize| -> i32 {
            rects
                .iter()
                .filter(|r| r.axis == axis)
                .map(|r| {
                    (0..3)
                        .filter(|&b| b != axis)
                        .map(|b| r.max[b] - r.min[b])
                        .product::<i32>()
                })
                .sum()
        };
        // The wall's face minus the hole; four reveals of 4 × 2; nothing outside.
        assert_eq!(area(0), 100 - 4);
        assert_eq!(area(1) + area(2), 4 * 8);
        assert!(rects.iter().all(|r| r.label.room == 0));
        assert_eq!(grid.cell_at([-1, 10, 10]), Cell::Air(None));
    }
}
