//! A small PCD codec of the tests' own, written from the format's description and independent
//! of sharpedge's reader and writer: it makes the test inputs (the real frame in every
//! encoding, organised or not, hand-made fields) and reads the outputs back record by record.
#![allow(dead_code)] // each test file uses a different part of this module

use std::path::Path;

/// One field: name, SIZE, TYPE, COUNT.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    pub name: String,
    pub size: usize,
    pub ty: char,
    pub count: usize,
}

pub fn field(name: &str, ty: char, size: usize, count: usize) -> Field {
    Field {
        name: name.into(),
        size,
        ty,
        count,
    }
}

/// A PCD file: header values and every slot's record (fields in order, padding included).
#[derive(Debug, Clone, PartialEq)]
pub struct Pcd {
    pub fields: Vec<Field>,
    pub width: usize,
    pub height: usize,
    pub viewpoint: [f64; 7],
    pub data: String,
    pub records: Vec<u8>,
}

impl Pcd {
    pub fn point_size(&self) -> usize {
        self.fields.iter().map(|f| f.size * f.count).sum()
    }

    pub fn points(&self) -> usize {
        self.width * self.height
    }

    pub fn record(&self, i: usize) -> &[u8] {
        let ps = self.point_size();
        &self.records[i * ps..(i + 1) * ps]
    }

    /// Byte offset of a field in a record.
    pub fn offset(&self, name: &str) -> usize {
        let mut off = 0;
        for f in &self.fields {
            if f.name == name {
                return off;
            }
            off += f.size * f.count;
        }
        panic!("no field {name}")
    }

    /// x, y, z of slot `i` as f32 (the tests' files store float coordinates).
    pub fn xyz(&self, i: usize) -> [f32; 3] {
        ["x", "y", "z"].map(|a| {
            let o = i * self.point_size() + self.offset(a);
            f32::from_le_bytes(self.records[o..o + 4].try_into().unwrap())
        })
    }

    /// The same points, unorganised (HEIGHT 1), keeping only the slots `keep` says.
    pub fn unorganised(&self, keep: impl Fn(usize) -> bool) -> Pcd {
        let mut records = Vec::new();
        let mut n = 0;
        for i in 0..self.points() {
            if keep(i) {
                records.extend_from_slice(self.record(i));
                n += 1;
            }
        }
        Pcd {
            width: n,
            height: 1,
            records,
            ..self.clone()
        }
    }

    pub fn with_data(&self, data: &str) -> Pcd {
        Pcd {
            data: data.into(),
            ..self.clone()
        }
    }
}

fn words<'a>(header: &'a [(String, Vec<String>)], key: &str) -> Option<&'a [String]> {
    header
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_slice())
}

