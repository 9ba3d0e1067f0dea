//! Neighbour search: a uniform grid for fixed-radius neighbourhoods and a kiddo k-d tree for
//! k-nearest-neighbour queries.
//!
//! Inputs: positions (f64, any magnitude). Outputs: `Grid` (points bucketed by cell, in a
//! cache-friendly spatial order, coordinates local to the grid's origin), `Knn` (flat arrays of
//! k neighbour ids per point), `Distinct` (exact duplicates collapsed), `mean_spacing`.
//!
//! Why two structures: the features stage needs *radius* neighbourhoods whose size follows the
//! measured noise (a fixed k is swamped by noise, see CRATES.md). On this machine, for a
//! 1,000,000-point box scan on 2 threads, kiddo 6's radius query at r = 3 spacings took 0.86 s
//! without doing anything with the neighbours, while this grid found the same neighbours *and*
//! accumulated their covariance in 0.29 s (r = 5 spacings: 0.45 s); kiddo's kNN at k = 16 took
//! 1.7 s, at k = 32 2.75 s (`cargo bench --bench neighbours` repeats the comparison). The k-d
//! tree stays the tool for nearest-neighbour queries (spacing, kNN).

use std::num::NonZeroUsize;

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use crate::error::{Error, Result};

/// A packed cell key: three cell coordinates of up to 2^42 + 1 values each.
type Key = u128;

/// An occupied cell: its key, first slot and end slot.
type Occupied = (Key, usize, usize);

/// Cell coordinates are clamped to ±this many cells around the grid's origin.
const FAR_CELL: i64 = 1 << 41;

/// The widest bulk (in cells) that keeps the asked cell size.
const BULK_CELLS: f64 = (1u64 << 40) as f64;

/// The cell coordinate of a local coordinate `x`: ⌊x / cell⌋, clamped to ±[`FAR_CELL`].
/// Monotone, and moves by no more than the true coordinate, so a query's cells still hold
/// every point within its radius.
#[inline]
fn cell_coord(x: f64, cell: f64) -> i64 {
    (x / cell).floor().clamp(-FAR_CELL as f64, FAR_CELL as f64) as i64
}

/// Points bucketed in cubic cells of side `cell`. Radius queries with `r <= cell` look at the
/// 27 cells around the query, wider ones as many rings of cells as they need.
pub struct Grid {
    origin: [f64; 3],
    cell: f64,
    /// Cell coordinates (from [`cell_coord`]) of the first cell of each axis.
    base: [i64; 3],
    dims: [u64; 3],
    layout: Layout,
    /// Point ids in cell order (x fastest, then y, then z).
    ids: Vec<u32>,
    /// Positions in cell order, relative to `origin`.
    local: Vec<[f64; 3]>,
}

/// The points standing for a crowded cloud ([`Grid::crowd`]): a grid of the kept points,
/// their ids in the full cloud (ascending; the grid's ids index this), and how many points
/// each stands for.
pub struct Crowd {
    pub grid: Grid,
    pub ids: Vec<u32>,
    pub weight: Vec<f64>,
}

/// An occupied cell of a [`Grid`] and the slot ranges of the rows of its 3×3×3 block.
pub struct Block {
    /// Slots of the cell's own points (their ids: [`Grid::slot_ids`]).
    pub slots: std::ops::Range<usize>,
    rows: [(u32, u32); 9],
    nrows: u8,
}

enum Layout {
    /// `starts[c]..starts[c + 1]` are the slots of cell `c`; used when the grid is not much
    /// larger than the cloud.
    Dense { starts: Vec<u32> },
    /// Non-empty cells only, sorted by key, for sparse clouds with a huge bounding box
    /// (outliers, lidar strips), and scanned surfaces, which fill few of their box's cells.
    /// `rows[row]` is the index of the first non-empty cell of each row (cells with the same
    /// y and z), when there are not too many rows for such a table: a query then looks at its
    /// row's few cells instead of binary-searching all of them (the search took 40 % of the
    /// features stage on a 1,000,000-point box).
    Sparse {
        keys: Vec<Key>,
        starts: Vec<u32>,
        rows: Option<Vec<u32>>,
    },
}

