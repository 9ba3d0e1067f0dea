//! sharpedge: sharp edges and corners of 3D scans with sub-point accuracy.
//!
//! The library holds every stage of the pipeline as a plain function over typed data, so tests
//! and other programs can call each one; the `sharpedge` binary only parses the command line
//! and calls in here. See DESIGN.md in the project's shared folder for the method and the
//! output contract.

pub mod bench;
pub mod cloud;
pub mod config;
pub mod error;
pub mod experiment;
pub mod fit;
pub mod geometry;
pub mod io;
pub mod json;
pub mod left_out;
pub mod lidar_out;
pub mod neighbours;
pub mod outcome;
pub mod pipeline;
pub mod progress;
pub mod report;
pub mod stages;
pub mod synth;
#[cfg(test)]
pub(crate) mod testdata;
pub mod tiles;

pub use cloud::{Attribute, Cloud, Column, Pose, Scan, ScanStructure, Source};
// The stages' public paths of before they were grouped under stages/ (sharpedge::features,
// ...) keep working; inside the crate they are named by their place (crate::stages::...).
pub use error::{Error, Result};
pub use stages::{corners, edges, features, rectify, segment};
