//! sharpedge: sharp edges and corners of 3D scans with sub-point accuracy.
//!
//! The library holds every stage of the pipeline as a plain function over typed data, so tests
//! and other programs can call each one; the `sharpedge` binary only parses the command line
//! and calls in here. See DESIGN.md in the project's shared folder for the method and the
//! output contract.

pub mod bench;
pub mod cloud;
pub mod config;
pub mod corners;
pub mod edges;
pub mod eigen3;
pub mod error;
pub mod experiment;
pub mod features;
pub mod fit;
pub mod io;
pub mod json;
pub mod lidar_out;
pub mod neighbours;
pub mod pipeline;
pub mod polyline;
pub mod progress;
pub mod rectify;
pub mod report;
pub mod segment;
pub mod synth;
#[cfg(test)]
pub(crate) mod testdata;

pub use cloud::{Attribute, Cloud, Column, Source};
pub use error::{Error, Result};