impl Grid {
    /// Buckets `positions` in cells of side `cell`. Fails on an empty cloud, a non-positive or
    /// non-finite cell size, or non-finite coordinates.
    pub fn new(positions: &[[f64; 3]], cell: f64) -> Result<Grid> {
        if positions.is_empty() {
            return Err(Error::TooFewPoints {
                what: "neighbour grid",
                needed: 1,
                got: 0,
            });
        }
        if !(cell.is_finite() && cell > 0.0) {
            return Err(Error::Degenerate {
                what: "neighbour grid",
                why: format!("cell size must be a positive finite length, got {cell}"),
            });
        }
        if positions.len() > u32::MAX as usize {
            return Err(Error::Degenerate {
                what: "neighbour grid",
                why: format!("{} points exceed the 2^32 limit", positions.len()),
            });
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in positions {
            for k in 0..3 {
                if !p[k].is_finite() {
                    return Err(Error::Degenerate {
                        what: "neighbour grid",
                        why: format!("non-finite coordinate {p:?}"),
                    });
                }
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        // Cells follow the asked size whatever the cloud's extent: coordinates are local to
        // the box's low corner, or to the bulk's centre when a few far points make the box
        // over 1,000 times wider than the bulk ([`bulk_frame`]); cell coordinates are clamped
        // to ±2^41 cells around that origin, so far points share the outermost cells while
        // the part keeps cells as small as its radius (with 2^21 cells a side over the box, a
        // part beside a point 1e12 away sat in one cell and every radius query read all of
        // it: the features stage took 16 s on 100,000 points). Only a bulk spanning more
        // than 2^40 cells gets coarser cells, which cost speed, never results.
        let mut cell = cell;
        let (origin, extent) = match bulk_frame(positions, lo, hi) {
            Some((centre, half)) => (centre, 2.0 * half),
            None => (lo, (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max)),
        };
        if extent / cell > BULK_CELLS {
            cell = extent / BULK_CELLS;
        }
        let base = [0, 1, 2].map(|k| cell_coord(lo[k] - origin[k], cell));
        let dims = [0, 1, 2].map(|k| (cell_coord(hi[k] - origin[k], cell) - base[k]) as u64 + 1);
        let cell_of = |p: &[f64; 3]| -> [u64; 3] {
            [0, 1, 2].map(|k| {
                ((cell_coord(p[k] - origin[k], cell) - base[k]).max(0) as u64).min(dims[k] - 1)
            })
        };
        let key_of = |c: [u64; 3]| {
            (c[2] as Key * dims[1] as Key + c[1] as Key) * dims[0] as Key + c[0] as Key
        };
        let keys: Vec<Key> = positions.par_iter().map(|p| key_of(cell_of(p))).collect();
        let ncell = dims[0] as Key * dims[1] as Key * dims[2] as Key;
        let dense = ncell <= (4 * positions.len() as Key).max(1 << 20);

        // Counting sort when dense; a stable sort by key otherwise. Both give the same order
        // (by key, ties by point id), so results never depend on the layout.
        let (ids, layout) = if dense {
            let mut starts = vec![0u32; ncell as usize + 1];
            for &k in &keys {
                starts[k as usize + 1] += 1;
            }
            for c in 0..ncell as usize {
                starts[c + 1] += starts[c];
            }
            let mut fill = starts.clone();
            let mut ids = vec![0u32; positions.len()];
            for (i, &k) in keys.iter().enumerate() {
                ids[fill[k as usize] as usize] = i as u32;
                fill[k as usize] += 1;
            }
            (ids, Layout::Dense { starts })
        } else {
            // The (key, id) pairs themselves are sorted, not ids by a key looked up at every
            // comparison (a cache miss each): the pairs are distinct, so the order is the
            // same.
            let mut pairs: Vec<(Key, u32)> = keys
                .par_iter()
                .enumerate()
                .map(|(i, &k)| (k, i as u32))
                .collect();
            pairs.par_sort_unstable();
            let ids: Vec<u32> = pairs.iter().map(|&(_, i)| i).collect();
            let mut ukeys = Vec::new();
            let mut starts = Vec::new();
            for (slot, &(k, _)) in pairs.iter().enumerate() {
                if ukeys.last() != Some(&k) {
                    ukeys.push(k);
                    starts.push(slot as u32);
                }
            }
            starts.push(ids.len() as u32);
            let nrows = dims[1] as Key * dims[2] as Key;
            let rows = (nrows <= (4 * positions.len() as Key).max(1 << 20)).then(|| {
                let mut rows = vec![0u32; nrows as usize + 1];
                let mut next = 0usize;
                for (row, slot) in rows.iter_mut().enumerate() {
                    while next < ukeys.len() && ukeys[next] / (dims[0] as Key) < row as Key {
                        next += 1;
                    }
                    *slot = next as u32;
                }
                rows
            });
            (
                ids,
                Layout::Sparse {
                    keys: ukeys,
                    starts,
                    rows,
                },
            )
        };
        let local = ids
            .par_iter()
            .map(|&i| {
                let p = positions[i as usize];
                [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]]
            })
            .collect();
        Ok(Grid {
            origin,
            cell,
            base,
            dims,
            layout,
            ids,
            local,
        })
    }

    /// The cell side actually used (larger than asked only for absurdly large extents).
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// Point ids in the grid's spatial order: iterating in this order keeps neighbouring
    /// queries on neighbouring memory.
    pub fn spatial_order(&self) -> &[u32] {
        &self.ids
    }

    /// Point ids of a range of slots (see [`Block::slots`]).
    pub fn slot_ids(&self, slots: std::ops::Range<usize>) -> &[u32] {
        &self.ids[slots]
    }

    /// The points that stand for a crowded cloud, or `None` when no cell is crowded.
    ///
    /// A cell holding more than `factor` times the median occupied cell's points (and more
    /// than `floor`) is crowded: thousands of distinct points within a fraction of the
    /// spacing (a hostile file, a scanner stuck on one spot while its noise spreads the
    /// copies) would make every radius query around them read all of them, quadratic work
    /// (50,000 points within 1e-3 of one point beside a 100,000-point box: 7 s in the
    /// features stage, 5 s in the faces stage). A crowded cell keeps every s-th of its
    /// points (s = ⌈count / cap⌉, in id order), each standing for count / kept points
    /// (`weight`); other cells keep all their points with weight 1. Sums over a
    /// neighbourhood of the kept points, weighted, estimate the sums over all its points
    /// with bounded work per query. Scanned clouds have no such cell (their densest cells
    /// hold a few times the median), so their results do not change.
    pub fn crowd(&self, positions: &[[f64; 3]], factor: usize, floor: usize) -> Option<Crowd> {
        let (cells, cap) = self.crowded_cells(factor, floor)?;
        let mut kept: Vec<(u32, f64)> = Vec::new();
        for &(_, a, b) in &cells {
            let len = b - a;
            let stride = len.div_ceil(cap);
            let keep = len.div_ceil(stride);
            let weight = len as f64 / keep as f64;
            kept.extend((a..b).step_by(stride).map(|s| (self.ids[s], weight)));
        }
        kept.sort_unstable_by_key(|&(i, _)| i);
        let ids: Vec<u32> = kept.iter().map(|&(i, _)| i).collect();
        let sub: Vec<[f64; 3]> = ids.iter().map(|&i| positions[i as usize]).collect();
        // The kept points are a subset of a grid's points: never empty, all finite.
        let grid = Grid::new(&sub, self.cell).ok()?;
        Some(Crowd {
            grid,
            ids,
            weight: kept.iter().map(|&(_, w)| w).collect(),
        })
    }

    /// Whether some cell is crowded (see [`Self::crowd`]).
    pub fn is_crowded(&self, factor: usize, floor: usize) -> bool {
        self.crowded_cells(factor, floor).is_some()
    }

    /// The occupied cells and the most points a cell may hold before it is crowded, when
    /// some cell holds more.
    fn crowded_cells(&self, factor: usize, floor: usize) -> Option<(Vec<Occupied>, usize)> {
        let cells = self.occupied();
        let mut counts: Vec<usize> = cells.iter().map(|&(_, a, b)| b - a).collect();
        let mid = counts.len() / 2;
        let median = *counts.select_nth_unstable(mid).1;
        let cap = (factor * median).max(floor).max(1);
        cells
            .iter()
            .any(|&(_, a, b)| b - a > cap)
            .then_some((cells, cap))
    }

    /// The occupied cells in key order: (key, first slot, end slot).
    fn occupied(&self) -> Vec<Occupied> {
        match &self.layout {
            Layout::Dense { starts } => (0..starts.len() - 1)
                .filter(|&c| starts[c] < starts[c + 1])
                .map(|c| (c as Key, starts[c] as usize, starts[c + 1] as usize))
                .collect(),
            Layout::Sparse { keys, starts, .. } => (0..keys.len())
                .map(|i| (keys[i], starts[i] as usize, starts[i + 1] as usize))
                .collect(),
        }
    }

    /// Number of cells the layout stores (all cells when dense, the occupied ones when
    /// sparse): what [`Self::occupied`] walks through.
    fn stored_cells(&self) -> usize {
        match &self.layout {
            Layout::Dense { starts } => starts.len() - 1,
            Layout::Sparse { keys, .. } => keys.len(),
        }
    }

    /// The cell coordinates of a key.
    fn cell_of_key(&self, key: Key) -> [u64; 3] {
        let (d0, d1) = (self.dims[0] as Key, self.dims[1] as Key);
        [key % d0, (key / d0) % d1, key / (d0 * d1)].map(|c| c as u64)
    }

    /// The key of the first cell of row (`y`, `z`).
    #[inline]
    fn row_key(&self, y: i64, z: i64) -> Key {
        (z as Key * self.dims[1] as Key + y as Key) * self.dims[0] as Key
    }

    /// The cell coordinates (not clamped to the grid's cells) of a local point.
    #[inline]
    fn query_cell(&self, ql: [f64; 3]) -> [i64; 3] {
        [0, 1, 2].map(|k| cell_coord(ql[k], self.cell) - self.base[k])
    }

    /// Whether a cell is one of the outermost ones far points are clamped into (its points
    /// may lie anywhere beyond it).
    fn clamped(&self, c: [u64; 3]) -> bool {
        (0..3).any(|k| (c[k] as i64 + self.base[k]).abs() >= FAR_CELL)
    }

    /// Every occupied cell in slot order, with the slot ranges of the 27 cells around it:
    /// all the queries from one cell's points look at the same cells, and finding them once
    /// per cell instead of once per query took the features stage of a 1,000,000-point box
    /// from 1.05 s to 0.79 s on 2 threads.
    pub fn blocks(&self) -> Vec<Block> {
        self.occupied()
            .par_iter()
            .map(|&(key, a, b)| {
                let c = self.cell_of_key(key).map(|c| c as i64);
                let (x0, x1) = ((c[0] - 1).max(0), (c[0] + 1).min(self.dims[0] as i64 - 1));
                let mut rows = [(0u32, 0u32); 9];
                let mut nrows = 0;
                for z in (c[2] - 1).max(0)..=(c[2] + 1).min(self.dims[2] as i64 - 1) {
                    for y in (c[1] - 1).max(0)..=(c[1] + 1).min(self.dims[1] as i64 - 1) {
                        let row = self.row_key(y, z);
                        let (s0, s1) = self.slots(row + x0 as Key, row + x1 as Key);
                        if s0 < s1 {
                            rows[nrows] = (s0 as u32, s1 as u32);
                            nrows += 1;
                        }
                    }
                }
                Block {
                    slots: a..b,
                    rows,
                    nrows: nrows as u8,
                }
            })
            .collect()
    }

    /// `q` relative to the grid's origin, as the stored positions are.
    #[inline]
    fn local_of(&self, q: [f64; 3]) -> [f64; 3] {
        [
            q[0] - self.origin[0],
            q[1] - self.origin[1],
            q[2] - self.origin[2],
        ]
    }

    /// [`Self::for_each_within`] for a query `q` inside `block`'s cell (one of its points),
    /// using the block's slot ranges when `r <= cell()` (wider radii go through
    /// [`Self::for_each_within`]). Same calls in the same order.
    #[inline]
    pub fn for_each_within_block(
        &self,
        block: &Block,
        q: [f64; 3],
        r: f64,
        mut f: impl FnMut(u32, [f64; 3], f64),
    ) {
        if r > self.cell * (1.0 + 1e-12) {
            return self.for_each_within(q, r, f);
        }
        let ql = self.local_of(q);
        for &(a, b) in &block.rows[..block.nrows as usize] {
            self.scan(a as usize..b as usize, ql, r * r, &mut |s: usize, d, d2| {
                f(self.ids[s], d, d2)
            });
        }
    }

    /// Calls `f(slot, offset, weight)` for every point of the 27 cells around `block`'s cell
    /// (for a query `q` inside it), with weight 1 for the points within `r` and 0 for the
    /// others, in [`Self::for_each_within_block`]'s order. Accumulating `w · x` over them
    /// gives every sum bit for bit as over the points within `r` (x · 1 = x, x + 0 = x),
    /// without a branch on the distance: about a third of a block's points are within `r`,
    /// in no predictable pattern, and the mispredicted branches cost more than the sums of
    /// the others (the features stage of a 1,000,000-point box: 0.72 s with the branch,
    /// 0.65 s without; collecting the hits first without a branch, then summing them, took
    /// 0.81 s). Radii wider than the cell: only the points within `r`, weight 1. Slots index
    /// [`Self::in_slot_order`] arrays.
    #[inline]
    pub fn for_each_in_block_weighted(
        &self,
        block: &Block,
        q: [f64; 3],
        r: f64,
        mut f: impl FnMut(usize, [f64; 3], f64),
    ) {
        self.fold_in_block_weighted(block, q, r, (), |(), s, d, w| f(s, d, w));
    }

    /// [`Self::for_each_in_block_weighted`] as a fold: `f(acc, slot, offset, weight)` returns
    /// the new accumulator. Same calls in the same order; the accumulator passed by value
    /// stays in registers, where sums kept behind a closure's `&mut` were stored and reloaded
    /// at every point.
    #[inline]
    pub fn fold_in_block_weighted<A: Copy>(
        &self,
        block: &Block,
        q: [f64; 3],
        r: f64,
        init: A,
        mut f: impl FnMut(A, usize, [f64; 3], f64) -> A,
    ) -> A {
        let ql = self.local_of(q);
        let mut acc = init;
        if r > self.cell * (1.0 + 1e-12) {
            self.for_each_within_slots(ql, r, &mut |s, d, _| acc = f(acc, s, d, 1.0));
            return acc;
        }
        let r2 = r * r;
        for &(a, b) in &block.rows[..block.nrows as usize] {
            for (s, p) in self.local[a as usize..b as usize].iter().enumerate() {
                let d = [p[0] - ql[0], p[1] - ql[1], p[2] - ql[2]];
                let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                acc = f(acc, a as usize + s, d, f64::from(u8::from(d2 <= r2)));
            }
        }
        acc
    }

    /// Per-point values (by id) rearranged in the grid's slot order.
    pub fn in_slot_order<T: Copy>(&self, values: &[T]) -> Vec<T> {
        self.ids.iter().map(|&i| values[i as usize]).collect()
    }

    /// Calls `f(slot, offset, squared distance)` for the points of `slots` within `sqrt(r2)`
    /// of the local point `ql`.
    #[inline]
    fn scan(
        &self,
        slots: std::ops::Range<usize>,
        ql: [f64; 3],
        r2: f64,
        f: &mut impl FnMut(usize, [f64; 3], f64),
    ) {
        for s in slots {
            let p = self.local[s];
            let d = [p[0] - ql[0], p[1] - ql[1], p[2] - ql[2]];
            let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if d2 <= r2 {
                f(s, d, d2);
            }
        }
    }

    /// Calls `f(id, offset, squared_distance)` for every point within `r` of `q` (inclusive),
    /// where `offset` = point − q. Any `r`: up to `cell()` the 27 cells around the query are
    /// read, beyond it as many rings as `r` needs (local scale gives some points a radius
    /// wider than the grid's cell). The order of calls is fixed (cell order, then point id),
    /// so accumulations are deterministic.
    #[inline]
    pub fn for_each_within(&self, q: [f64; 3], r: f64, mut f: impl FnMut(u32, [f64; 3], f64)) {
        let ql = self.local_of(q);
        self.for_each_within_slots(ql, r, &mut |s, d, d2| f(self.ids[s], d, d2));
    }

    /// [`Self::for_each_within`] for a local query point, calling `f(slot, offset, d2)`.
    #[inline]
    fn for_each_within_slots(
        &self,
        ql: [f64; 3],
        r: f64,
        f: &mut impl FnMut(usize, [f64; 3], f64),
    ) {
        let r2 = r * r;
        // `as` saturates: an infinite radius spans the whole grid.
        let span = if r <= self.cell * (1.0 + 1e-12) {
            1
        } else {
            (r / self.cell).ceil() as i64
        };
        let c = self.query_cell(ql);
        // Only the cells the ball reaches: those of q ± r along each axis, not all `span`
        // rings. A radius a little wider than the cell (a tenth of the points on a box scan:
        // the grid's cell is the 0.9 quantile of the radii) otherwise read 5 x 5 x 5 cells
        // where 3 or 4 a side hold the ball. Every point within r lies between q − r and
        // q + r on each axis, and `cell_coord` is monotone, so the cells left out hold none
        // of them; the slack (far above the rounding of these sums) keeps it so in floating
        // point. Same calls in the same order (the cells kept are visited as before).
        let slack = 1e-9 * (r + self.cell);
        let reach = |k: usize, x: f64| cell_coord(x, self.cell) - self.base[k];
        let lo = [0, 1, 2].map(|k| {
            let near = reach(k, ql[k] - r - (slack + 1e-9 * ql[k].abs()));
            c[k].saturating_sub(span).max(near).max(0)
        });
        let hi = [0, 1, 2].map(|k| {
            let near = reach(k, ql[k] + r + (slack + 1e-9 * ql[k].abs()));
            c[k].saturating_add(span)
                .min(near)
                .min(self.dims[k] as i64 - 1)
        });
        if (0..3).any(|k| lo[k] > hi[k]) {
            return;
        }
        // A radius spanning more rows than the grid stores cells (an isolated outlier
        // measures a radius as wide as the cloud, and a cloud 1e12 wide has 2^21 cells a
        // side): visit the occupied cells in order instead of every row. Same calls, same
        // order (cells by key, then point id).
        let rows = (hi[2] - lo[2] + 1) as Key * (hi[1] - lo[1] + 1) as Key;
        if rows > self.stored_cells() as Key {
            for (key, s0, s1) in self.occupied() {
                let cell = self.cell_of_key(key);
                if (0..3).all(|k| (lo[k]..=hi[k]).contains(&(cell[k] as i64))) {
                    self.scan(s0..s1, ql, r2, f);
                }
            }
            return;
        }
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let row = self.row_key(y, z);
                let (a, b) = self.slots(row + lo[0] as Key, row + hi[0] as Key);
                self.scan(a..b, ql, r2, f);
            }
        }
    }

