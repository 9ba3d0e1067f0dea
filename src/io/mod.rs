//! Reading and writing point clouds. Format details (PLY, LAS/LAZ, XYZ, meshes) stay in here;
//! the rest of the library sees only `Cloud`.

pub mod mesh;