/// Parses a PCD file (any encoding).
pub fn parse(bytes: &[u8]) -> Pcd {
    let mut header: Vec<(String, Vec<String>)> = Vec::new();
    let mut pos = 0;
    loop {
        let end = pos + bytes[pos..].iter().position(|&b| b == b'\n').unwrap();
        let line = std::str::from_utf8(&bytes[pos..end])
            .unwrap()
            .trim()
            .to_string();
        pos = end + 1;
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut w = line.split_whitespace().map(str::to_string);
        let key = w.next().unwrap();
        let done = key == "DATA";
        header.push((key, w.collect()));
        if done {
            break;
        }
    }
    let names = words(&header, "FIELDS").unwrap();
    let sizes = words(&header, "SIZE").unwrap();
    let types = words(&header, "TYPE").unwrap();
    let counts = words(&header, "COUNT").unwrap();
    let fields: Vec<Field> = (0..names.len())
        .map(|i| Field {
            name: names[i].clone(),
            size: sizes[i].parse().unwrap(),
            ty: types[i].chars().next().unwrap(),
            count: counts[i].parse().unwrap(),
        })
        .collect();
    let num = |k: &str| -> usize { words(&header, k).unwrap()[0].parse().unwrap() };
    let vp: Vec<f64> = words(&header, "VIEWPOINT")
        .unwrap()
        .iter()
        .map(|v| v.parse().unwrap())
        .collect();
    let mut pcd = Pcd {
        fields,
        width: num("WIDTH"),
        height: num("HEIGHT"),
        viewpoint: vp.try_into().unwrap(),
        data: words(&header, "DATA").unwrap()[0].clone(),
        records: Vec::new(),
    };
    assert_eq!(num("POINTS"), pcd.points());
    let n = pcd.points();
    let ps = pcd.point_size();
    let body = &bytes[pos..];
    pcd.records = match pcd.data.as_str() {
        "binary" => body[..n * ps].to_vec(),
        "binary_compressed" => {
            let c = u32::from_le_bytes(body[0..4].try_into().unwrap()) as usize;
            let u = u32::from_le_bytes(body[4..8].try_into().unwrap()) as usize;
            let soa = if u == 0 {
                Vec::new()
            } else {
                lzf::decompress(&body[8..8 + c], u).unwrap()
            };
            assert_eq!(soa.len(), u);
            let mut rec = vec![0u8; n * ps];
            let (mut off, mut block) = (0, 0);
            for f in &pcd.fields {
                let w = f.size * f.count;
                if f.name != "_" {
                    for i in 0..n {
                        let src = block + i * w;
                        rec[i * ps + off..i * ps + off + w].copy_from_slice(&soa[src..src + w]);
                    }
                    block += n * w;
                }
                off += w;
            }
            rec
        }
        "ascii" => {
            let text = std::str::from_utf8(body).unwrap();
            let mut rec = Vec::with_capacity(n * ps);
            for line in text.lines().filter(|l| !l.trim().is_empty()) {
                let mut tok = line.split_whitespace();
                for f in &pcd.fields {
                    for _ in 0..f.count {
                        let t = tok.next().unwrap();
                        let colour = f.ty == 'F' && (f.name == "rgb" || f.name == "rgba");
                        let b: Vec<u8> = match (f.ty, f.size) {
                            _ if f.name == "_" => vec![0; f.size],
                            ('F', 4) if colour && !t.contains(['.', 'e', 'n']) => {
                                t.parse::<u32>().unwrap().to_le_bytes().to_vec()
                            }
                            ('F', 4) => t.parse::<f32>().unwrap().to_le_bytes().to_vec(),
                            ('F', 8) => t.parse::<f64>().unwrap().to_le_bytes().to_vec(),
                            ('I', 1) => t.parse::<i8>().unwrap().to_le_bytes().to_vec(),
                            ('I', 2) => t.parse::<i16>().unwrap().to_le_bytes().to_vec(),
                            ('I', 4) => t.parse::<i32>().unwrap().to_le_bytes().to_vec(),
                            ('U', 1) => t.parse::<u8>().unwrap().to_le_bytes().to_vec(),
                            ('U', 2) => t.parse::<u16>().unwrap().to_le_bytes().to_vec(),
                            ('U', 4) => t.parse::<u32>().unwrap().to_le_bytes().to_vec(),
                            ('I', 8) => t.parse::<i64>().unwrap().to_le_bytes().to_vec(),
                            ('U', 8) => t.parse::<u64>().unwrap().to_le_bytes().to_vec(),
                            other => panic!("type {other:?}"),
                        };
                        rec.extend_from_slice(&b);
                    }
                }
            }
            rec
        }
        other => panic!("DATA {other}"),
    };
    assert_eq!(pcd.records.len(), n * ps);
    pcd
}

pub fn read(path: &Path) -> Pcd {
    parse(&std::fs::read(path).unwrap())
}

/// The header text of `pcd`, with `points` as POINTS (a lying header when it differs).
pub fn header_text(pcd: &Pcd, points: usize) -> String {
    let list = |f: &dyn Fn(&Field) -> String| -> String {
        pcd.fields.iter().map(f).collect::<Vec<_>>().join(" ")
    };
    let viewpoint: Vec<String> = pcd.viewpoint.iter().map(|v| v.to_string()).collect();
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {}\nSIZE {}\nTYPE {}\nCOUNT {}\nWIDTH {}\nHEIGHT {}\nVIEWPOINT {}\nPOINTS {}\nDATA {}\n",
        list(&|f| f.name.clone()),
        list(&|f| f.size.to_string()),
        list(&|f| f.ty.to_string()),
        list(&|f| f.count.to_string()),
        pcd.width,
        pcd.height,
        viewpoint.join(" "),
        points,
        pcd.data
    )
}

