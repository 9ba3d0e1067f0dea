//! Hostile files (issue 12): counts in a header that the file cannot hold, names given twice,
//! and inputs found by fuzzing. Each must answer at once with an error naming the file and
//! the problem (or be read, when the file is fine), never loop, abort on an allocation or
//! panic. Each test is named after what it guards.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use sharpedge::io::{self, CloudFormat, ReadOptions};
use sharpedge::{Cloud, Error};

fn read(path: &Path) -> Result<Cloud, Error> {
    io::read(path, &ReadOptions::default())
}

/// The message of an error that must occur, checked to start with the file's path.
fn message<T: std::fmt::Debug>(r: Result<T, Error>, path: &Path) -> String {
    let e = r.expect_err("hostile input must be an error").to_string();
    assert!(
        e.starts_with(&format!("{}: ", path.display())),
        "the message must start with the file: {e}"
    );
    e
}

fn assert_contains(e: &str, parts: &[&str]) {
    for p in parts {
        assert!(e.contains(p), "message `{e}` should contain `{p}`");
    }
}

fn write(dir: &Path, name: &str, content: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

/// Runs `f` and checks it took less than `limit` (the hostile files below took minutes or
/// for ever before the fixes).
fn quick<T>(limit: Duration, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let r = f();
    assert!(t.elapsed() < limit, "took {:?}", t.elapsed());
    r
}

const XYZ_FLOAT: &str = "property float x\nproperty float y\nproperty float z\n";

fn ply_bytes(header: &str, body: &[u8]) -> Vec<u8> {
    let mut b = header.as_bytes().to_vec();
    b.extend_from_slice(body);
    b
}

fn float_xyz(points: &[[f32; 3]]) -> Vec<u8> {
    points
        .iter()
        .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
        .collect()
}

// ---- PLY ------------------------------------------------------------------------------------

#[test]
fn ply_element_without_properties_and_count_2_pow_64_is_not_looped_over() {
    let dir = tempfile::tempdir().unwrap();
    let header = format!(
        "ply\nformat binary_little_endian 1.0\nelement void 18446744073709551615\n\
         element vertex 1\n{XYZ_FLOAT}end_header\n"
    );
    // The 161-byte file: the element takes no bytes, whatever its count.
    let bytes = ply_bytes(&header, &float_xyz(&[[1.0, 2.0, 3.0]]));
    assert_eq!(bytes.len(), 161);
    let p = write(dir.path(), "empty-element.ply", &bytes);
    let c = quick(Duration::from_secs(2), || read(&p)).unwrap();
    assert_eq!(c.positions, vec![[1.0, 2.0, 3.0]]);
    // The mesh reader skips every element it does not use the same way.
    let mesh_header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\n{XYZ_FLOAT}\
         element face 1\nproperty list uchar int vertex_indices\n\
         element void 18446744073709551615\nend_header\n"
    );
    let mut body = float_xyz(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    body.push(3);
    for i in [0i32, 1, 2] {
        body.extend_from_slice(&i.to_le_bytes());
    }
    let m = write(dir.path(), "mesh.ply", &ply_bytes(&mesh_header, &body));
    let mesh = quick(Duration::from_secs(2), || io::mesh::read_mesh(&m)).unwrap();
    assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    // In ascii every item is a line: 2^64 - 1 of them cannot follow.
    let ascii = format!(
        "ply\nformat ascii 1.0\nelement void 18446744073709551615\nelement vertex 1\n\
         {XYZ_FLOAT}end_header\n\n1 2 3\n"
    );
    let p = write(dir.path(), "empty-ascii.ply", ascii.as_bytes());
    let e = message(quick(Duration::from_secs(2), || read(&p)), &p);
    assert_contains(
        &e,
        &[
            "void 7 of 18446744073709551615",
            "the header declares 18446744073709551615 `void` items (one line each)",
            "only 7 bytes follow",
        ],
    );
}

#[test]
fn ply_element_count_beyond_the_file_is_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    // A binary element of scalars before `vertex` with more items than bytes.
    let header = format!(
        "ply\nformat binary_little_endian 1.0\nelement range 4000000000000\nproperty int a\n\
         element vertex 1\n{XYZ_FLOAT}end_header\n"
    );
    let p = write(
        dir.path(),
        "range.ply",
        &ply_bytes(&header, &float_xyz(&[[0.0; 3]; 2])),
    );
    let e = message(quick(Duration::from_secs(2), || read(&p)), &p);
    assert_contains(
        &e,
        &[
            "range 6 of 4000000000000",
            "the header declares 4000000000000 `range` items (4 bytes each)",
            "only 24 bytes follow",
        ],
    );
    // With a list, every item takes at least its count.
    let header = format!(
        "ply\nformat binary_big_endian 1.0\nelement face 100\n\
         property list ushort int vertex_indices\nelement vertex 1\n{XYZ_FLOAT}end_header\n"
    );
    let p = write(dir.path(), "faces.ply", &ply_bytes(&header, &[0u8; 40]));
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &["face 20 of 100", "(at least 2 bytes each)", "only 40 bytes"],
    );
}

