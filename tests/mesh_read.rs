//! `io::mesh::read_mesh` on the shared CAD meshes and PLY format files (counts from
//! ../shared/data/SOURCES.md), and on malformed inputs (each with its error text).

use std::path::{Path, PathBuf};

use sharpedge::io::mesh::{Mesh, read_mesh};

fn data(rel: &str) -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if !root.is_dir() {
        eprintln!("skipped: ../shared/data absent");
        return None;
    }
    Some(root.join(rel))
}

fn read(rel: &str) -> Option<Mesh> {
    let p = data(rel)?;
    Some(read_mesh(&p).unwrap_or_else(|e| panic!("{rel}: {e}")))
}

/// Every triangle index is in range and every coordinate finite (what a sampler relies on).
fn assert_valid(m: &Mesh) {
    let n = m.vertices.len() as u32;
    assert!(m.triangles.iter().all(|t| t.iter().all(|&i| i < n)));
    assert!(m.vertices.iter().all(|v| v.iter().all(|c| c.is_finite())));
}

#[test]
fn cad_off_meshes_have_the_documented_counts() {
    for (file, v, f) in [
        ("cad/fandisk.off", 6475, 12946),
        ("cad/anchor_dense.off", 3793, 7598),
        ("cad/joint.off", 221, 446),
        // The header's third count is a non-zero edge count (1950).
        ("cad/pinion.off", 650, 1300),
    ] {
        let Some(m) = read(file) else { return };
        assert_eq!((m.vertices.len(), m.triangles.len()), (v, f), "{file}");
        assert_valid(&m);
    }
}

#[test]
fn fandisk_first_vertex_and_extent() {
    let Some(m) = read("cad/fandisk.off") else {
        return;
    };
    assert_eq!(m.vertices[0], [0.1696, 0.04095, -0.0471]);
    let (lo, hi) = m.bbox().unwrap();
    let ext: Vec<f64> = (0..3).map(|k| hi[k] - lo[k]).collect();
    // SOURCES.md: about 0.92 x 0.51 x 1.0 (axis order as in the file).
    let mut sorted = ext.clone();
    sorted.sort_by(f64::total_cmp);
    assert!((sorted[2] - 1.0).abs() < 0.05, "{ext:?}");
    assert!((sorted[0] - 0.51).abs() < 0.05, "{ext:?}");
}

#[test]
fn box_obj_quads_become_twelve_triangles_of_a_unit_cube() {
    let Some(m) = read("cad/box.obj") else { return };
    assert_eq!(m.vertices.len(), 8);
    assert_eq!(m.triangles.len(), 12);
    assert_eq!(m.bbox(), Some(([-0.5; 3], [0.5; 3])));
    assert!((m.area() - 6.0).abs() < 1e-12);
    // `f 4 3 2 1` is the first quad: fan (4,3,2), (4,2,1) in 0-based indices.
    assert_eq!(m.triangles[0], [3, 2, 1]);
    assert_eq!(m.triangles[1], [3, 1, 0]);
}

#[test]
fn plyfmt_meshes_with_faces() {
    for (file, v, t) in [
        // 50 polygons (triangles, squares, pentagons): 80 triangles. Face element first.
        ("plyfmt/platonic_shelf.ply", 50, 80),
        ("plyfmt/platonic_shelf_big_endian.ply", 50, 80),
        ("plyfmt/platonic_shelf_ascii.ply", 50, 80),
        // Face list plus a float texcoord list per face.
        ("plyfmt/sofa.ply", 12103, 24104),
        ("plyfmt/icosahedron.ply", 12, 20),
        // Face has extra scalar properties after the list; an `edge` element follows.
        ("plyfmt/colored_tetra.ply", 4, 4),
        // List named `vertex_index`; 2 triangles and 5 quads.
        ("plyfmt/greg_turk_example2_ok_ascii.ply", 8, 12),
        // Only `tristrips` (one list, strips separated by -1): 39290 non-degenerate triangles.
        ("plyfmt/elephant_tristrips.ply", 19753, 39290),
    ] {
        let Some(m) = read(file) else { return };
        assert_eq!((m.vertices.len(), m.triangles.len()), (v, t), "{file}");
        assert_valid(&m);
    }
}