    /// The ids of all points within `r` of `q`, sorted by id.
    pub fn within(&self, q: [f64; 3], r: f64) -> Vec<u32> {
        let mut out = Vec::new();
        self.for_each_within(q, r, |i, _, _| out.push(i));
        out.sort_unstable();
        out
    }

    /// Calls `f(id)` once for every point within `reach` of the segment `a`–`b` (any
    /// `reach`, also wider than a cell), in a fixed order (cell order, then id).
    pub fn for_each_near_segment(
        &self,
        a: [f64; 3],
        b: [f64; 3],
        reach: f64,
        mut f: impl FnMut(u32),
    ) {
        let la = self.local_of(a);
        let lb = self.local_of(b);
        let ab = [lb[0] - la[0], lb[1] - la[1], lb[2] - la[2]];
        let len2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
        let len = len2.sqrt();
        let reach2 = reach * reach;
        // Squared distance from a local point to the segment.
        let dist2 = |p: [f64; 3]| {
            let ap = [p[0] - la[0], p[1] - la[1], p[2] - la[2]];
            let t = if len2 > 0.0 {
                ((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let d = [ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]];
            d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        };
        // The exact test, point by point, for the slots of the cells found.
        let mut visit = |s0: usize, s1: usize| {
            for s in s0..s1 {
                if dist2(self.local[s]) <= reach2 {
                    f(self.ids[s]);
                }
            }
        };
        // Cells within `reach` of sample points half a cell apart cover the capsule.
        let steps = (2.0 * len / self.cell).ceil() as usize + 1;
        let span = (reach / self.cell).ceil() as i64 + 1;
        // A segment crossing far more cells than the grid stores (a ray to the edge of a cloud
        // 1e12 wide, whose cells are 2^21 a side): test the occupied cells instead, those
        // whose centre lies within `reach` plus half a cell diagonal of the segment. Same
        // calls in the same order (cell key order, then id).
        let work = (steps as f64 + 1.0) * ((2 * span + 1) as f64).powi(2);
        if work > self.stored_cells() as f64 {
            let near = reach + self.cell * 0.87;
            for (key, s0, s1) in self.occupied() {
                let c = self.cell_of_key(key);
                let m = [0, 1, 2].map(|k| ((c[k] as i64 + self.base[k]) as f64 + 0.5) * self.cell);
                if self.clamped(c) || dist2(m).sqrt() <= near {
                    visit(s0, s1);
                }
            }
            return;
        }
        let mut rows: Vec<(Key, i64, i64)> = Vec::new(); // (row key base, x0, x1)
        for s in 0..=steps {
            let u = if steps == 0 {
                0.0
            } else {
                s as f64 / steps as f64
            };
            let q = [0, 1, 2].map(|k| la[k] + u * ab[k]);
            let c = self.query_cell(q);
            let x0 = (c[0] - span).max(0);
            let x1 = (c[0] + span).min(self.dims[0] as i64 - 1);
            if x0 > x1 {
                continue;
            }
            for z in (c[2] - span).max(0)..=(c[2] + span).min(self.dims[2] as i64 - 1) {
                for y in (c[1] - span).max(0)..=(c[1] + span).min(self.dims[1] as i64 - 1) {
                    rows.push((self.row_key(y, z), x0, x1));
                }
            }
        }
        // Merge the x ranges of each row so no cell is visited twice.
        rows.sort_unstable();
        let mut merged: Vec<(Key, i64, i64)> = Vec::with_capacity(rows.len());
        for (row, x0, x1) in rows {
            match merged.last_mut() {
                Some(m) if m.0 == row && x0 <= m.2 + 1 => m.2 = m.2.max(x1),
                _ => merged.push((row, x0, x1)),
            }
        }
        for (row, x0, x1) in merged {
            let (s0, s1) = self.slots(row + x0 as Key, row + x1 as Key);
            visit(s0, s1);
        }
    }

    /// Slot range covering the cells with keys `k0..=k1` (consecutive in one x row).
    #[inline]
    fn slots(&self, k0: Key, k1: Key) -> (usize, usize) {
        match &self.layout {
            Layout::Dense { starts } => (
                starts[k0 as usize] as usize,
                starts[k1 as usize + 1] as usize,
            ),
            Layout::Sparse { keys, starts, rows } => {
                // Within one row (k0 and k1 always share one): its cells only.
                let (lo, hi) = match rows {
                    Some(rows) => {
                        let row = (k0 / self.dims[0] as Key) as usize;
                        (rows[row] as usize, rows[row + 1] as usize)
                    }
                    None => (0, keys.len()),
                };
                let cells = &keys[lo..hi];
                let a = lo + cells.partition_point(|&k| k < k0);
                let b = a + keys[a..hi].partition_point(|&k| k <= k1);
                (starts[a] as usize, starts[b] as usize)
            }
        }
    }
}

/// k nearest neighbours of every point, flat: the neighbours of point `i` are
/// `ids[i * k..(i + 1) * k]`, nearest first, the point itself excluded.
pub struct Knn {
    pub k: usize,
    pub ids: Vec<u32>,
    /// Distances matching `ids`.
    pub dist: Vec<f64>,
}

impl Knn {
    pub fn of(&self, i: usize) -> &[u32] {
        &self.ids[i * self.k..(i + 1) * self.k]
    }
}

/// A kiddo k-d tree over f32 coordinates local to the cloud's centre (f32 steps are ~3 cm at
/// 500 km, so absolute georeferenced coordinates must never be converted directly) and scaled
/// by a power of two that brings the cloud's half extent into [1, 2): squared distances in f32
/// underflow to 0 below ~1e-19 and overflow above ~1e19, and a tree whose distances are all 0
/// or infinite prunes nothing (every query read every point: a box scaled by 1e-30 took
/// `sharpedge info` past two minutes). A power of two changes no rounding, so on any cloud
/// whose distances f32 held before, every distance is bit for bit what it was. Centre and
/// extent are the bulk's when a few far outliers would dominate them ([`frame`]).
///
/// When f32 merges many distinct positions into one (50,000 points within 1e-6 of each
/// other in a part 100 wide: all at one f32 point, every query among them at distance 0
/// from all of them, read all of them: `info` took 13 s on 51,000 points), the tree holds
/// f64 coordinates instead ([`crowded_in_f32`]); other clouds keep f32 and their distances.
pub struct KdTree {
    centre: [f64; 3],
    /// Local units per model unit (a power of two).
    scale: f64,
    tree: Tree,
}

enum Tree {
    F32(ImmutableKdTree<f32, 3>),
    F64(ImmutableKdTree<f64, 3>),
}

/// More distinct positions than this at one f32 point make the k-d tree use f64.
const F32_CROWD: usize = 32;

/// Whether more than [`F32_CROWD`] distinct `positions` share one point of `local` (their
/// f32 coordinates), found by sorting the f32 points.
fn crowded_in_f32(positions: &[[f64; 3]], local: &[[f32; 3]]) -> bool {
    // + 0.0 turns −0 into +0: equal coordinates, equal bits.
    let bits = |p: &[f32; 3]| p.map(|x| (x + 0.0).to_bits());
    // Sorting (bits, id) pairs, not ids by bits looked up at every comparison (a cache miss
    // each): only the groups of equal bits matter, and they are the same.
    let mut pairs: Vec<([u32; 3], u32)> = local
        .par_iter()
        .enumerate()
        .map(|(i, p)| (bits(p), i as u32))
        .collect();
    pairs.par_sort_unstable();
    pairs
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|group| group.len() > F32_CROWD)
        .any(|group| {
            let mut exact: Vec<[u64; 3]> = group
                .iter()
                .map(|&(_, i)| positions[i as usize].map(|x| (x + 0.0).to_bits()))
                .collect();
            exact.sort_unstable();
            exact.dedup();
            exact.len() > F32_CROWD
        })
}

impl KdTree {
    pub fn new(positions: &[[f64; 3]]) -> Result<KdTree> {
        if positions.is_empty() {
            return Err(Error::TooFewPoints {
                what: "k-d tree",
                needed: 1,
                got: 0,
            });
        }
        let (lo, hi) = crate::geometry::bounds(positions);
        if !(0..3).all(|k| lo[k].is_finite() && hi[k].is_finite()) {
            return Err(Error::Degenerate {
                what: "k-d tree",
                why: "non-finite coordinates".into(),
            });
        }
        let (centre, half) = frame(positions, lo, hi);
        let scale = if half > 0.0 {
            pow2(-(half.log2().floor() as i32))
        } else {
            1.0
        };
        // Far outliers are clamped where their squared distances stay finite in f32: they
        // are then still ~10^18 bulk sizes away from everything.
        let far = 2f64.powi(62);
        let local: Vec<[f32; 3]> = positions
            .par_iter()
            .map(|p| [0, 1, 2].map(|k| ((p[k] - centre[k]) * scale).clamp(-far, far) as f32))
            .collect();
        let failed = |e| Error::Degenerate {
            what: "k-d tree",
            why: format!("{e:?}"),
        };
        let tree = if crowded_in_f32(positions, &local) {
            let local: Vec<[f64; 3]> = positions
                .par_iter()
                .map(|p| [0, 1, 2].map(|k| ((p[k] - centre[k]) * scale).clamp(-far, far)))
                .collect();
            Tree::F64(ImmutableKdTree::new_from_slice(&local).map_err(failed)?)
        } else {
            Tree::F32(ImmutableKdTree::new_from_slice(&local).map_err(failed)?)
        };
        Ok(KdTree {
            centre,
            scale,
            tree,
        })
    }