#[test]
fn ply_vertex_property_given_twice_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let header = "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n\
                  property float x\nproperty float y\nproperty float z\nend_header\n";
    let p = write(dir.path(), "two-x.ply", &ply_bytes(header, &[0u8; 32]));
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &[
            "header line 5",
            "element `vertex` has two properties named `x` (header lines 4 and 5)",
            "rename or remove one",
        ],
    );
    // `info` and the mesh reader read the same header.
    let e = io::describe(&p).unwrap_err().to_string();
    assert_contains(&e, &["two properties named `x`"]);
    let e = io::mesh::read_mesh(&p).unwrap_err().to_string();
    assert_contains(&e, &["two properties named `x`"]);
    // Two elements of one name are as ambiguous.
    let header = format!(
        "ply\nformat ascii 1.0\nelement vertex 1\n{XYZ_FLOAT}element vertex 1\n\
         {XYZ_FLOAT}end_header\n0 0 0\n1 1 1\n"
    );
    let p = write(dir.path(), "two-vertex.ply", header.as_bytes());
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &[
            "header line 7",
            "element `vertex` is declared twice (header lines 3 and 7)",
        ],
    );
}

// ---- XYZ ------------------------------------------------------------------------------------

#[test]
fn xyz_header_of_20000_equal_names_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    // The 80 KB file: a header line naming 20,000 columns `a`, then points.
    let mut text = vec!["a"; 20_000].join(" ");
    text.push('\n');
    text.push_str(&vec!["1"; 20_000].join(" "));
    text.push('\n');
    let p = write(dir.path(), "names.xyz", text.as_bytes());
    let e = message(quick(Duration::from_secs(2), || read(&p)), &p);
    assert_contains(
        &e,
        &[
            "line 1",
            "columns 1 and 2 of the header line are both named `a`",
            "rename one",
        ],
    );
    // 20,000 distinct names that become equal once made PLY-safe are renamed, quickly.
    let names: Vec<String> = (0..20_000)
        .map(|i| {
            if i < 3 {
                format!("c{i}")
            } else {
                format!("a{}b", [" ", ".", ":", "!"][i % 4].repeat(i / 4 + 1))
            }
        })
        .collect();
    let mut text = names.join(",");
    text.push('\n');
    text.push_str(&vec!["1"; 20_000].join(","));
    text.push('\n');
    let p = write(dir.path(), "renamed.xyz", text.as_bytes());
    let c = quick(Duration::from_secs(5), || read(&p)).unwrap();
    assert_eq!(c.attributes.len(), 19_997);
    assert_eq!(c.attributes[0].name, "a_b");
    assert_eq!(c.attributes[1].name, "a__b");
}

// ---- LAS / LAZ ------------------------------------------------------------------------------

/// A LAS (or LAZ, by `compressed`) 1.4 file of `n` points of format 1 in `dir`.
fn small_las(dir: &Path, name: &str, n: usize, compressed: bool) -> PathBuf {
    las_of_format(dir, name, n, compressed, 1)
}