#[test]
fn platonic_shelf_encodings_agree() {
    let Some(a) = read("plyfmt/platonic_shelf.ply") else {
        return;
    };
    let b = read("plyfmt/platonic_shelf_big_endian.ply").unwrap();
    let c = read("plyfmt/platonic_shelf_ascii.ply").unwrap();
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.triangles, c.triangles);
    for (p, q) in a.vertices.iter().zip(&c.vertices) {
        for k in 0..3 {
            assert!((p[k] - q[k]).abs() <= 1e-6 * p[k].abs().max(1.0));
        }
    }
    assert_eq!(a.vertices, b.vertices);
}

#[test]
fn ply_point_clouds_are_rejected_for_having_no_faces() {
    for (file, why) in [
        ("plyfmt/simple_text.ply", "no faces"),
        ("plyfmt/simple_binary.ply", "no faces"),
        ("plyfmt/text_extradim.ply", "the mesh has no faces"), // `element face 0`
        (
            "plyfmt/all_atomic_types_ok_ascii.ply",
            "no `vertex` element",
        ),
        ("scan/bun000.ply", "no faces"), // range_grid lists, not faces
    ] {
        let Some(p) = data(file) else { return };
        let e = read_mesh(&p).unwrap_err().to_string();
        assert!(e.starts_with(&p.display().to_string()), "{e}");
        assert!(e.contains(why), "{file}: {e}");
    }
}

// ---- malformed inputs -----------------------------------------------------------------------

fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn err(name: &str, bytes: &[u8]) -> String {
    let dir = tempfile::TempDir::new().unwrap();
    let p = write(&dir, name, bytes);
    let e = read_mesh(&p).unwrap_err().to_string();
    let prefix = format!("{}: ", p.display());
    assert!(e.starts_with(&prefix), "{e}");
    e[prefix.len()..].to_owned()
}

const TETRA_OFF: &str =
    "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

#[test]
fn off_reference_tetrahedron_reads() {
    let dir = tempfile::TempDir::new().unwrap();
    let m = read_mesh(&write(&dir, "t.off", TETRA_OFF.as_bytes())).unwrap();
    assert_eq!(m.vertices.len(), 4);
    assert_eq!(m.triangles[3], [1, 2, 3]);
}

#[test]
fn off_truncated_in_faces() {
    let text = TETRA_OFF.lines().take(9).collect::<Vec<_>>().join("\n");
    assert_eq!(
        err("t.off", text.as_bytes()),
        "line 10: truncated: the header promises 4 faces, the file ends after 3"
    );
}

#[test]
fn off_truncated_in_vertices() {
    assert_eq!(
        err("t.off", b"OFF\n4 4 6\n0 0 0\n1 0 0\n"),
        "line 5: truncated: the header promises 4 vertices and 4 faces, the file ends after 2 vertices"
    );
}

#[test]
fn off_bad_counts() {
    assert_eq!(
        err("t.off", b"OFF\nfour 4 6\n"),
        "line 2: bad vertex count \"four\": expected a non-negative integer"
    );
    assert_eq!(
        err("t.off", b"OFF\n4\n"),
        "line 2: missing the face count; the counts line is `vertices faces edges`"
    );
    assert_eq!(
        err("t.off", b"PLY\n4 4 6\n"),
        "line 1: expected the keyword OFF (or COFF, NOFF, CNOFF, STOFF), found \"PLY\""
    );
}

#[test]
fn off_index_out_of_range() {
    let text = TETRA_OFF.replace("3 1 2 3", "3 1 2 4");
    assert_eq!(
        err("t.off", text.as_bytes()),
        "line 10: face 3: vertex index 4 out of range (the file has 4 vertices, indices 0..3)"
    );
}

#[test]
fn off_face_with_two_vertices_and_bad_coordinate() {
    let text = TETRA_OFF.replace("3 1 2 3", "2 1 2");
    assert_eq!(
        err("t.off", text.as_bytes()),
        "line 10: face 3 has 2 vertices; a face needs at least 3"
    );
    let text = TETRA_OFF.replace("0 0 1\n", "0 0 nan\n");
    assert_eq!(
        err("t.off", text.as_bytes()),
        "line 6: vertex 3: bad coordinate \"nan\" (expected a finite number)"
    );
}

