//! A uniform grid over primitives (segments, triangles) for exact nearest-primitive queries.
//!
//! Input: one bounding box per primitive. Each primitive is registered in every cell its box
//! overlaps. A query visits Chebyshev rings of cells around the query's cell, keeps the best
//! exact distance (computed by the caller's closure), and stops once the next ring cannot
//! hold anything closer: a primitive not yet seen lies only in cells of ring >= k+1, all of
//! which are at least k cell widths from the query (also for queries outside the grid, whose
//! projection onto the grid box lies in the start cell and is no farther from any cell).
//!
//! Rays. [`GridIndex::ray_cells`] walks the cells a ray crosses in order (Amanatides & Woo,
//! "A fast voxel traversal algorithm for ray tracing", Eurographics 1987) and lets the caller
//! stop as soon as its best hit lies before the current cell's exit: the first hit of a ray
//! through a surface mesh. The simulator's sensors cast one ray per pixel with it. A crate BVH
//! (`bvh`, `parry3d-f64`) would add a large dependency for the same first-hit query; the grid
//! already exists, is exact (f64, no traversal epsilon), and the parts are surfaces of
//! roughly uniform triangle size, where a uniform grid is as fast as a tree.

use crate::geometry::V3;

#[derive(Debug, Clone)]
pub struct GridIndex {
    lo: V3,
    cell: f64,
    dims: [usize; 3],
    /// CSR layout: items of cell `c` are `items[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    items: Vec<u32>,
    /// The primitives' boxes: a cheap lower bound that skips most exact distances.
    boxes: Vec<(V3, V3)>,
    len: usize,
}

impl GridIndex {
    /// Builds the grid for primitives with these bounding boxes, aiming at about
    /// `per_cell` primitives per occupied cell.
    pub fn build(boxes: &[(V3, V3)], per_cell: f64) -> Self {
        let n = boxes.len().max(1);
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (a, b) in boxes {
            for k in 0..3 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
            }
        }
        if boxes.is_empty() {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        let ext: Vec<f64> = (0..3).map(|k| hi[k] - lo[k]).collect();
        let diag = ext.iter().map(|e| e * e).sum::<f64>().sqrt().max(1e-300);
        // Surfaces fill a grid roughly like n^(2/3) cells per axis^2: size cells from the
        // extent and the count so that a cell holds `per_cell` primitives of a surface.
        let target_cells = (n as f64 / per_cell).max(1.0);
        let mut cell = diag / target_cells.sqrt().max(1.0);
        // Never more than ~8 n cells in the volume (flat or thin parts).
        loop {
            let cells: f64 = ext.iter().map(|e| (e / cell).floor() + 1.0).product();
            if cells <= 8.0 * n as f64 + 8.0 {
                break;
            }
            cell *= 1.25;
        }
        let dims = [0, 1, 2].map(|k| ((ext[k] / cell).floor() as usize + 1).max(1));
        let ncell = dims[0] * dims[1] * dims[2];
        let mut counts = vec![0u32; ncell + 1];
        let range = |a: V3, b: V3| {
            let i0 = [0, 1, 2].map(|k| (((a[k] - lo[k]) / cell).floor() as usize).min(dims[k] - 1));
            let i1 = [0, 1, 2].map(|k| (((b[k] - lo[k]) / cell).floor() as usize).min(dims[k] - 1));
            (i0, i1)
        };
        for (a, b) in boxes {
            let (i0, i1) = range(*a, *b);
            for x in i0[0]..=i1[0] {
                for y in i0[1]..=i1[1] {
                    for z in i0[2]..=i1[2] {
                        counts[(x * dims[1] + y) * dims[2] + z] += 1;
                    }
                }
            }
        }
        let mut starts = vec![0u32; ncell + 1];
        for c in 0..ncell {
            starts[c + 1] = starts[c] + counts[c];
        }
        let mut fill = starts.clone();
        let mut items = vec![0u32; starts[ncell] as usize];
        for (id, (a, b)) in boxes.iter().enumerate() {
            let (i0, i1) = range(*a, *b);
            for x in i0[0]..=i1[0] {
                for y in i0[1]..=i1[1] {
                    for z in i0[2]..=i1[2] {
                        let c = (x * dims[1] + y) * dims[2] + z;
                        items[fill[c] as usize] = id as u32;
                        fill[c] += 1;
                    }
                }
            }
        }
        GridIndex {
            lo,
            cell,
            dims,
            starts,
            items,
            boxes: boxes.to_vec(),
            len: boxes.len(),
        }
    }

