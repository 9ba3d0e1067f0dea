//! Tiles: one large cloud cut into boxes with halos, each box processed by its own worker
//! (any batch engine: a Slurm job array, `xargs -P`, a Kubernetes Indexed Job), the partial
//! results joined into one result with the output contract of `run`.
//!
//! - [`plan`] (`sharpedge plan`): one streaming pass over the input → `plan.json` (the tile
//!   grid, each tile's core and halo box and expected point counts, the halo width and how it
//!   was derived, the input and the pipeline file used), a copy of the pipeline file and an
//!   `sbatch --array` script.
//! - [`run`] (`sharpedge run CONFIG --plan DIR --tile I`): streams the input keeping the
//!   points inside tile I's halo box, runs the normal pipeline on them
//!   (`pipeline::process`), keeps what the tile owns and publishes `tiles/NNNN/partial.json`
//!   and `tiles/NNNN/rectified.ply` in the plan folder (atomically, as one set); a failure
//!   is recorded in `tiles/NNNN.failed` for `merge` to name.
//! - [`merge`] (`sharpedge merge DIR --out OUT`): joins the edges cut by seams, de-duplicates
//!   corners and writes report.json, features.ply, edges.geojson and the rectified points
//!   (one PLY per tile plus the index `rectified.json`).
//!
//! Ownership is one rule everywhere ([`Grid::owner`]): a position belongs to the tile whose
//! cell of the grid holds it (cells half-open, the outer cells reaching to infinity), so every
//! point, corner and piece of edge has exactly one owner, whatever the float rounding at a
//! seam: all decisions call the same function on the same coordinates.
//!
//! The halo (README, "Tiles"): a result inside the core depends on the points around it up
//! to the reach of the stages that made it. The local scale is measured at one point per cell
//! of 10 mean spacings and smoothed over the cells within 3 cells (`stages::scale`): 40 mean
//! spacings; the features read one neighbourhood radius; a corner's 3D fit reads its edges'
//! rectified points up to `corners.reach` radii away (a curved edge; a straight one all of
//! them), each from a slab of points within `edges.band` radii of the edge. So the halo is
//! 40 spacings + (1 + corners.reach + edges.band) radii, from the spacing the plan measures
//! and the radius rule of the pipeline file; each tile checks it against the scale it
//! measures and fails, naming the halo it needs, when it is narrower.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

pub mod merge;
pub mod plan;
pub mod run;

/// The plan's file name in its folder.
pub const PLAN_FILE: &str = "plan.json";
/// The copy of the pipeline file in the plan folder (what the generated scripts run).
pub const CONFIG_FILE: &str = "pipeline.toml";
/// The generated Slurm script.
pub const SBATCH_FILE: &str = "sbatch.sh";

/// Reach of the local scale in mean spacings: cells of `SAMPLE_CELL` = 10 spacings, smoothed
/// over `SMOOTH_CELLS` = 3 cells around (`stages::scale`), plus the cell itself.
pub const SCALE_REACH_SPACINGS: f64 = 40.0;

/// A box: `[min, max]`.
pub type Bounds = [[f64; 3]; 2];

/// The tile grid: cells of `size` from `origin`, `cells` along each axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    pub origin: [f64; 3],
    pub size: [f64; 3],
    pub cells: [usize; 3],
}

impl Grid {
    /// Number of tiles (`usize::MAX` when the product of the cells overflows: a grid no plan
    /// accepts).
    pub fn len(&self) -> usize {
        self.cells
            .iter()
            .try_fold(1usize, |n, &c| n.checked_mul(c))
            .unwrap_or(usize::MAX)
    }

    /// Whether the grid has no tile.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The cell of a position along each axis (clamped into the grid: the outer cells reach to
    /// infinity).
    pub fn cell(&self, p: [f64; 3]) -> [usize; 3] {
        let mut c = [0usize; 3];
        for k in 0..3 {
            let t = ((p[k] - self.origin[k]) / self.size[k]).floor();
            let last = (self.cells[k] - 1) as f64;
            // NaN (never: positions are finite) lands in cell 0.
            c[k] = if t >= last {
                self.cells[k] - 1
            } else if t > 0.0 {
                t as usize
            } else {
                0
            };
        }
        c
    }

    /// The tile id of a cell (x fastest).
    pub fn id(&self, c: [usize; 3]) -> usize {
        c[0] + self.cells[0] * (c[1] + self.cells[1] * c[2])
    }

    /// The cell of a tile id.
    pub fn cell_of(&self, id: usize) -> [usize; 3] {
        let nx = self.cells[0];
        let ny = self.cells[1];
        [id % nx, (id / nx) % ny, id / (nx * ny)]
    }

    /// The tile owning a position.
    pub fn owner(&self, p: [f64; 3]) -> usize {
        self.id(self.cell(p))
    }

    /// The core box of a tile as planned (finite: the cell itself).
    pub fn core(&self, id: usize) -> Bounds {
        let c = self.cell_of(id);
        let mut b = [[0.0; 3]; 2];
        for k in 0..3 {
            b[0][k] = self.origin[k] + c[k] as f64 * self.size[k];
            b[1][k] = self.origin[k] + (c[k] + 1) as f64 * self.size[k];
        }
        b
    }

