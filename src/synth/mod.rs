//! The scan simulator: point clouds of parts with known sharp edges and corners.
