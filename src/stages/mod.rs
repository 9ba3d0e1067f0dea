//! The pipeline's stages, one plain function from typed input to typed output each, in the
//! order `crate::pipeline` runs them: scale (each point's spacing, noise and radius) ->
//! features (per-point PCA, sharpness, candidate edge points) -> faces (planar faces and their
//! planes) -> segment (edge runs and the vertices where they meet) -> edges (the paper's
//! constrained 2D fit per slab across each edge) -> corners (the constrained 3D fit per
//! vertex) -> plane_corners (where three planar faces meet; short edges between) -> pair_edges
//! (where two planar faces meet along a stretch the scan follows) -> convexity (the side of the material
//! of each edge) -> rectify (abnormal points moved onto the fitted faces).
//!
//! Stages use the layers below them (geometry, fit, neighbours, cloud) and the stages before
//! them, never the pipeline, the writers or a later stage.

pub mod convexity;
pub mod corners;
pub mod edges;
pub mod faces;
pub mod features;
pub mod occlusion;
pub mod pair_edges;
pub mod plane_corners;
pub mod rectify;
pub mod scale;
pub mod segment;