    /// The `k` nearest points to `q` as (id, distance), nearest first.
    pub fn nearest(&self, q: [f64; 3], k: usize) -> Vec<(u32, f64)> {
        let Some(k) = NonZeroUsize::new(k) else {
            return Vec::new();
        };
        let ql = [0, 1, 2].map(|j| (q[j] - self.centre[j]) * self.scale);
        match &self.tree {
            Tree::F32(tree) => tree
                .query(&ql.map(|x| x as f32))
                .nearest_n::<SquaredEuclidean<f32>>(k)
                .execute()
                .into_iter()
                .map(|r| (r.item, f64::from(r.distance).sqrt() / self.scale))
                .collect(),
            Tree::F64(tree) => tree
                .query(&ql)
                .nearest_n::<SquaredEuclidean<f64>>(k)
                .execute()
                .into_iter()
                .map(|r| (r.item, r.distance.sqrt() / self.scale))
                .collect(),
        }
    }
}

/// The centre and half extent the k-d tree's local coordinates are taken in: the bounding
/// box's, unless a few far points dominate it ([`bulk_frame`]).
fn frame(positions: &[[f64; 3]], lo: [f64; 3], hi: [f64; 3]) -> ([f64; 3], f64) {
    bulk_frame(positions, lo, hi).unwrap_or_else(|| {
        // Halves first: lo + hi overflows for coordinates beyond ±9e307.
        let centre = [0, 1, 2].map(|k| 0.5 * lo[k] + 0.5 * hi[k]);
        let half = (0..3)
            .map(|k| 0.5 * hi[k] - 0.5 * lo[k])
            .fold(0.0, f64::max);
        (centre, half)
    })
}

/// The centre and half extent of the bulk of the points (the 1st to 99th percentile per
/// axis, on at most 4,096 evenly spread points) when it is over 1,000 times smaller than the
/// bounding box `lo`..`hi`, `None` otherwise. Then a few far points (one outlier 1e12 away
/// from a 100-unit part) would leave the part a few f32 steps wide in the k-d tree, piled in
/// a handful of leaves that every query reads (`info` took 34 s on such a 100,000-point
/// cloud), and in one cell of the neighbour grid. Clouds without such outliers keep the
/// box's frame, and so their distances.
fn bulk_frame(positions: &[[f64; 3]], lo: [f64; 3], hi: [f64; 3]) -> Option<([f64; 3], f64)> {
    let half = (0..3)
        .map(|k| 0.5 * hi[k] - 0.5 * lo[k])
        .fold(0.0, f64::max);
    let step = positions.len().div_ceil(4096).max(1);
    let mut bulk_centre = [0.0; 3];
    let mut bulk_half = 0.0f64;
    for k in 0..3 {
        let mut v: Vec<f64> = positions.iter().step_by(step).map(|p| p[k]).collect();
        v.sort_by(f64::total_cmp);
        let cut = v.len() / 100;
        let (a, b) = (v[cut], v[v.len() - 1 - cut]);
        bulk_centre[k] = 0.5 * a + 0.5 * b;
        bulk_half = bulk_half.max(0.5 * b - 0.5 * a);
    }
    (bulk_half > 0.0 && half > 1000.0 * bulk_half).then_some((bulk_centre, bulk_half))
}

/// A 64-bit mix of a position's coordinate bits (splitmix64's finaliser over each word in
/// turn): different positions rarely share it, and [`Distinct::of`] does not rely on it.
fn mix(bits: [u64; 3]) -> u64 {
    bits.iter().fold(0x9e37_79b9_7f4a_7c15u64, |h, &w| {
        let mut z = (h ^ w).wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    })
}

/// 2^n, with n clamped to the normal f64 exponents (a subnormal cloud gets the largest scale
/// there is, which still brings it far above f32's smallest normal number).
fn pow2(n: i32) -> f64 {
    f64::from_bits(((n.clamp(-1022, 1023) + 1023) as u64) << 52)
}

/// k nearest neighbours of every point (itself excluded), in parallel. Ties at equal distance
/// are broken by id so the result is deterministic.
pub fn knn(positions: &[[f64; 3]], k: usize) -> Result<Knn> {
    if positions.len() <= k {
        return Err(Error::TooFewPoints {
            what: "k nearest neighbours",
            needed: k + 1,
            got: positions.len(),
        });
    }
    let tree = KdTree::new(positions)?;
    let rows: Vec<(Vec<u32>, Vec<f64>)> = positions
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            // One extra to drop the point itself, whatever its rank among duplicates.
            let mut res = tree.nearest(*p, k + 1);
            res.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            match res.iter().position(|r| r.0 as usize == i) {
                Some(j) => {
                    res.remove(j);
                }
                None => {
                    res.pop();
                }
            }
            res.truncate(k);
            res.into_iter().unzip()
        })
        .collect();
    let mut ids = Vec::with_capacity(positions.len() * k);
    let mut dist = Vec::with_capacity(positions.len() * k);
    for (a, b) in rows {
        ids.extend(a);
        dist.extend(b);
    }
    Ok(Knn { k, ids, dist })
}

