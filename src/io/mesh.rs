//! Triangle meshes (OFF, PLY, OBJ) for the scan simulator.
