//! The reading-speed check of issue 16 for PCD, one measurement per process so that each
//! reports its own peak memory: run by scripts/bench_read_pcd.sh.
//!
//! `pcd_read gen DIR N`: writes the same N points (a jittered 3D grid with random colours,
//! as benches/read.rs makes them) as DIR/cloud.ply (binary little endian, float x y z, uchar
//! red green blue), DIR/binary.pcd and DIR/compressed.pcd (float x y z, packed float rgb, as
//! PCL writes `PointXYZRGB`).
//! `pcd_read read FILE`: reads FILE with `sharpedge::io::read` and prints
//! `seconds points peak_rss_mb`.
//! `pcd_read lzf FILE`: decompresses the LZF body of the binary_compressed FILE with the
//! `lzf` crate and with sharpedge's decoder, alternating, 5 times each, and prints each one's
//! median and best seconds (both into a new buffer of the whole body, as a whole-file read
//! does).

use std::path::Path;
use std::time::Instant;

use sharpedge::io::{self, PlyWriteOptions, ReadOptions};
use sharpedge::{Attribute, Column};

fn make_cloud(n: usize) -> (Vec<[f64; 3]>, Vec<[u8; 3]>) {
    let mut positions = Vec::with_capacity(n);
    let mut rgb = Vec::with_capacity(n);
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    for i in 0..n {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        // Jitter in steps of 1/1024, as a sensor's quantised depth: LZF then finds repeats,
        // as it does in real frames (the three in ../shared/data/pcd compress 2-3x).
        let j = ((s >> 40) & 1023) as f64 / 1024.0;
        // Float coordinates, so that PLY and PCD hold the very same points.
        positions.push(
            [
                (i % 200) as f64 + j,
                ((i / 200) % 200) as f64 - j,
                (i / 40_000) as f64 * 0.5 + j,
            ]
            .map(|c| f64::from(c as f32)),
        );
        // A colour per grid cell of 4 x 4 points, a little noise in blue.
        let cell = (i / 4) as u64;
        rgb.push([(cell * 37) as u8, (cell * 11) as u8, (s as u8) & 7]);
    }
    (positions, rgb)
}

fn pcd_header(n: usize, data: &str) -> String {
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\n\
         TYPE F F F F\nCOUNT 1 1 1 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\n\
         DATA {data}\n"
    )
}

fn generate(dir: &Path, n: usize) -> Result<(), Box<dyn std::error::Error>> {
    let (positions, rgb) = make_cloud(n);
    let channel = |k: usize| Column::U8(rgb.iter().map(|c| c[k]).collect());
    let attrs = [
        Attribute {
            name: "red".into(),
            values: channel(0),
        },
        Attribute {
            name: "green".into(),
            values: channel(1),
        },
        Attribute {
            name: "blue".into(),
            values: channel(2),
        },
    ];
    let refs: Vec<&Attribute> = attrs.iter().collect();
    io::write_ply(
        &dir.join("cloud.ply"),
        &positions,
        &refs,
        &[],
        &PlyWriteOptions::default(),
    )?;
    let packed = |c: &[u8; 3]| u32::from(c[0]) << 16 | u32::from(c[1]) << 8 | u32::from(c[2]);
    let mut records = Vec::with_capacity(16 * n);
    for (p, c) in positions.iter().zip(&rgb) {
        for v in p {
            records.extend_from_slice(&(*v as f32).to_le_bytes());
        }
        records.extend_from_slice(&packed(c).to_le_bytes());
    }
    let mut file = pcd_header(n, "binary").into_bytes();
    file.extend_from_slice(&records);
    std::fs::write(dir.join("binary.pcd"), &file)?;
    let mut blocks = Vec::with_capacity(16 * n);
    for k in 0..4 {
        for i in 0..n {
            blocks.extend_from_slice(&records[16 * i + 4 * k..16 * i + 4 * k + 4]);
        }
    }
    let packed = lzf::compress(&blocks).map_err(|e| format!("lzf: {e}"))?;
    let mut file = pcd_header(n, "binary_compressed").into_bytes();
    file.extend_from_slice(&(packed.len() as u32).to_le_bytes());
    file.extend_from_slice(&(blocks.len() as u32).to_le_bytes());
    file.extend_from_slice(&packed);
    std::fs::write(dir.join("compressed.pcd"), &file)?;
    Ok(())
}

/// The `lzf` crate against sharpedge's LZF decoder on the body of a binary_compressed file.
fn lzf_race(path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let bytes = std::fs::read(path)?;
    let mark = b"DATA binary_compressed\n";
    let at = bytes
        .windows(mark.len())
        .position(|w| w == mark)
        .ok_or("not a binary_compressed PCD file")?
        + mark.len();
    let size = |o: usize| -> Result<usize, Box<dyn std::error::Error>> {
        Ok(u32::from_le_bytes(bytes[o..o + 4].try_into()?) as usize)
    };
    let (c, u) = (size(at)?, size(at + 4)?);
    let data = &bytes[at + 8..at + 8 + c];
    let (mut krate, mut ours) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        let t = Instant::now();
        let a = lzf::decompress(data, u).map_err(|e| format!("lzf: {e}"))?;
        krate.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let b = io::lzf_decompress(data, u)?;
        ours.push(t.elapsed().as_secs_f64());
        assert!(a == b, "the decoders disagree");
    }
    for (name, mut t) in [("lzf crate", krate), ("sharpedge", ours)] {
        t.sort_by(f64::total_cmp);
        println!("{name:10} median {:.3} s, best {:.3} s", t[2], t[0]);
    }
    Ok(())
}

/// Peak resident memory of this process in MB (Linux: VmHWM).
fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    match args.get(1).map(String::as_str) {
        Some("gen") if args.len() == 4 => generate(Path::new(&args[2]), args[3].parse()?),
        Some("read") if args.len() == 3 => {
            let t = Instant::now();
            let cloud = io::read(Path::new(&args[2]), &ReadOptions::default())?;
            let s = t.elapsed().as_secs_f64();
            println!("{s:.3} {} {:.0}", cloud.len(), peak_rss_mb());
            Ok(())
        }
        Some("lzf") if args.len() == 3 => lzf_race(Path::new(&args[2])),
        _ => Err("usage: pcd_read gen DIR N | pcd_read read FILE | pcd_read lzf FILE".into()),
    }
}