/// The distinct positions of a cloud: points with exactly equal coordinates (+0 = −0) are
/// one position, represented by the first of them.
///
/// Why: a scan with many copies of a point (a stuck sensor, merged tiles, an f32 file far from
/// the origin where one float step is wider than the part) puts them all in one k-d tree leaf
/// and one grid cell, and every query near them reads all of them: 50,000 copies of one point
/// took `sharpedge info` 26 s and `run` 29 s. The copies say nothing a single point does not,
/// so the stages run on the distinct positions and each copy gets its first point's result.
/// Found by sorting (O(N log N), no hash a hostile file could make collide).
#[derive(Debug, Clone, PartialEq)]
pub struct Distinct {
    /// Id of the first point at each distinct position, ascending.
    pub first: Vec<u32>,
    /// Distinct index of every point; empty when no position repeats (the index is then the
    /// point id).
    of_point: Vec<u32>,
}

impl Distinct {
    /// Groups `positions` (finite or not: NaN coordinates are grouped by their bits).
    pub fn of(positions: &[[f64; 3]]) -> Result<Distinct> {
        if positions.len() > u32::MAX as usize {
            return Err(Error::Degenerate {
                what: "duplicate points",
                why: format!("{} points exceed the 2^32 limit", positions.len()),
            });
        }
        // Adding +0 turns −0 into +0, so equal coordinates have equal bits.
        let key = |p: &[f64; 3]| p.map(|c| (c + 0.0).to_bits());
        // Sorting 16-byte (hash, id) pairs instead of the 32-byte exact keys, the whole cost
        // on a cloud without copies, took a 1,000,000-point box from 0.059–0.073 s to
        // 0.043–0.060 s on 2 threads of a busy machine (the k-d tree's build: 0.066–0.086 s).
        // Equal positions have equal hashes; points with equal hashes are then sorted by
        // their exact keys, so colliding hashes (by chance or by a hostile file) cost a sort
        // of their run, never a comparison of all pairs.
        let mut order: Vec<(u64, u32)> = positions
            .par_iter()
            .enumerate()
            .map(|(i, p)| (mix(key(p)), i as u32))
            .collect();
        order.par_sort_unstable();
        if order.windows(2).all(|w| w[0].0 != w[1].0) {
            return Ok(Distinct {
                first: (0..positions.len() as u32).collect(),
                of_point: Vec::new(),
            });
        }
        // Each point's first point: the lowest id of its group.
        let mut first_of: Vec<u32> = (0..positions.len() as u32).collect();
        for run in order.chunk_by_mut(|a, b| a.0 == b.0) {
            if run.len() == 1 {
                continue;
            }
            // Within a run, by exact key, then id: a group's first point leads it.
            run.sort_unstable_by_key(|&(_, i)| (key(&positions[i as usize]), i));
            for group in
                run.chunk_by(|a, b| key(&positions[a.1 as usize]) == key(&positions[b.1 as usize]))
            {
                for &(_, i) in group {
                    first_of[i as usize] = group[0].1;
                }
            }
        }
        drop(order);
        let mut first = Vec::new();
        let mut of_point = vec![0u32; positions.len()];
        for i in 0..positions.len() {
            let f = first_of[i] as usize;
            of_point[i] = if f == i {
                first.push(i as u32);
                (first.len() - 1) as u32
            } else {
                of_point[f]
            };
        }
        if first.len() == positions.len() {
            // Only colliding hashes, no copies.
            of_point.clear();
        }
        Ok(Distinct { first, of_point })
    }

    /// Number of distinct positions.
    pub fn len(&self) -> usize {
        self.first.len()
    }

    pub fn is_empty(&self) -> bool {
        self.first.is_empty()
    }

    /// Whether some position holds more than one point.
    pub fn has_duplicates(&self) -> bool {
        !self.of_point.is_empty()
    }

    /// The distinct positions, in the order of their first points.
    pub fn positions(&self, positions: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.first.iter().map(|&i| positions[i as usize]).collect()
    }

    /// The distinct index of point `i`.
    pub fn index(&self, i: usize) -> usize {
        if self.has_duplicates() {
            self.of_point[i] as usize
        } else {
            i
        }
    }