    /// The primitive nearest to `p` and its distance, `dist(id)` being the exact distance from
    /// `p` to primitive `id`; `None` when there are no primitives.
    pub fn nearest(&self, p: V3, mut dist: impl FnMut(usize) -> f64) -> Option<(f64, usize)> {
        if self.len == 0 {
            return None;
        }
        let c0 = [0, 1, 2].map(|k| {
            let f = ((p[k] - self.lo[k]) / self.cell).floor();
            if f.is_nan() || f < 0.0 {
                0
            } else {
                (f as usize).min(self.dims[k] - 1)
            }
        });
        let margin = (0..3)
            .map(|k| {
                let f = p[k] - (self.lo[k] + c0[k] as f64 * self.cell);
                if (0.0..=self.cell).contains(&f) {
                    f.min(self.cell - f)
                } else {
                    0.0
                }
            })
            .fold(f64::INFINITY, f64::min);
        let mut best: Option<(f64, usize)> = None;
        let dims = self.dims;
        let max_ring = (0..3)
            .map(|k| c0[k].max(dims[k] - 1 - c0[k]))
            .max()
            .unwrap_or(0);
        for ring in 0..=max_ring {
            let lo_i = [0, 1, 2].map(|k| c0[k].saturating_sub(ring));
            let hi_i = [0, 1, 2].map(|k| (c0[k] + ring).min(dims[k] - 1));
            for x in lo_i[0]..=hi_i[0] {
                let ex = x.abs_diff(c0[0]) == ring;
                for y in lo_i[1]..=hi_i[1] {
                    let ey = y.abs_diff(c0[1]) == ring;
                    let mut visit = |z: usize| {
                        let c = (x * dims[1] + y) * dims[2] + z;
                        for &id in &self.items[self.starts[c] as usize..self.starts[c + 1] as usize]
                        {
                            let (lo, hi) = self.boxes[id as usize];
                            let g = [0, 1, 2].map(|k| (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0));
                            let lower = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                            if best.is_some_and(|(bd, _)| lower >= bd) {
                                continue;
                            }
                            let d = dist(id as usize);
                            if best.is_none_or(|(bd, _)| d < bd) {
                                best = Some((d, id as usize));
                            }
                        }
                    };
                    if ex || ey {
                        for z in lo_i[2]..=hi_i[2] {
                            visit(z);
                        }
                    } else {
                        if c0[2] >= ring {
                            visit(c0[2] - ring);
                        }
                        if ring > 0 && c0[2] + ring < dims[2] {
                            visit(c0[2] + ring);
                        }
                    }
                }
            }
            if let Some((bd, _)) = best {
                // Unseen primitives lie in rings > `ring`: at least `ring` whole cells plus the
                // way from p to its own cell's nearest face (0 when p is outside the grid).
                if bd <= ring as f64 * self.cell + margin {
                    break;
                }
            }
        }
        best
    }
}