fn las_of_format(dir: &Path, name: &str, n: usize, compressed: bool, format: u8) -> PathBuf {
    let path = dir.join(name);
    let mut b = las::Builder::from((1, 4));
    b.point_format = las::point::Format::new(format).unwrap();
    b.point_format.is_compressed = compressed;
    let mut w = las::Writer::from_path(&path, b.into_header().unwrap()).unwrap();
    for i in 0..n {
        w.write_point(las::Point {
            x: i as f64,
            y: (i * 7 % 13) as f64,
            z: (i * 5 % 11) as f64,
            gps_time: Some(i as f64),
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
    path
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// The byte where a LAZ file's chunk table starts (from the 8 bytes at the point data).
fn chunk_table_at(b: &[u8]) -> usize {
    let data = u32_at(b, 96) as usize;
    u64::from_le_bytes(b[data..data + 8].try_into().unwrap()) as usize
}

#[test]
fn laz_chunk_table_claiming_billions_of_chunks_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.laz", 200, true);
    let mut b = std::fs::read(&good).unwrap();
    let table = chunk_table_at(&b);
    // The chunk count follows the table's 4-byte version: 4 billion chunks of 16 bytes each
    // made the laz crate ask for 64 GB and abort.
    b[table + 4..table + 8].copy_from_slice(&u32::MAX.to_le_bytes());
    let p = write(dir.path(), "chunks.laz", &b);
    for r in [
        read(&p).map(|_| ()),
        io::read_for_output(&p, &ReadOptions::default(), CloudFormat::Laz).map(|_| ()),
    ] {
        let e = message(r, &p);
        assert_contains(
            &e,
            &[
                &format!("LAZ chunk table at byte {table}"),
                "the chunk table declares 4294967295 chunks",
                "each chunk starts with one 28-byte point",
            ],
        );
    }
}

#[test]
fn laz_chunk_table_is_checked_whatever_the_header_size_field_says() {
    // Found by fuzzing: with a header size of 0 the VLRs were looked for at byte 0, the
    // laszip VLR was not found, the checks were skipped and laz reserved 46 GB.
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.laz", 200, true);
    let mut b = std::fs::read(&good).unwrap();
    b[94..96].copy_from_slice(&0u16.to_le_bytes());
    let table = chunk_table_at(&b);
    b[table + 4..table + 8].copy_from_slice(&u32::MAX.to_le_bytes());
    let p = write(dir.path(), "header-size.laz", &b);
    let e = message(read(&p), &p);
    assert_contains(&e, &["the chunk table declares 4294967295 chunks"]);
}

#[test]
fn laz_layer_sizes_beyond_the_chunk_are_refused_before_allocating() {
    // Found by fuzzing: a layered chunk (point format 6) whose first layer claims 4 GB made
    // laz reserve it before reading.
    let dir = tempfile::tempdir().unwrap();
    let good = las_of_format(dir.path(), "good.laz", 40, true, 6);
    let mut b = std::fs::read(&good).unwrap();
    let chunk = u32_at(&b, 96) as usize + 8;
    // The first point raw (30 bytes), the point count, then the layer sizes.
    let sizes = chunk + 30 + 4;
    b[sizes..sizes + 4].copy_from_slice(&0xffff_ff00u32.to_le_bytes());
    let p = write(dir.path(), "layers.laz", &b);
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &[
            &format!("LAZ chunk 0 of 1 at byte {chunk}"),
            "the chunk's layers declare",
        ],
    );
    // The good file reads.
    assert_eq!(read(&good).unwrap().len(), 40);
}

#[test]
fn laz_chunk_table_offset_outside_the_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.laz", 50, true);
    let mut b = std::fs::read(&good).unwrap();
    let data = u32_at(&b, 96) as usize;
    b[data..data + 8].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let p = write(dir.path(), "offset.laz", &b);
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &[
            &format!("byte {data}"),
            "the LAZ chunk table is said to start at byte 1099511627776",
            "the end of the file",
        ],
    );
}