    /// Per-point values from per-distinct-position ones: each point gets its position's.
    pub fn expand<T: Clone>(&self, values: Vec<T>) -> Vec<T> {
        if !self.has_duplicates() {
            return values;
        }
        self.of_point
            .iter()
            .map(|&d| values[d as usize].clone())
            .collect()
    }
}

/// Mean distance from a point to its nearest *distinct* neighbour, over the distinct
/// positions (copies of a point count once) but isolated points (over 1,000 times the
/// median), estimated on an evenly spread subsample of at most `max_samples` of them (all
/// when fewer). `None` when there are fewer than two distinct positions.
pub fn mean_spacing(positions: &[[f64; 3]], max_samples: usize) -> Option<f64> {
    mean_spacing_of(&Distinct::of(positions).ok()?, positions, max_samples)
}

/// [`mean_spacing`] with the distinct positions of `positions` found already.
pub fn mean_spacing_of(
    distinct: &Distinct,
    positions: &[[f64; 3]],
    max_samples: usize,
) -> Option<f64> {
    if distinct.len() < 2 {
        return None;
    }
    if distinct.has_duplicates() {
        let positions = distinct.positions(positions);
        return mean_spacing_in(&KdTree::new(&positions).ok()?, &positions, max_samples);
    }
    mean_spacing_in(&KdTree::new(positions).ok()?, positions, max_samples)
}

/// [`mean_spacing`] with a tree of `positions` built already; `positions` must be distinct
/// ([`Distinct`]), so the nearest other point of the tree is a distinct one.
pub fn mean_spacing_in(tree: &KdTree, positions: &[[f64; 3]], max_samples: usize) -> Option<f64> {
    if positions.len() < 2 {
        return None;
    }
    let step = positions.len().div_ceil(max_samples.max(1));
    let sample: Vec<usize> = (0..positions.len()).step_by(step).collect();
    let dists: Vec<f64> = sample
        .par_iter()
        .filter_map(|&i| {
            let p = positions[i];
            // The point itself comes first, at distance 0; positions distinct in f64 may
            // still round to one f32 point of the tree, so look a little further then.
            let mut k = 2;
            loop {
                let res = tree.nearest(p, k.min(positions.len()));
                if let Some(d) = res.iter().map(|r| r.1).find(|&d| d > 0.0) {
                    return Some(d);
                }
                if k >= positions.len() || k >= 128 {
                    return None;
                }
                k *= 4;
            }
        })
        .collect();
    if dists.is_empty() {
        return None;
    }
    // Samples over FAR_SAMPLE times the median are isolated points, left out of the mean: one
    // point 1e12 away from a 20,000-point box made the mean 8.7e7 and the line check called
    // the box a line. Samples under the median over FAR_SAMPLE are near-copies, left out
    // too: 5,000 points within 1e-9 of one point of a 20,000-point box (which the f32 k-d
    // tree could not tell apart, and so dropped) made the mean 0.87 for the box's 1.09. On
    // clouds without such points the mean is what it was.
    let mut sorted = dists.clone();
    let mid = sorted.len() / 2;
    let median = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
    let kept: Vec<f64> = dists
        .into_iter()
        .filter(|&d| d <= FAR_SAMPLE * median && d * FAR_SAMPLE >= median)
        .collect();
    Some(kept.iter().sum::<f64>() / kept.len() as f64)
}