#[test]
fn off_without_faces() {
    assert_eq!(
        err("t.off", b"OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n"),
        "file: the mesh has no faces; give a surface mesh, not a point cloud"
    );
}

#[test]
fn obj_errors() {
    assert_eq!(
        err("t.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"),
        "line 4: face 0: vertex index 4 out of range (3 vertices defined so far; indices are 1..=3 or -1..=-3)"
    );
    assert_eq!(
        err("t.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n"),
        "line 4: face 0 has 2 vertices; a face needs at least 3"
    );
    assert_eq!(
        err("t.obj", b"v 0 0\n"),
        "line 1: vertex with 2 coordinates; expected `v x y z`"
    );
    assert_eq!(
        err("t.obj", b"# only points\nv 0 0 0\nv 1 0 0\n"),
        "file: the mesh has no faces; give a surface mesh, not a point cloud"
    );
    assert_eq!(
        err("t.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 3\n"),
        "line 4: face 0: bad vertex reference \"x\""
    );
}

#[test]
fn obj_usemtl_groups_and_polygons() {
    let dir = tempfile::TempDir::new().unwrap();
    let text = "mtllib a.mtl\no part\ng side\nusemtl steel\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                vn 0 0 1\nvt 0 0\ns off\nf 1/1/1 2/1/1 3/1/1 4/1/1 # a quad\nl 1 2\n";
    let m = read_mesh(&write(&dir, "q.OBJ", text.as_bytes())).unwrap();
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
}

fn ply_binary_tetra(face_count_in_header: usize, cut_tail: usize, bad_index: bool) -> Vec<u8> {
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nelement face {face_count_in_header}\nproperty list uchar ushort vertex_indices\nend_header\n"
    )
    .into_bytes();
    for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]] {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in [
        [0u16, 2, 1],
        [0, 1, 3],
        [0, 3, 2],
        [1, 2, if bad_index { 9 } else { 3 }],
    ] {
        b.push(3);
        for i in f {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }
    b.truncate(b.len() - cut_tail);
    b
}

#[test]
fn ply_binary_ushort_indices_read() {
    let dir = tempfile::TempDir::new().unwrap();
    let m = read_mesh(&write(&dir, "t.ply", &ply_binary_tetra(4, 0, false))).unwrap();
    assert_eq!(
        m.triangles,
        vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    );
}

#[test]
fn ply_truncated_body() {
    let e = err("t.ply", &ply_binary_tetra(4, 3, false));
    assert!(
        e.starts_with(
            "element face: Unexpected end of file while reading binary element 'face' (expected 4, got 3); "
        ),
        "{e}"
    );
}

#[test]
fn ply_header_count_larger_than_body() {
    let e = err("t.ply", &ply_binary_tetra(5, 0, false));
    assert!(e.contains("(expected 5, got 4)"), "{e}");
}

#[test]
fn ply_index_out_of_range() {
    assert_eq!(
        err("t.ply", &ply_binary_tetra(4, 0, true)),
        "element face 3: vertex index 9 out of range (the file has 4 vertices, indices 0..3)"
    );
}

#[test]
fn ply_float_index_list_rejected() {
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\nelement face 1\nproperty list uchar float vertex_indices\nend_header\n\
                0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    assert!(
        err("t.ply", text.as_bytes()).starts_with(
            "header: element face: property vertex_indices must be a list of integers"
        ),
    );
}

#[test]
fn ply_vertex_without_z() {
    let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                element face 0\nproperty list uchar int vertex_indices\nend_header\n0 0\n";
    assert_eq!(
        err("t.ply", text.as_bytes()),
        "header: the vertex element has no property z"
    );
}

#[test]
fn unknown_extension_and_missing_file() {
    let e = err("t.stl", b"solid x\n");
    assert_eq!(
        e,
        "unknown file type \"stl\": a triangle mesh must be .off, .ply or .obj"
    );
    let e = read_mesh(Path::new("/nonexistent/m.off")).unwrap_err();
    // The OS reason is the error's source: `main` prints the chain once.
    assert_eq!(e.to_string(), "/nonexistent/m.off: cannot open");
    let reason = std::error::Error::source(&e)
        .expect("the OS error as source")
        .to_string();
    assert!(reason.contains("No such file"), "{reason}");
}
