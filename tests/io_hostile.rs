//! Hostile files (issue 12): counts in a header that the file cannot hold, names given twice,
//! and inputs found by fuzzing. Each must answer at once with an error naming the file and
//! the problem (or be read, when the file is fine), never loop, abort on an allocation or
//! panic. Each test is named after what it guards.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

mod io_common;

use sharpedge::io::{self, CloudFormat, ReadOptions};

use io_common::{assert_contains, message, read, write};

/// Reads `p` and checks the error's message holds every part.
fn refused(p: &Path, parts: &[&str]) {
    assert_contains(&message(read(p), p), parts);
}

/// A copy of `good` named `name`, with `patch` applied to its bytes.
fn patched(good: &Path, name: &str, patch: impl FnOnce(&mut Vec<u8>)) -> PathBuf {
    let mut b = std::fs::read(good).unwrap();
    patch(&mut b);
    write(good.parent().unwrap(), name, &b)
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
    assert_contains(&e, &["line 1", "more than 1024 columns"]);
    // Within the column limit, the equal names are named.
    let mut text = vec!["a"; 1000].join(" ");
    text.push('\n');
    let p = write(dir.path(), "names1000.xyz", text.as_bytes());
    let e = message(quick(Duration::from_secs(2), || read(&p)), &p);
    assert_contains(
        &e,
        &[
            "line 1",
            "columns 1 and 2 of the header line are both named `a`",
            "rename one",
        ],
    );
    // 1,024 distinct names (the most a line may have) that become equal once made PLY-safe
    // are renamed, quickly.
    let names: Vec<String> = (0..1024)
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
    text.push_str(&vec!["1"; 1024].join(","));
    text.push('\n');
    let p = write(dir.path(), "renamed.xyz", text.as_bytes());
    let c = quick(Duration::from_secs(5), || read(&p)).unwrap();
    assert_eq!(c.attributes.len(), 1021);
    assert_eq!(c.attributes[0].name, "a_b");
    assert_eq!(c.attributes[1].name, "a__b");
}

#[test]
fn xyz_line_of_millions_of_columns_is_refused_before_allocating_per_column() {
    // A 20 MB line of 10,000,000 numbers made an attribute per column: gigabytes.
    let dir = tempfile::tempdir().unwrap();
    let text = format!("1 2 3 {}\n", "4 ".repeat(10_000_000));
    let p = write(dir.path(), "long.xyz", text.as_bytes());
    refused(
        &p,
        &[
            "line 1",
            "more than 1024 columns",
            "at most 1021 attributes",
        ],
    );
    // The same as a header line of names.
    let names: Vec<String> = (0..5000).map(|i| format!("c{i}")).collect();
    let p = write(
        dir.path(),
        "names.xyz",
        format!("{}\n", names.join(" ")).as_bytes(),
    );
    refused(&p, &["line 1", "more than 1024 columns"]);
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

/// Both LAS/LAZ reading paths (attribute columns; raw records for a LAS/LAZ output).
fn read_both(p: &Path) -> [Result<(), sharpedge::Error>; 2] {
    [
        read(p).map(|_| ()),
        io::read_for_output(p, &ReadOptions::default(), CloudFormat::Las).map(|_| ()),
    ]
}

#[test]
fn laz_chunk_table_claiming_billions_of_chunks_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.laz", 200, true);
    let table = chunk_table_at(&std::fs::read(&good).unwrap());
    // The chunk count follows the table's 4-byte version: 4 billion chunks of 16 bytes each
    // made the laz crate ask for 64 GB and abort.
    let p = patched(&good, "chunks.laz", |b| {
        b[table + 4..table + 8].copy_from_slice(&u32::MAX.to_le_bytes())
    });
    for r in read_both(&p) {
        assert_contains(
            &message(r, &p),
            &[
                &format!("LAZ chunk table at byte {table}"),
                "the chunk table declares 4294967295 chunks",
                "each chunk starts with one 28-byte point",
            ],
        );
    }
    // Found by fuzzing: with a header size of 0 the VLRs were looked for at byte 0, the
    // laszip VLR was not found, the checks were skipped and laz reserved 46 GB.
    let p = patched(&p, "header-size.laz", |b| {
        b[94..96].copy_from_slice(&0u16.to_le_bytes())
    });
    refused(&p, &["the chunk table declares 4294967295 chunks"]);
}