/// The body alone (after DATA).
pub fn body(pcd: &Pcd) -> Vec<u8> {
    let n = pcd.points();
    let ps = pcd.point_size();
    match pcd.data.as_str() {
        "binary" => pcd.records.clone(),
        "binary_compressed" => {
            let mut soa = Vec::new();
            let mut off = 0;
            for f in &pcd.fields {
                let w = f.size * f.count;
                if f.name != "_" {
                    for i in 0..n {
                        soa.extend_from_slice(&pcd.records[i * ps + off..i * ps + off + w]);
                    }
                }
                off += w;
            }
            let c = lzf::compress(&soa).unwrap();
            let mut out = (c.len() as u32).to_le_bytes().to_vec();
            out.extend_from_slice(&(soa.len() as u32).to_le_bytes());
            out.extend_from_slice(&c);
            out
        }
        "ascii" => {
            let mut s = String::new();
            for i in 0..n {
                let r = pcd.record(i);
                let mut off = 0;
                let mut vals = Vec::new();
                for f in &pcd.fields {
                    for _ in 0..f.count {
                        let b = &r[off..off + f.size];
                        off += f.size;
                        let colour = f.ty == 'F' && (f.name == "rgb" || f.name == "rgba");
                        vals.push(match (f.ty, f.size) {
                            ('F', 4) if colour => {
                                u32::from_le_bytes(b.try_into().unwrap()).to_string()
                            }
                            ('F', 4) => {
                                let v = f32::from_le_bytes(b.try_into().unwrap());
                                float_text(v.is_nan(), format!("{v:e}"))
                            }
                            ('F', 8) => {
                                let v = f64::from_le_bytes(b.try_into().unwrap());
                                float_text(v.is_nan(), format!("{v:e}"))
                            }
                            ('I', 1) => (b[0] as i8).to_string(),
                            ('U', 1) => b[0].to_string(),
                            ('I', 2) => i16::from_le_bytes(b.try_into().unwrap()).to_string(),
                            ('U', 2) => u16::from_le_bytes(b.try_into().unwrap()).to_string(),
                            ('I', 4) => i32::from_le_bytes(b.try_into().unwrap()).to_string(),
                            ('U', 4) => u32::from_le_bytes(b.try_into().unwrap()).to_string(),
                            ('I', 8) => i64::from_le_bytes(b.try_into().unwrap()).to_string(),
                            ('U', 8) => u64::from_le_bytes(b.try_into().unwrap()).to_string(),
                            other => panic!("type {other:?}"),
                        });
                    }
                }
                s.push_str(&vals.join(" "));
                s.push('\n');
            }
            s.into_bytes()
        }
        other => panic!("DATA {other}"),
    }
}

/// A float as PCL writes it: `nan`, else the given text.
fn float_text(nan: bool, text: String) -> String {
    if nan { "nan".into() } else { text }
}

/// The whole file.
pub fn bytes(pcd: &Pcd) -> Vec<u8> {
    let mut b = header_text(pcd, pcd.points()).into_bytes();
    b.extend_from_slice(&body(pcd));
    b
}

pub fn write(path: &Path, pcd: &Pcd) {
    std::fs::write(path, bytes(pcd)).unwrap();
}

/// The real organised frame `../shared/data/pcd/NAME`, or `None` (with a note) when the
/// shared data is absent.
pub fn real_frame(name: &str) -> Option<Pcd> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/pcd")
        .join(name);
    if !p.is_file() {
        eprintln!("skipped: ../shared/data absent");
        return None;
    }
    Some(read(&p))
}