    /// The region a tile owns: its core with the outer sides of the grid's outer cells at
    /// infinity.
    pub fn region(&self, id: usize) -> Bounds {
        let c = self.cell_of(id);
        let mut b = self.core(id);
        for k in 0..3 {
            if c[k] == 0 {
                b[0][k] = f64::NEG_INFINITY;
            }
            if c[k] + 1 == self.cells[k] {
                b[1][k] = f64::INFINITY;
            }
        }
        b
    }
}

/// One tile of a plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tile {
    pub id: usize,
    /// Its cell in the grid.
    pub cell: [usize; 3],
    /// The box it owns (the outer tiles own everything beyond it too).
    pub core: Bounds,
    /// The box whose points it reads: the core widened by the halo.
    pub halo: Bounds,
    /// Expected points in the core and in the halo box (estimated from a uniform sample of
    /// the input; the tile's partial output has the exact counts).
    pub points: u64,
    pub halo_points: u64,
}

/// A plan: what `plan` wrote into `plan.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Plan {
    pub sharpedge: String,
    /// The input cloud (absolute path) and its format.
    pub input: PathBuf,
    pub format: String,
    /// Finite points of the input.
    pub points: u64,
    /// The pipeline file given to `plan` (absolute path) and its text: a tile refuses to run
    /// with another (the halo was derived from it).
    pub config: PathBuf,
    pub config_text: String,
    /// Bounding box of the finite points.
    pub bounds: Bounds,
    /// Mean spacing estimated from the sample, and the radius the halo assumes.
    pub spacing: f64,
    pub radius: f64,
    /// Halo width (model units) and how it was derived.
    pub halo: f64,
    pub halo_rule: String,
    pub grid: Grid,
    pub tiles: Vec<Tile>,
}

impl Plan {
    /// Reads `DIR/plan.json`.
    pub fn load(dir: &Path) -> Result<Plan> {
        let path = dir.join(PLAN_FILE);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            Error::io(
                &path,
                "cannot read the plan (make one with `sharpedge plan CONFIG --input CLOUD --out DIR`)",
                e,
            )
        })?;
        let plan: Plan = serde_json::from_str(&text).map_err(|e| Error::Plan {
            path: path.clone(),
            what: format!(
                "line {}: not a plan written by `sharpedge plan`: {e}",
                e.line()
            ),
        })?;
        let n = plan.grid.len();
        if n == 0 || plan.tiles.len() != n || plan.tiles.iter().enumerate().any(|(i, t)| t.id != i)
        {
            return Err(Error::Plan {
                path,
                what: format!(
                    "the grid has {n} cells but the plan lists {} tiles (or their ids are out of \
                     order); make the plan again",
                    plan.tiles.len()
                ),
            });
        }
        Ok(plan)
    }

    /// A tile by id, or an error naming the valid range.
    pub fn tile(&self, dir: &Path, id: usize) -> Result<&Tile> {
        self.tiles.get(id).ok_or_else(|| Error::Plan {
            path: dir.join(PLAN_FILE),
            what: format!(
                "there is no tile {id}: the plan has tiles 0 to {}",
                self.tiles.len() - 1
            ),
        })
    }
}

/// The folder of a tile's partial outputs in the plan folder.
pub fn tile_dir(plan_dir: &Path, id: usize) -> PathBuf {
    plan_dir.join("tiles").join(format!("{id:04}"))
}

/// The file recording a tile's failure (its error message).
pub fn failed_file(plan_dir: &Path, id: usize) -> PathBuf {
    plan_dir.join("tiles").join(format!("{id:04}.failed"))
}

/// Whether `p` lies in the closed box `b`.
pub fn inside(b: &Bounds, p: [f64; 3]) -> bool {
    (0..3).all(|k| p[k] >= b[0][k] && p[k] <= b[1][k])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_position_has_one_owner_and_outer_cells_reach_to_infinity() {
        let g = Grid {
            origin: [0.0, 0.0, 0.0],
            size: [1.0, 2.0, 3.0],
            cells: [3, 2, 1],
        };
        assert_eq!(g.len(), 6);
        assert_eq!(g.owner([0.5, 0.5, 0.5]), 0);
        // On a seam: the upper cell (half-open cells).
        assert_eq!(g.owner([1.0, 0.5, 0.5]), 1);
        assert_eq!(g.owner([2.0, 2.0, 0.0]), 2 + 3);
        // Outside the grid: the outer cells.
        assert_eq!(g.owner([-5.0, 9.0, 100.0]), 3);
        assert_eq!(g.owner([7.0, -1.0, -1.0]), 2);
        for id in 0..g.len() {
            assert_eq!(g.id(g.cell_of(id)), id);
            let r = g.region(id);
            let c = g.core(id);
            let mid = [0, 1, 2].map(|k| (c[0][k] + c[1][k]) / 2.0);
            assert_eq!(g.owner(mid), id);
            assert!(inside(&r, mid));
        }
        assert_eq!(g.region(0)[0][0], f64::NEG_INFINITY);
        assert_eq!(g.region(2)[1][0], f64::INFINITY);
        assert_eq!(g.region(1)[0][0], 1.0);
        // A product of cells past usize is no grid's size (it wrapped to 0 before).
        let huge = Grid {
            cells: [1 << 32, 1 << 32, 1],
            ..g
        };
        assert_eq!(huge.len(), usize::MAX);
    }
}