#[test]
fn laz_layer_sizes_beyond_the_chunk_are_refused_before_allocating() {
    // Found by fuzzing: a layered chunk (point format 6) whose first layer claims 4 GB made
    // laz reserve it before reading.
    let dir = tempfile::tempdir().unwrap();
    let good = las_of_format(dir.path(), "good.laz", 40, true, 6);
    assert_eq!(read(&good).unwrap().len(), 40);
    let chunk = u32_at(&std::fs::read(&good).unwrap(), 96) as usize + 8;
    // The first point raw (30 bytes), the point count, then the layer sizes.
    let sizes = chunk + 30 + 4;
    let p = patched(&good, "layers.laz", |b| {
        b[sizes..sizes + 4].copy_from_slice(&0xffff_ff00u32.to_le_bytes())
    });
    refused(
        &p,
        &[
            &format!("LAZ chunk 0 of 1 at byte {chunk}"),
            "the chunk's layers declare",
        ],
    );
}

#[test]
fn laz_chunk_table_offset_outside_the_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.laz", 50, true);
    let data = u32_at(&std::fs::read(&good).unwrap(), 96) as usize;
    let p = patched(&good, "offset.laz", |b| {
        b[data..data + 8].copy_from_slice(&(1u64 << 40).to_le_bytes())
    });
    refused(
        &p,
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
    // The chunk size is at byte 12 of the laszip VLR's data (after compressor, coder,
    // version and options); the decoder sizes a buffer of chunk size x record length.
    let p = patched(&good, "chunk-size.laz", |b| {
        let at = b.windows(14).position(|w| w == b"laszip encoded").unwrap();
        let size = at - 2 + 54 + 12;
        b[size..size + 4].copy_from_slice(&4_000_000_000u32.to_le_bytes())
    });
    refused(
        &p,
        &[
            "LAZ chunk 0 of 1",
            "the chunk declares 4000000000 points",
            "more than a LAZ chunk can hold",
        ],
    );
}

/// Sets a LAS 1.4 file's point count: the legacy 32-bit field (byte 107) to 0 and the
/// 64-bit one (byte 247) to `n`.
fn set_count(b: &mut [u8], n: u64) {
    b[107..111].copy_from_slice(&0u32.to_le_bytes());
    b[247..255].copy_from_slice(&n.to_le_bytes());
}

#[test]
fn las_and_laz_point_counts_beyond_the_file_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.las", 10, false);
    let p = patched(&good, "count.las", |b| set_count(b, u64::MAX / 16));
    quick(Duration::from_secs(2), || {
        refused(&p, &["header", "more than any file can hold"])
    });
    let p = patched(&good, "more.las", |b| set_count(b, 1_000_000));
    refused(
        &p,
        &[
            "point 10 of 1000000",
            "the point data ends early: the header declares 1000000 points of 28 bytes",
        ],
    );
    // LAZ: at most the chunk table's chunks x points a chunk.
    let good = small_las(dir.path(), "good.laz", 50, true);
    let p = patched(&good, "count.laz", |b| set_count(b, 1 << 50));
    quick(Duration::from_secs(2), || {
        refused(
            &p,
            &[
                "header",
                "the header declares 1125899906842624 points",
                "1 chunks hold at most 50000",
            ],
        )
    });
}

#[test]
fn las_evlr_longer_than_the_file_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let good = small_las(dir.path(), "good.las", 10, false);
    // Append one EVLR of 4 data bytes and point the header at it (LAS 1.4: start at 235,
    // count at 243).
    let start = std::fs::metadata(&good).unwrap().len();
    let with_evlr = |len: u64| {
        move |b: &mut Vec<u8>| {
            let mut evlr = vec![0u8; 60];
            evlr[2..9].copy_from_slice(b"hostile");
            evlr[20..28].copy_from_slice(&len.to_le_bytes());
            b.extend_from_slice(&evlr);
            b.extend_from_slice(b"data");
            b[235..243].copy_from_slice(&start.to_le_bytes());
            b[243..247].copy_from_slice(&1u32.to_le_bytes());
        }
    };
    let p = patched(&good, "evlr.las", with_evlr(4));
    assert!(read_both(&p).iter().all(|r| r.is_ok()));
    // Now it claims 2^60 bytes: las would reserve them before reading.
    let p = patched(&good, "evlr-long.las", with_evlr(1 << 60));
    for r in read_both(&p) {
        assert_contains(
            &message(r, &p),
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

#[test]
fn laz_data_that_makes_the_laz_crate_panic_is_an_error() {
    // Found by fuzzing (1133 bytes, from the format 8 seed): an RGB layer that decodes to a
    // symbol past laz 0.13's decoding table (index out of bounds in decoders.rs).
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "panic.laz", &unhex(LAZ_PANIC_HEX));
    refused(&p, &["the LAZ decoder failed on this data"]);
}

#[test]
fn laz_gps_times_that_recurse_deep_in_the_laz_crate_do_not_overflow_the_stack() {
    // Found by fuzzing (1034 bytes, format 6): laz 0.13 decodes these GPS times recursively
    // so deep that rayon's 2 MB thread stacks overflowed and the process aborted.
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "deep.laz", &unhex(LAZ_DEEP_HEX));
    refused(&p, &["points 0..40 of 40", "the point data ends early"]);
}