#[test]
fn laz_chunk_of_billions_of_points_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.laz", 50, true);
    let mut b = std::fs::read(&good).unwrap();
    // The chunk size is at byte 12 of the laszip VLR's data (after compressor, coder,
    // version and options); the decoder sizes a buffer of chunk size x record length.
    let at = b.windows(14).position(|w| w == b"laszip encoded").unwrap();
    let vlr_data = at - 2 + 54;
    b[vlr_data + 12..vlr_data + 16].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    let p = write(dir.path(), "chunk-size.laz", &b);
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &[
            "LAZ chunk 0 of 1",
            "the chunk declares 4000000000 points",
            "more than a LAZ chunk can hold",
        ],
    );
}

#[test]
fn laz_header_count_beyond_what_the_chunks_hold_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.laz", 50, true);
    let mut b = std::fs::read(&good).unwrap();
    // LAS 1.4: the legacy count at 107, the 64-bit count at 247.
    b[107..111].copy_from_slice(&0u32.to_le_bytes());
    b[247..255].copy_from_slice(&(1u64 << 50).to_le_bytes());
    let p = write(dir.path(), "count.laz", &b);
    let e = message(quick(Duration::from_secs(2), || read(&p)), &p);
    assert_contains(
        &e,
        &[
            "header",
            "the header declares 1125899906842624 points",
            "1 chunks hold at most 50000",
        ],
    );
}

#[test]
fn las_point_count_beyond_the_file_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.las", 10, false);
    let mut b = std::fs::read(&good).unwrap();
    b[107..111].copy_from_slice(&0u32.to_le_bytes());
    b[247..255].copy_from_slice(&(u64::MAX / 16).to_le_bytes());
    let p = write(dir.path(), "count.las", &b);
    let e = message(quick(Duration::from_secs(2), || read(&p)), &p);
    assert_contains(&e, &["header", "more than any file can hold"]);
    b[247..255].copy_from_slice(&1_000_000u64.to_le_bytes());
    let p = write(dir.path(), "more.las", &b);
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &[
            "point 10 of 1000000",
            "the point data ends early: the header declares 1000000 points of 28 bytes",
        ],
    );
}

#[test]
fn las_evlr_longer_than_the_file_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.las", 10, false);
    let mut b = std::fs::read(&good).unwrap();
    // Append one EVLR of 4 data bytes and point the header at it (LAS 1.4: start at 235,
    // count at 243).
    let start = b.len() as u64;
    let mut evlr = vec![0u8; 60];
    evlr[2..9].copy_from_slice(b"hostile");
    evlr[20..28].copy_from_slice(&4u64.to_le_bytes());
    b.extend_from_slice(&evlr);
    b.extend_from_slice(b"data");
    b[235..243].copy_from_slice(&start.to_le_bytes());
    b[243..247].copy_from_slice(&1u32.to_le_bytes());
    let p = write(dir.path(), "evlr.las", &b);
    let (c, _) = io::read_for_output(&p, &ReadOptions::default(), CloudFormat::Las).unwrap();
    assert_eq!(c.len(), 10);
    // Now it claims 2^60 bytes: las would reserve them before reading.
    let at = start as usize + 20;
    b[at..at + 8].copy_from_slice(&(1u64 << 60).to_le_bytes());
    let p = write(dir.path(), "evlr-long.las", &b);
    for r in [
        read(&p).map(|_| ()),
        io::read_for_output(&p, &ReadOptions::default(), CloudFormat::Las).map(|_| ()),
    ] {
        let e = message(r, &p);
        assert_contains(
            &e,
            &[
                &format!("EVLR 0 of 1 at byte {start}"),
                "the EVLR declares 1152921504606846976 bytes of data",
            ],
        );
    }
}

#[test]
fn small_las_and_laz_still_read() {
    // The checks must not refuse good files: empty ones, one point, many chunks.
    let dir = tempfile::tempdir().unwrap();
    for (n, compressed) in [
        (0, false),
        (0, true),
        (1, true),
        (120_000, true),
        (3, false),
    ] {
        let ext = if compressed { "laz" } else { "las" };
        let p = small_las(dir.path(), &format!("n{n}.{ext}"), n, compressed);
        let c = read(&p).unwrap();
        assert_eq!(c.len(), n, "{}", p.display());
    }
}
