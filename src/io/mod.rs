//! Reading and writing point clouds. Format details (PLY, LAS/LAZ, XYZ, meshes) stay in here;
//! the rest of the library sees only `Cloud`.

pub mod mesh;

/// What to do with points whose coordinates are NaN or infinite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NonFinite {
    Reject,
    Drop,
}

/// PLY body encoding of written files.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlyEncoding {
    BinaryLittleEndian,
    Ascii,
}