#[test]
fn laz_gps_times_that_switch_sequences_without_end_do_not_recurse() {
    // Found by fuzzing (1133 bytes, format 6): GPS times that switch to another sequence
    // over and over; laz 0.13 read them recursively, deeper than the decoding threads' 64 MB
    // stacks (it needed 128 MB), and the process aborted. The vendored laz reads them in a
    // loop (vendor/README.md).
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "deeper.laz", &unhex(LAZ_DEEPER_HEX));
    refused(&p, &["points 0..40 of 40", "the point data ends early"]);
}

fn unhex(hex: &str) -> Vec<u8> {
    (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect()
}

/// The fuzzer's input, byte for byte.
const LAZ_PANIC_HEX: &str = concat!(
    "4c4153460000100000000000000000000000000000000000010400000000000000000000000000000000000000000000",
    "0000000000000000000000000000000000000000000000000000000000000000000000000000af870000000000007701",
    "db01000001000000882600280000000103fffe00000000000000000000000000000000fca9f1d24d62503ffca9f1d24d",
    "62503ffca9f1d24d62503f0000000000408f400000000000408f400000000000408f40295c8fc2f5478f404260e5d022",
    "388f40f2d24d6290419f400000000000409f400000000000002640c024068195032240000000000000000040420f00b8",
    "e8f0ff000000002800300000000000280000000000000000000000000000000000000000000000000000000000000000",
    "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000",
    "00000000000000000000000000000000000000000000000000000000000000000000000000000000006c61737a697020",
    "656e636f6465640000bc562e0068747470733a2f2f6c61737a69702e6f72670000000000000000000000000000030000",
    "00020200000000000050c30000ffffffffffffffffffffffffffffffff02000a001e0003000c00080003006004000000",
    "0000000000000040420f00b8e8f0ff00001100000000000000000000000000000000000300ffff1100280000007f0000",
    "003f0000000000000000000000110000000000000000000000000000000b0100004d0000000000000020a4a9605d216a",
    "6a268fea6972ac65ab361994c7dc1cb626c36318ff6c1e38e85cfd280199c547c82498ffffffffffffff0fd28f54d2c7",
    "8198adf45eb6236284e16ea596f90c34fa6c29f2c26398ee48fef32b85ee7dc044c2c3c6bcad10e88973a2bf176589b8",
    "4dcbe2b64ab08b2bf7580f81e11fe82c94e709c4d800000030c04fa162c55754758284b8c8c0e045f4b7e7d5c7762d8d",
    "6786eb8e7e58af88f72e8901b0d7d83f054b441eb180bbb1af9cf4d91fb4955a1a719a8f00000038e2887c03c7b7032f",
    "17a9364aba000000634afad117f80000024d0dcf4c78000039aa426cfa00000be43101c410000247310b198000014a63",
    "609280000182852bfce00001c9556341600002067374e0400004c03e25f3000028000000000000000000000000000000",
    "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000",
    "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000",
    "000000000000000000006c61737a697020656e636f6465640000bc562e0068747470733a2f2f6c61737a69702e6f7267",
    "000000000000000000000000000003000000020200000000000050c30000ffffffffffffffffffffffffffffffff0200",
    "0a001e0003000c00080003006004000000000800030060040000000000000000000040420f00b8e8f0ff000011000000",
    "000000000000141a283450686000000000000000010000005263870000",
);

/// The fuzzer's input, byte for byte.
const LAZ_DEEP_HEX: &str = concat!(
    "4c4153460000100000000000000000000000000000000000010400000000000000000000000000000000000000000000",
    "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000007701",
    "d501000001000000861e00280000002800000000000000000000000000000000000000fca9f1d24d62503ffca9f1d24d",
    "62503ffca9f1d24d62503f0000000000408f400000000000408f400000000000408f40295c8fc2f5478f404260e5d022",
    "348f40f2d24d6290419f400000000000409f400000000000002640c02406819503224000000000000000000000000000",
    "000000000000002800000000000000280000000000000000000000000000000000000000000000000000000000000000",
    "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000",
    "00000000000000000000000000000000000000000000000000000000000000000000000000000000006c61737a697020",
    "656e636f6465640000bc562800723a206661696c656420746f2066696c6c2077686f6c65206275660000000000030000",
    "00020200000000000050c30000ffffffffffffffffffffffffffffffff01000a001e000300fd03000000000000000000",
    "0040420f00b8e8f0ff000011000000000000000000000000000000280000007f0000003f000000000000000000000011",
    "0000000000000000000000000000000b01000020a4a9605d216a6a268fea6972ac65ab361994c7dc1cb626c36318ff6c",
    "1e38e85cfd280199c547c8249829f42c5e73e4aff0d28f54d2c78198adf45eb6236284e16ea596f90c34fa6c29f2c263",
    "98ee48fef32b85ee7dc044c2c3c6bcad10e88973a2bf176589b84dcbe2b64ab08b2bf7580f81e11fe82c94e709c4d800",
    "000035c04fa162c55754758284b8c8c0e045f4b7e7d5c7762d8d6786eb8e7e58af2f6c61737a69702e6f726700000000",
    "0000000000000000000003000000020200000000000050c30000ffffffffffffffffffffffffffffffff02000a001e00",
    "03000b00060003005a040000000000000000000040420f00b8e8f0ff0000110000000000000000000000000000007374",
    "e0400004c03e25f300000b210b5d5f80001c96ed21480000617c07d8000000805130adc0000373bdd5a6c0000a110cd6",
    "b400001bf64afece0000d7c4e4e28000053634986d800019d95195720001c9cac8f580001d44d7f29500020737c17500",
    "0021101d777200023cc3aedb8000248775d04f00025de95348000028a8a1515d0002c970535c00002ff996114900035d",
    "daa087000039d419fa940003389339c600001bb0355be4000120b619a8000009b5c08671000053aa4c5ce800031a946e",
    "a700001b9720ea580001000000000000000100000051af340000",
);

/// The fuzzer's input, byte for byte (stop 33's CI run).
const LAZ_DEEPER_HEX: &str = concat!(
    "4c4153460000100000000000000000000000000000000000010400000000000000000000000000000000000000000000",
    "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000007701",
    "db01000001000000882600280000002800000000000000000000000000000000000000fca9f1d24d62503ffca9f1d24d",
    "62503ffca9f1d24d62503f0000000000408f400000000000408f400000000000408f40295c8fc2f5478f404260e5d022",
    "388f40f2d24d6290419f400000000000409f400000000000002640c02406819503224000000000000000000000000000",
    "000000000000002800000000000000280000000000000000000000000000000000000000000000000000000000000000",
    "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000",
    "00000000000000000000000000000000000000000000000000000000000000000000000000000000006c61737a697020",
    "656e636f6465640000bc562e0068747470733a2f2f6c61737a69702e6f72670000000000000000000000000000030000",
    "00020200000000000050c30000ffffffffffffffffffffffffffffffff02000a001e0003000c00080003006004000000",
    "0000000000000040420f00b8e8f0ff00001100000000000000000000000000000000000300ffff1100280000007f0000",
    "003f0000000000000000000000110000000000000000000000000000000b0100004d0000000000000020a4a9605d216a",
    "6a268fea6972ac65ab371994c7dc1cb626c36318ff6c1e38e85cfd280199c547c8249829f42c5e73e4aff0d28f54d2c7",
    "8198adf45eb6236284e16ea596f90c34fa6c29f2c26398ee48fef32b85ee7dc044c2c3c6bcad10e88973a2bf176589b8",
    "4dcbe2b64ab08b2bf7580f81e11fe82c94e709c4d800000030c04fa162c55754758284b8c8c0e045f4b7e7d5c7762d8d",
    "6786eb8e7e58af88f72e8901b0d7d83f05ffffffffffffffffffffffffffffffffffffffffffefffffffffffffffffff",
    "ffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffffff2aff",
    "ffffffff000001000000821a00280000002800000000000000000000000000000000000000fca9f1d24d62503ffca9f1",
    "d24d62503ffca9f1d24d62503f0000000000408f400000000000408f400000000000408f40295c8fc2f5478f404260e5",
    "d022368f40f2d24d6290419f400000000000409f400000000000002640c024068195032240000000000000000000006c",
    "61737a697020656e636f6465640000bc562e0068747470733a2f2f6c61737a69702e6f72670000000000000000000400",
    "000000020000b5c08671000053aa4c5ce800031a94a76e00001b9720ea5800010000008202c245068a0d141a28345068",
    "a0d141a28345068a0d141a28a250833441d1a06845068a0d141a28345068a0d141a28345068a0d141a28345068a0d141",
    "a28345068a0d141a283450686000000000000000010000005263870000",
);