impl GridIndex {
    /// Calls `visit(items, t_exit)` for every cell the ray `o + t d` (t in `[0, t_max]`)
    /// crosses, nearest first, with the cell's primitives and the ray parameter where it leaves
    /// the cell; stops when `visit` returns true (the caller's best hit lies before `t_exit`,
    /// so no later cell can hold a nearer one). Primitives spanning several cells are visited
    /// once per cell.
    pub fn ray_cells(&self, o: V3, d: V3, t_max: f64, mut visit: impl FnMut(&[u32], f64) -> bool) {
        if self.len == 0 {
            return;
        }
        // Clip the ray to the grid's box (slab test).
        let (mut t0, mut t1) = (0.0f64, t_max);
        for k in 0..3 {
            let lo = self.lo[k];
            let hi = self.lo[k] + self.dims[k] as f64 * self.cell;
            if d[k] == 0.0 {
                if o[k] < lo || o[k] > hi {
                    return;
                }
            } else {
                let (a, b) = ((lo - o[k]) / d[k], (hi - o[k]) / d[k]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        if t0.is_nan() || t1.is_nan() || t0 > t1 {
            return;
        }
        let mut cell = [0usize; 3];
        let mut step = [0i64; 3];
        let mut t_next = [f64::INFINITY; 3];
        let mut t_delta = [f64::INFINITY; 3];
        for k in 0..3 {
            let x = (o[k] + t0 * d[k] - self.lo[k]) / self.cell;
            let c = (x.floor().max(0.0) as usize).min(self.dims[k] - 1);
            cell[k] = c;
            if d[k] > 0.0 {
                step[k] = 1;
                t_delta[k] = self.cell / d[k];
                t_next[k] = (self.lo[k] + (c + 1) as f64 * self.cell - o[k]) / d[k];
            } else if d[k] < 0.0 {
                step[k] = -1;
                t_delta[k] = -self.cell / d[k];
                t_next[k] = (self.lo[k] + c as f64 * self.cell - o[k]) / d[k];
            }
        }
        loop {
            let c = (cell[0] * self.dims[1] + cell[1]) * self.dims[2] + cell[2];
            let items = &self.items[self.starts[c] as usize..self.starts[c + 1] as usize];
            // The axis whose boundary comes first is where the ray leaves this cell.
            let k = (0..3)
                .min_by(|&a, &b| t_next[a].total_cmp(&t_next[b]))
                .unwrap_or(0);
            let t_exit = t_next[k].min(t1);
            if visit(items, t_exit) || t_next[k] > t1 {
                return;
            }
            let next = cell[k] as i64 + step[k];
            if next < 0 || next >= self.dims[k] as i64 {
                return;
            }
            cell[k] = next as usize;
            t_next[k] += t_delta[k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{V3, point_segment};
    use rand::rngs::SmallRng;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn nearest_segment_matches_brute_force() {
        let mut rng = SmallRng::seed_from_u64(5);
        let mut r = |s: f64| -> V3 {
            [
                rng.random::<f64>() * s,
                rng.random::<f64>() * s,
                0.3 * rng.random::<f64>(),
            ]
        };
        let segs: Vec<(V3, V3)> = (0..500)
            .map(|_| {
                let a = r(10.0);
                let d = r(0.5);
                (a, [a[0] + d[0], a[1] + d[1], a[2] + d[2]])
            })
            .collect();
        let boxes: Vec<(V3, V3)> = segs
            .iter()
            .map(|(a, b)| {
                (
                    [0, 1, 2].map(|k| a[k].min(b[k])),
                    [0, 1, 2].map(|k| a[k].max(b[k])),
                )
            })
            .collect();
        let grid = GridIndex::build(&boxes, 2.0);
        for _ in 0..2000 {
            // Queries inside and well outside the grid.
            let q = r(14.0).map(|c| c - 2.0);
            let got = grid
                .nearest(q, |i| point_segment(q, segs[i].0, segs[i].1).0)
                .unwrap();
            let want = (0..segs.len())
                .map(|i| (point_segment(q, segs[i].0, segs[i].1).0, i))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap();
            assert_eq!(got.0, want.0);
        }
    }

    #[test]
    fn empty_grid_has_no_nearest() {
        let g = GridIndex::build(&[], 2.0);
        assert!(g.nearest([0.0; 3], |_| 0.0).is_none());
    }
}