/// See [`mean_spacing_in`]: a nearest distance this many times the median is an isolated
/// point's, and one this many times smaller a near-copy's, not the sampling's.
const FAR_SAMPLE: f64 = 1000.0;

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::SmallRng;
    use rand::{RngExt, SeedableRng};

    fn random_cloud(n: usize, seed: u64, scale: f64, offset: f64) -> Vec<[f64; 3]> {
        let mut rng = SmallRng::seed_from_u64(seed);
        (0..n)
            .map(|_| [0, 1, 2].map(|_| offset + scale * rng.random::<f64>()))
            .collect()
    }

    fn brute_within(pts: &[[f64; 3]], q: [f64; 3], r: f64) -> Vec<u32> {
        (0..pts.len() as u32)
            .filter(|&i| {
                let p = pts[i as usize];
                let d2: f64 = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum();
                d2 <= r * r
            })
            .collect()
    }

    /// Every point as (id, distance to `q`), nearest first, ties by id.
    fn brute_nearest(pts: &[[f64; 3]], q: [f64; 3]) -> Vec<(u32, f64)> {
        let mut all: Vec<(u32, f64)> = (0..pts.len() as u32)
            .map(|j| {
                let d2: f64 = (0..3).map(|k| (pts[j as usize][k] - q[k]).powi(2)).sum();
                (j, d2.sqrt())
            })
            .collect();
        all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        all
    }

    /// The ids of the points within `reach` of the segment `a`–`b`, sorted.
    fn brute_near_segment(pts: &[[f64; 3]], a: [f64; 3], b: [f64; 3], reach: f64) -> Vec<u32> {
        (0..pts.len() as u32)
            .filter(|&i| {
                let p = pts[i as usize];
                let ab = [0, 1, 2].map(|k| b[k] - a[k]);
                let ap = [0, 1, 2].map(|k| p[k] - a[k]);
                let l2: f64 = ab.iter().map(|x| x * x).sum();
                let t = if l2 > 0.0 {
                    (0..3).map(|k| ab[k] * ap[k]).sum::<f64>() / l2
                } else {
                    0.0
                };
                let t = t.clamp(0.0, 1.0);
                (0..3).map(|k| (ap[k] - t * ab[k]).powi(2)).sum::<f64>() <= reach * reach
            })
            .collect()
    }

    #[test]
    fn grid_radius_query_matches_brute_force() {
        let pts = random_cloud(3000, 7, 10.0, 0.0);
        for r in [0.3, 1.0, 2.5] {
            let grid = Grid::new(&pts, r).unwrap();
            for q in random_cloud(50, 8, 12.0, -1.0)
                .into_iter()
                .chain(pts[..20].iter().copied())
            {
                assert_eq!(grid.within(q, r), brute_within(&pts, q, r), "r={r} q={q:?}");
            }
        }
    }

    #[test]
    fn weighted_block_scan_weighs_exactly_the_points_within_the_radius() {
        let pts = random_cloud(3000, 17, 10.0, 0.0);
        let grid = Grid::new(&pts, 1.0).unwrap();
        let ids = grid.in_slot_order(&(0..pts.len() as u32).collect::<Vec<_>>());
        for block in grid.blocks().iter().step_by(7) {
            for &i in grid.slot_ids(block.slots.clone()) {
                let q = pts[i as usize];
                // Within the cell (weights 0 and 1) and wider (the ring scan, weight 1).
                for r in [0.6, 1.0, 1.7] {
                    let mut got = Vec::new();
                    let mut sum = [0.0; 3];
                    grid.for_each_in_block_weighted(block, q, r, |s, d, w| {
                        assert!(w == 0.0 || w == 1.0);
                        if w == 1.0 {
                            got.push(ids[s]);
                        }
                        for k in 0..3 {
                            sum[k] += w * d[k];
                        }
                    });
                    got.sort_unstable();
                    let want = brute_within(&pts, q, r);
                    assert_eq!(got, want, "r={r} q={q:?}");
                    let mut exact = [0.0; 3];
                    grid.for_each_within_block(block, q, r, |_, d, _| {
                        for k in 0..3 {
                            exact[k] += d[k];
                        }
                    });
                    assert_eq!(
                        sum, exact,
                        "weighted sums must equal the plain ones bit for bit"
                    );
                }
            }
        }
    }

    #[test]
    fn radius_wider_than_the_cell_matches_brute_force() {
        // Local scale gives some points radii several cells wide; the block path must agree.
        let pts = random_cloud(3000, 17, 10.0, 0.0);
        let grid = Grid::new(&pts, 0.4).unwrap();
        let blocks = grid.blocks();
        for r in [0.39, 0.41, 1.3, 3.7] {
            for q in random_cloud(30, 9, 12.0, -1.0) {
                assert_eq!(grid.within(q, r), brute_within(&pts, q, r), "r={r} q={q:?}");
            }
            for block in blocks.iter().step_by(41) {
                let i = grid.slot_ids(block.slots.clone())[0];
                let q = pts[i as usize];
                let mut got = Vec::new();
                grid.for_each_within_block(block, q, r, |j, _, _| got.push(j));
                got.sort_unstable();
                assert_eq!(got, brute_within(&pts, q, r), "block query r={r}");
            }
        }
    }

    #[test]
    fn segment_query_matches_brute_force() {
        let pts = random_cloud(4000, 21, 10.0, 0.0);
        // With a point 1e12 away the grid has 2^21 cells a side, and a segment to it crosses
        // millions of them: the occupied cells are tested instead.
        let mut far = pts.clone();
        far.push([1e12, 2e11, 1e12]);
        let segs = [
            ([1.0, 1.0, 1.0], [9.0, 8.0, 7.5], 2.3),
            ([5.0, 5.0, 5.0], [5.0, 5.0, 5.0], 1.5),
            ([-3.0, 2.0, 4.0], [2.0, 2.0, 4.0], 0.4),
            ([0.0, 9.5, 0.0], [10.0, 9.5, 10.0], 3.0),
            ([5.0, 5.0, 5.0], [1e12, 2e11, 1e12], 3.0),
            ([5.0, 5.0, 5.0], [-1e12, 5.0, 5.0], 1e6),
        ];
        for (pts, (a, b, reach)) in [&pts, &far]
            .into_iter()
            .flat_map(|p| segs.iter().map(move |s| (p, *s)))
        {
            let grid = Grid::new(pts, 0.7).unwrap();
            let mut got = Vec::new();
            grid.for_each_near_segment(a, b, reach, |i| got.push(i));
            let n = got.len();
            got.sort_unstable();
            got.dedup();
            assert_eq!(n, got.len(), "a point was visited twice");
            let want = brute_near_segment(pts, a, b, reach);
            assert_eq!(got, want, "segment {a:?}-{b:?} reach {reach}");
        }
    }

    #[test]
    fn sparse_layout_matches_brute_force() {
        // Two clumps very far apart: the dense grid would have ~10^15 cells.
        let mut pts = random_cloud(500, 3, 1.0, 0.0);
        pts.extend(random_cloud(500, 4, 1.0, 1.0e6));
        let grid = Grid::new(&pts, 0.2).unwrap();
        assert!(matches!(grid.layout, Layout::Sparse { .. }));
        for &q in pts.iter().step_by(37) {
            assert_eq!(grid.within(q, 0.2), brute_within(&pts, q, 0.2));
        }
    }

    #[test]
    fn radius_wider_than_the_cloud_beside_a_far_outlier_matches_brute_force() {
        // A part and one point 1e12 away: 2^21 cells a side, and the outlier's radius spans
        // them all (visiting every row would take hours).
        let mut pts = random_cloud(2000, 43, 10.0, 0.0);
        pts.push([1e12, 1e12, 1e12]);
        let grid = Grid::new(&pts, 0.5).unwrap();
        assert!(matches!(grid.layout, Layout::Sparse { .. }));
        for (q, r) in [
            (pts[2000], 2e12),
            (pts[2000], 1.7e12),
            (pts[5], 3e12),
            (pts[5], f64::INFINITY),
        ] {
            assert_eq!(grid.within(q, r), brute_within(&pts, q, r), "r {r:e}");
        }
    }

    #[test]
    fn cells_beside_far_outliers_keep_the_asked_size_and_queries_stay_exact() {
        // A part between points 1e12 and 1e300 away on either side: the part's cells are
        // 0.5 wide (with 2^21 cells over the box they were 5e5 to 1e294 wide, the whole part
        // in one cell), the far points share the outermost cells, and radius and segment
        // queries from the part and from the far points find what brute force finds.
        let part = random_cloud(3000, 47, 10.0, 0.0);
        for far in [
            vec![[1e12, 1e12, 1e12]],
            vec![[-1e12, 5.0, 5.0]],
            vec![
                [1e300, -1e300, 3.0],
                [-1e300, 2.0, 1e300],
                [9e299, -1e300, 3.0],
            ],
        ] {
            let mut pts = part.clone();
            pts.extend(&far);
            let grid = Grid::new(&pts, 0.5).unwrap();
            assert_eq!(grid.cell(), 0.5);
            let in_part = part.iter().step_by(97).map(|&q| (q, 0.5));
            let wide = far.iter().map(|&q| (q, 2e300)).chain([(part[3], 1e12)]);
            for (q, r) in in_part.chain(wide) {
                assert_eq!(grid.within(q, r), brute_within(&pts, q, r), "r {r:e}");
            }
            let toward = far[0].map(|x| x.clamp(-1e15, 1e15));
            for (a, b, reach) in [(part[0], part[1], 0.7), (part[2], toward, 1.0)] {
                let mut got = Vec::new();
                grid.for_each_near_segment(a, b, reach, |i| got.push(i));
                got.sort_unstable();
                let want = brute_near_segment(&pts, a, b, reach);
                assert_eq!(got, want, "segment to {b:?}");
            }
        }
    }

    #[test]
    fn grid_keeps_precision_at_georeferenced_offsets() {
        let base = random_cloud(400, 5, 1.0, 0.0);
        let far: Vec<[f64; 3]> = base
            .iter()
            .map(|p| [p[0] + 512345.123, p[1] + 4101234.567, p[2] + 80.0])
            .collect();
        let g1 = Grid::new(&base, 0.15).unwrap();
        let g2 = Grid::new(&far, 0.15).unwrap();
        for i in (0..base.len()).step_by(13) {
            assert_eq!(g1.within(base[i], 0.15), g2.within(far[i], 0.15));
        }
    }

    #[test]
    fn crowd_keeps_a_weighted_share_of_crowded_cells_only() {
        let mut pts = random_cloud(5_000, 3, 10.0, 0.0);
        assert!(Grid::new(&pts, 1.0).unwrap().crowd(&pts, 64, 256).is_none());
        // 20,000 points within 1e-3 of one point.
        let at = pts[17];
        let blob = random_cloud(20_000, 4, 2e-3, 0.0);
        pts.extend(blob.iter().map(|d| [0, 1, 2].map(|k| at[k] + d[k] - 1e-3)));
        let grid = Grid::new(&pts, 1.0).unwrap();
        let crowd = grid.crowd(&pts, 64, 256).unwrap();
        assert!(crowd.ids.windows(2).all(|w| w[0] < w[1]));
        // Every point is accounted for: the weights sum to the cloud's size.
        let total: f64 = crowd.weight.iter().sum();
        assert!((total - pts.len() as f64).abs() < 1e-6, "{total}");
        // The blob's cell keeps at most its cap (64 x the median cell's 5 points); the
        // others keep all their points, with weight 1.
        let kept_blob = crowd.ids.iter().filter(|&&i| i >= 5_000).count();
        assert!((100..=64 * 6).contains(&kept_blob), "{kept_blob}");
        let ones = crowd.weight.iter().filter(|&&w| w == 1.0).count();
        assert!(ones >= 4_990, "{ones}");
        // Weighted counts within a radius estimate the true counts (brute force).
        for q in [at, pts[100], [at[0] + 0.3, at[1], at[2]]] {
            let want = brute_within(&pts, q, 0.8).len() as f64;
            let mut got = 0.0;
            crowd
                .grid
                .for_each_within(q, 0.8, |k, _, _| got += crowd.weight[k as usize]);
            assert!(
                (got - want).abs() <= 0.02 * want + 1.0,
                "{q:?}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn grid_rejects_bad_input() {
        assert!(Grid::new(&[], 1.0).is_err());
        assert!(Grid::new(&[[0.0; 3]], 0.0).is_err());
        assert!(Grid::new(&[[0.0; 3]], f64::NAN).is_err());
        let e = Grid::new(&[[0.0, f64::NAN, 0.0]], 1.0).err().unwrap();
        assert!(e.to_string().contains("non-finite"), "{e}");
    }

    #[test]
    fn knn_matches_brute_force() {
        let pts = random_cloud(800, 11, 5.0, 100.0);
        let k = 6;
        let nn = knn(&pts, k).unwrap();
        for i in (0..pts.len()).step_by(17) {
            let all: Vec<(u32, f64)> = brute_nearest(&pts, pts[i])
                .into_iter()
                .filter(|&(j, _)| j as usize != i)
                .collect();
            let want: Vec<u32> = all[..k].iter().map(|x| x.0).collect();
            assert_eq!(nn.of(i), &want[..], "point {i}");
            for (a, b) in nn.dist[i * k..(i + 1) * k].iter().zip(&all[..k]) {
                assert!((a - b.1).abs() < 1e-5 * b.1.max(1.0));
            }
        }
    }

    #[test]
    fn distinct_groups_exact_copies_onto_their_first_point() {
        let a = [1.0, 2.0, 3.0];
        let b = [1.0, 2.0, 3.0 + 1e-15];
        let pts = [a, b, [0.0, -0.0, 5.0], a, [-0.0, 0.0, 5.0], b, a, [7.0; 3]];
        let d = Distinct::of(&pts).unwrap();
        assert!(d.has_duplicates());
        // a, b (distinct from a by one ulp), the zeros (−0 = +0), [7, 7, 7].
        assert_eq!(d.first, vec![0, 1, 2, 7]);
        assert_eq!(
            (0..pts.len()).map(|i| d.index(i)).collect::<Vec<_>>(),
            vec![0, 1, 2, 0, 2, 1, 0, 3]
        );
        assert_eq!(d.positions(&pts), vec![a, b, [0.0, -0.0, 5.0], [7.0; 3]]);
        assert_eq!(
            d.expand(vec!['a', 'b', 'z', 's']),
            vec!['a', 'b', 'z', 'a', 'z', 'b', 'a', 's']
        );
    }

    #[test]
    fn distinct_without_copies_is_the_identity() {
        let pts = random_cloud(2000, 12, 1.0, 0.0);
        let d = Distinct::of(&pts).unwrap();
        assert!(!d.has_duplicates());
        assert_eq!(d.len(), pts.len());
        assert_eq!(d.index(1234), 1234);
        assert_eq!(d.expand(vec![5u8, 6]), vec![5, 6]);
        assert!(Distinct::of(&[]).unwrap().is_empty());
    }

    #[test]
    fn distinct_of_many_copies_of_few_positions() {
        // 30,000 points on 3 positions, interleaved: three groups, first points 0, 1, 2.
        let pos = [[0.5, 0.0, 0.0], [0.0, 1e-300, 0.0], [0.0, 0.0, 1e300]];
        let pts: Vec<[f64; 3]> = (0..30_000).map(|i| pos[i % 3]).collect();
        let d = Distinct::of(&pts).unwrap();
        assert_eq!(d.first, vec![0, 1, 2]);
        assert!((0..pts.len()).all(|i| d.index(i) == i % 3));
    }

    #[test]
    fn kd_tree_distances_do_not_depend_on_the_scale() {
        // Powers of two change no rounding: the same neighbours, the distances scaled bit for
        // bit; other factors, within float rounding. Before the tree was scaled, a cloud
        // 1e-30 wide had all its f32 squared distances at 0 and 1e30 at infinity.
        let pts = random_cloud(3000, 31, 10.0, 5.0);
        let tree = KdTree::new(&pts).unwrap();
        for s in [2f64.powi(-120), 2f64.powi(110), 1e-30, 1e30, 1e-300, 1e300] {
            let scaled: Vec<[f64; 3]> = pts.iter().map(|p| p.map(|x| x * s)).collect();
            let st = KdTree::new(&scaled).unwrap();
            for i in (0..pts.len()).step_by(97) {
                let want = tree.nearest(pts[i], 6);
                let got = st.nearest(scaled[i], 6);
                if s.log2().fract() == 0.0 {
                    let unscaled: Vec<(u32, f64)> = got.iter().map(|&(j, d)| (j, d / s)).collect();
                    assert_eq!(unscaled, want, "scale {s:e}, point {i}");
                } else {
                    // Coordinates rounded to f32 in a cloud 10 wide: a few 1e-7 per distance.
                    for (g, w) in got.iter().zip(&want) {
                        assert!((g.1 / s - w.1).abs() <= 1e-5, "scale {s:e}, point {i}");
                    }
                }
            }
        }
    }

    #[test]
    fn kd_tree_tells_apart_thousands_of_points_within_a_billionth() {
        // 3,000 distinct points within 1e-9 of one point of a part 10 wide round to a few f32
        // points: the f32 tree put them all at distance 0 from each other, and every query
        // among them read all of them. Their nearest neighbours must be the true ones.
        let mut pts = random_cloud(2000, 53, 10.0, 0.0);
        let c = pts[7];
        pts.extend(
            random_cloud(3000, 54, 1e-9, 0.0)
                .iter()
                .map(|d| [c[0] + d[0], c[1] + d[1], c[2] + d[2]]),
        );
        let tree = KdTree::new(&pts).unwrap();
        for i in (2000..pts.len()).step_by(71).chain([7, 100]) {
            let all = brute_nearest(&pts, pts[i]);
            let got = tree.nearest(pts[i], 4);
            assert_eq!(got[0], (i as u32, 0.0), "point {i}");
            for (g, w) in got.iter().zip(&all).skip(1) {
                assert!(
                    (g.1 - w.1).abs() <= 1e-12 * w.1.max(1.0),
                    "point {i}: {g:?} vs {w:?}"
                );
                assert!(g.1 > 0.0, "point {i}");
            }
        }
    }

    #[test]
    fn kd_tree_keeps_the_bulk_precise_beside_a_far_outlier() {
        // One point 1e12 away: with the box's centre and extent the 3,000 bulk points would
        // be a few f32 steps wide. The bulk's neighbours must be what they are without it.
        let pts = random_cloud(3000, 41, 10.0, 0.0);
        let mut with = pts.clone();
        with.push([1e12, -1e12, 3e11]);
        with.push([f64::MAX, 0.0, 0.0]);
        let (a, b) = (KdTree::new(&pts).unwrap(), KdTree::new(&with).unwrap());
        for i in (0..pts.len()).step_by(53) {
            let (want, got) = (a.nearest(pts[i], 5), b.nearest(pts[i], 5));
            let ids = |v: &[(u32, f64)]| v.iter().map(|r| r.0).collect::<Vec<_>>();
            assert_eq!(ids(&got), ids(&want), "point {i}");
            for (g, w) in got.iter().zip(&want) {
                assert!((g.1 - w.1).abs() <= 1e-5, "point {i}: {} vs {}", g.1, w.1);
            }
        }
        // The outliers' own nearest: each other, then the bulk.
        let near = b.nearest(with[3000], 2);
        assert_eq!(near[0].0, 3000);
        assert!(near[1].1 > 1e11, "{near:?}");
    }

    #[test]
    fn mean_spacing_counts_copies_once() {
        let pts = random_cloud(3000, 13, 10.0, 0.0);
        let mut copied = pts.clone();
        copied.extend(std::iter::repeat_n(pts[17], 20_000));
        assert_eq!(mean_spacing(&copied, 50_000), mean_spacing(&pts, 50_000));
        assert_eq!(
            mean_spacing(&[[1.0, 2.0, 3.0], [1.0, 2.0, 4.0]], 10),
            Some(1.0)
        );
    }

    #[test]
    fn mean_spacing_leaves_out_near_copies() {
        // 5,000 distinct points within 1e-9 of one point of a 20,000-point cloud: the mean is
        // the cloud's (their nearest distances are a billion times below it).
        let pts = random_cloud(20_000, 61, 10.0, 0.0);
        let c = pts[5];
        let mut crowded = pts.clone();
        crowded.extend(
            random_cloud(5000, 62, 1e-9, 0.0)
                .iter()
                .map(|d| [c[0] + d[0], c[1] + d[1], c[2] + d[2]]),
        );
        let (with, without) = (mean_spacing(&crowded, 50_000), mean_spacing(&pts, 50_000));
        let (with, without) = (with.unwrap(), without.unwrap());
        // pts[5] itself now has a near-copy as its nearest point: one sample fewer.
        assert!(
            (with - without).abs() < 1e-3 * without,
            "{with} vs {without}"
        );
    }

    #[test]
    fn mean_spacing_of_a_grid_is_its_pitch() {
        let pts: Vec<[f64; 3]> = (0..40)
            .flat_map(|i| (0..40).map(move |j| [i as f64 * 0.5, j as f64 * 0.5, 3.0]))
            .collect();
        let s = mean_spacing(&pts, 10_000).unwrap();
        assert!((s - 0.5).abs() < 1e-6, "{s}");
    }

    #[test]
    fn mean_spacing_ignores_duplicates_and_rejects_identical_points() {
        let mut pts: Vec<[f64; 3]> = (0..30).map(|i| [i as f64, 0.0, 0.0]).collect();
        let dup = pts.clone();
        pts.extend(dup);
        assert!((mean_spacing(&pts, 1000).unwrap() - 1.0).abs() < 1e-6);
        assert_eq!(mean_spacing(&[[1.0, 2.0, 3.0]; 50], 1000), None);
        assert_eq!(mean_spacing(&[[1.0, 2.0, 3.0]], 1000), None);
    }
}
