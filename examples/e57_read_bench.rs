//! The E57 reading benchmark's two halves (driven by `scripts/bench_read_e57.sh`):
//!
//! - `e57_read_bench gen DIR N`: writes the same N points twice, as `DIR/points.e57` (one scan,
//!   double cartesian, 16-bit intensity, 8-bit colour: what a terrestrial scanner's export
//!   holds) with the e57 crate, and as `DIR/points.ply` (binary little endian, double x y z,
//!   ushort intensity, uchar red green blue) with sharpedge's writer.
//! - `e57_read_bench read FILE`: reads FILE with `sharpedge::io::read` and prints one line:
//!   `seconds points peak_rss_kb decoded_bytes file_bytes`, the peak RSS being the process's
//!   high-water mark (VmHWM) after the read, and `decoded_bytes` the size of the cloud's
//!   positions, attributes and scan structure.

use std::path::Path;
use std::time::Instant;

use e57::{E57Writer, Record, RecordValue};
use sharpedge::io::{PlyEncoding, PlyWriteOptions, Precision, ReadOptions};
use sharpedge::{Attribute, Column};

/// The points: a jittered grid (not trivially compressible) with varied attribute values.
fn point(i: usize) -> ([f64; 3], u16, [u8; 3]) {
    let h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    let jitter = |k: u32| ((h >> (k * 16)) & 0xFFFF) as f64 / 65_536.0 * 1e-3;
    let p = [
        (i % 1000) as f64 * 0.01 + jitter(0),
        ((i / 1000) % 1000) as f64 * 0.01 + jitter(1),
        (i / 1_000_000) as f64 * 0.01 + jitter(2),
    ];
    let b = h.to_le_bytes();
    (p, (h >> 48) as u16, [b[0], b[1], b[2]])
}

fn gen_files(dir: &Path, n: usize) -> Result<(), Box<dyn std::error::Error>> {
    let mut w = E57Writer::from_file(dir.join("points.e57"), "bench")?;
    let mut pc = w.add_pointcloud(
        "bench-scan",
        vec![
            Record::CARTESIAN_X_F64,
            Record::CARTESIAN_Y_F64,
            Record::CARTESIAN_Z_F64,
            Record::INTENSITY_U16,
            Record::COLOR_RED_U8,
            Record::COLOR_GREEN_U8,
            Record::COLOR_BLUE_U8,
        ],
    )?;
    let mut positions = Vec::with_capacity(n);
    let mut intensity = Vec::with_capacity(n);
    let mut rgb = [
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    ];
    for i in 0..n {
        let (p, v, c) = point(i);
        pc.add_point(vec![
            RecordValue::Double(p[0]),
            RecordValue::Double(p[1]),
            RecordValue::Double(p[2]),
            RecordValue::Integer(i64::from(v)),
            RecordValue::Integer(i64::from(c[0])),
            RecordValue::Integer(i64::from(c[1])),
            RecordValue::Integer(i64::from(c[2])),
        ])?;
        positions.push(p);
        intensity.push(v);
        for k in 0..3 {
            rgb[k].push(c[k]);
        }
    }
    pc.finalize()?;
    w.finalize()?;
    let [r, g, b] = rgb;
    let attrs = [
        Attribute {
            name: "intensity".into(),
            values: Column::U16(intensity),
        },
        Attribute {
            name: "red".into(),
            values: Column::U8(r),
        },
        Attribute {
            name: "green".into(),
            values: Column::U8(g),
        },
        Attribute {
            name: "blue".into(),
            values: Column::U8(b),
        },
    ];
    let refs: Vec<&Attribute> = attrs.iter().collect();
    sharpedge::io::write_ply(
        &dir.join("points.ply"),
        &positions,
        &refs,
        &[],
        &PlyWriteOptions {
            encoding: PlyEncoding::BinaryLittleEndian,
            precision: Precision::F64,
        },
    )?;
    Ok(())
}

/// Bytes of a PLY scalar type.
fn type_size(ty: &str) -> usize {
    match ty {
        "char" | "uchar" => 1,
        "short" | "ushort" => 2,
        "double" => 8,
        _ => 4,
    }
}

/// The process's peak resident set (VmHWM) in KB.
fn peak_rss_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
        .unwrap_or(0)
}

fn read_file(path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let bytes = std::fs::metadata(path)?.len();
    let t = Instant::now();
    let cloud = sharpedge::io::read(path, &ReadOptions::default())?;
    let secs = t.elapsed().as_secs_f64();
    let attr_bytes: usize = cloud
        .attributes
        .iter()
        .map(|a| a.values.len() * type_size(a.values.ply_type()))
        .sum();
    let structure_bytes = cloud
        .structure
        .as_ref()
        .map_or(0, |s| s.scan.len() * 4 + s.grid.len() * 8);
    let decoded = cloud.len() * 24 + attr_bytes + structure_bytes;
    println!(
        "{secs:.4} {} {} {decoded} {bytes}",
        cloud.len(),
        peak_rss_kb()
    );
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    match args.as_slice() {
        [_, m, dir, n] if m == "gen" => gen_files(Path::new(dir), n.parse()?),
        [_, m, file] if m == "read" => read_file(Path::new(file)),
        _ => Err("usage: e57_read_bench gen DIR N | read FILE".into()),
    }
}