/// A small hand-made organised frame (4 x 3) with every kind of field: normals, intensity,
/// label, packed float rgb, a COUNT 3 field, padding, a double; two NaN slots.
pub fn every_field_frame() -> Pcd {
    let fields = vec![
        field("x", 'F', 4, 1),
        field("y", 'F', 4, 1),
        field("z", 'F', 4, 1),
        field("_", 'U', 1, 4),
        field("normal_x", 'F', 4, 1),
        field("normal_y", 'F', 4, 1),
        field("normal_z", 'F', 4, 1),
        field("intensity", 'U', 2, 1),
        field("label", 'I', 4, 1),
        field("rgb", 'F', 4, 1),
        field("hist", 'I', 1, 3),
        field("time", 'F', 8, 1),
    ];
    let (width, height) = (4, 3);
    let mut records = Vec::new();
    for i in 0..width * height {
        let nan = i == 5 || i == 10;
        let c = |v: f32| if nan { f32::NAN } else { v };
        for v in [
            c(i as f32 * 0.25),
            c(1.0 - i as f32 * 0.125),
            c(2.0 + (i % 4) as f32),
        ] {
            records.extend_from_slice(&v.to_le_bytes());
        }
        records.extend_from_slice(&[0; 4]);
        for v in [0.0f32, 0.6, 0.8] {
            records.extend_from_slice(&v.to_le_bytes());
        }
        records.extend_from_slice(&(1000 + i as u16).to_le_bytes());
        records.extend_from_slice(&(-(i as i32)).to_le_bytes());
        // 0x00RRGGBB with r = 10 i, g = 20, b = 255 - i.
        let rgb = (10 * i as u32) << 16 | 20 << 8 | (255 - i as u32);
        records.extend_from_slice(&rgb.to_le_bytes());
        records.extend_from_slice(&[i as u8, (i as i8 - 6) as u8, 7]);
        records.extend_from_slice(&(1e9 + i as f64 * 0.001).to_le_bytes());
    }
    Pcd {
        fields,
        width,
        height,
        viewpoint: [0.5, -1.0, 2.0, 0.6, 0.0, 0.8, 0.0],
        data: "binary".into(),
        records,
    }
}

/// A bigger unorganised cloud (`n` points) whose binary_compressed body spans many of the
/// reader's decoding chunks, values split between them: x y z, packed `rgb` (U 4), a
/// 64-bit signed and unsigned integer, a double normal of COUNT 3, a byte, padding. Values
/// repeat in runs, as a sensor's do, so LZF finds back references of every length.
pub fn big_cloud(n: usize) -> Pcd {
    let fields = vec![
        field("x", 'F', 4, 1),
        field("y", 'F', 4, 1),
        field("z", 'F', 4, 1),
        field("rgb", 'U', 4, 1),
        field("stamp", 'I', 8, 1),
        field("id", 'U', 8, 1),
        field("normal", 'F', 8, 3),
        field("_", 'U', 1, 3),
        field("ring", 'U', 1, 1),
    ];
    let mut records = Vec::new();
    let mut s: u64 = 0x2545_F491_4F6C_DD1D;
    for i in 0..n {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let j = (s >> 54) as f32 / 1024.0;
        for v in [(i % 300) as f32 + j, (i / 300) as f32 * 0.5, j * j] {
            records.extend_from_slice(&v.to_le_bytes());
        }
        records.extend_from_slice(&((i / 7) as u32 * 0x0001_0203).to_le_bytes());
        records.extend_from_slice(&(-(i as i64) * 1_000_000_007).to_le_bytes());
        records.extend_from_slice(&((1u64 << 52) + (i / 3) as u64).to_le_bytes());
        for k in 0..3 {
            records.extend_from_slice(&(((i / 5) % 17) as f64 * 0.125 - k as f64).to_le_bytes());
        }
        records.extend_from_slice(&[0, 0, 0, (i % 32) as u8]);
    }
    Pcd {
        fields,
        width: n,
        height: 1,
        viewpoint: [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        data: "binary".into(),
        records,
    }
}
