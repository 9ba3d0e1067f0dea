//! LAS 1.0–1.4 and LAZ (including COPC, read sequentially) through the `las` crate.
//!
//! Points are decoded in chunks with `Reader::fill_points` into one reused `PointData` byte
//! slab and swept column by column (the per-point iterator is ~3x slower). Coordinates are the
//! stored integers with scale and offset applied, in f64. Attributes kept, with their LAS
//! types: intensity, return_number, number_of_returns, classification, scan_angle (degrees,
//! f32), user_data, point_source_id, and when the point format has them gps_time, red, green,
//! blue (u16) and nir. Extra bytes and waveform packets are not carried as attributes.
//!
//! For a LAS/LAZ output ([`read_lidar`] with records kept) the reader keeps instead the raw
//! point records as the file stores them (decompressed), with the header and every EVLR: the
//! writer in `las_write.rs` copies them back, so every attribute, flag and extra byte survives
//! bit for bit. The attribute columns are then not built: one copy of the points, not two.

use std::io::BufReader;
use std::path::{Path, PathBuf};

use las::{PointData, PointDataBuilder, Reader};

use super::las_check::las_error;
use super::{Loaded, PropertyInfo, attribute, f32_step};
use crate::cloud::{Attribute, Cloud, Column, Source};
use crate::error::{Error, Result};
use crate::progress::Progress;

/// Points decoded per `fill_points` call: large enough for the parallel LAZ decoder to use
/// both cores on several LAZ chunks (50 000 points each by default), small enough to keep the
/// slab in the tens of megabytes.
const CHUNK: u64 = 1 << 18;

/// Runs a call into the las/laz crates, turning a panic into an error naming the file. laz
/// 0.13 indexes its decoding tables with symbols decoded from the file without checking
/// them: damaged LAZ data made it panic with an index out of bounds (`decoders.rs`, found
/// by fuzzing), and no check of the file short of decoding it tells such data from good
/// data. The panic message is still printed by the panic hook; the run then stops with
/// this error instead of a crash.
fn unpanicked<T>(path: &Path, place: impl Into<String>, f: impl FnOnce() -> T) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|_| {
        Error::malformed(
            path,
            place,
            "the LAZ decoder failed on this data (a panic in the laz crate): the compressed \
             points are damaged",
        )
    })
}

/// Column storage for one chunk sweep.
struct Columns {
    intensity: Vec<u16>,
    return_number: Vec<u8>,
    number_of_returns: Vec<u8>,
    classification: Vec<u8>,
    scan_angle: Vec<f32>,
    user_data: Vec<u8>,
    point_source_id: Vec<u16>,
    gps_time: Option<Vec<f64>>,
    rgb: Option<[Vec<u16>; 3]>,
    nir: Option<Vec<u16>>,
}

impl Columns {
    fn new(format: &las::point::Format, capacity: usize) -> Self {
        Columns {
            intensity: Vec::with_capacity(capacity),
            return_number: Vec::with_capacity(capacity),
            number_of_returns: Vec::with_capacity(capacity),
            classification: Vec::with_capacity(capacity),
            scan_angle: Vec::with_capacity(capacity),
            user_data: Vec::with_capacity(capacity),
            point_source_id: Vec::with_capacity(capacity),
            gps_time: format.has_gps_time.then(|| Vec::with_capacity(capacity)),
            rgb: format.has_color.then(|| {
                [
                    Vec::with_capacity(capacity),
                    Vec::with_capacity(capacity),
                    Vec::with_capacity(capacity),
                ]
            }),
            nir: format.has_nir.then(|| Vec::with_capacity(capacity)),
        }
    }

    fn append(&mut self, pd: &PointData) {
        self.intensity.extend(pd.intensity());
        self.return_number.extend(pd.return_number());
        self.number_of_returns.extend(pd.number_of_returns());
        self.classification.extend(pd.classification());
        self.scan_angle.extend(pd.scan_angle_degrees());
        self.user_data.extend(pd.user_data());
        self.point_source_id.extend(pd.point_source_id());
        if let (Some(col), Some(it)) = (self.gps_time.as_mut(), pd.gps_time()) {
            col.extend(it);
        }
        if let (Some([r, g, b]), Some(it)) = (self.rgb.as_mut(), pd.rgb()) {
            for (cr, cg, cb) in it {
                r.push(cr);
                g.push(cg);
                b.push(cb);
            }
        }
        if let (Some(col), Some(it)) = (self.nir.as_mut(), pd.nir()) {
            col.extend(it);
        }
    }

    fn into_attributes(self) -> Vec<Attribute> {
        let mut a = vec![
            attribute("intensity", Column::U16(self.intensity)),
            attribute("return_number", Column::U8(self.return_number)),
            attribute("number_of_returns", Column::U8(self.number_of_returns)),
            attribute("classification", Column::U8(self.classification)),
            attribute("scan_angle", Column::F32(self.scan_angle)),
            attribute("user_data", Column::U8(self.user_data)),
            attribute("point_source_id", Column::U16(self.point_source_id)),
        ];
        if let Some(g) = self.gps_time {
            a.push(attribute("gps_time", Column::F64(g)));
        }
        if let Some([r, g, b]) = self.rgb {
            a.push(attribute("red", Column::U16(r)));
            a.push(attribute("green", Column::U16(g)));
            a.push(attribute("blue", Column::U16(b)));
        }
        if let Some(n) = self.nir {
            a.push(attribute("nir", Column::U16(n)));
        }
        a
    }
}

/// A LAS/LAZ input as the writer of a LAS/LAZ output needs it: the header as read, every
/// EVLR of the file, and (when kept) the raw point records in file order.
#[derive(Debug, Clone)]
pub struct Lidar {
    pub(super) path: PathBuf,
    pub(super) header: las::Header,
    /// Every EVLR of the file when the records are kept (the las crate's header holds only
    /// the first, which is all this holds otherwise).
    pub(super) evlrs: Vec<las::Vlr>,
    /// The point records as stored (decompressed), `record_len` bytes each; empty when not
    /// kept.
    pub(super) records: Vec<u8>,
    pub(super) record_len: usize,
}

impl Lidar {
    /// True when the input was COPC (its octree VLRs are not written back).
    pub fn is_copc(&self) -> bool {
        self.header.copc_info_vlr().is_some()
    }

    /// The coordinate reference system of the file, from its WKT VLR or its GeoTIFF keys.
    pub fn crs(&self) -> Option<super::Crs> {
        super::crs::of_vlrs(self.header.vlrs().iter().chain(&self.evlrs))
    }

    /// The point format number (0–10) of the input.
    pub fn point_format(&self) -> u8 {
        self.header.point_format().to_u8().unwrap_or(0)
    }

    /// True when the raw point records were kept (needed to write LAS/LAZ).
    pub fn has_records(&self) -> bool {
        !self.records.is_empty() || self.header.number_of_points() == 0
    }

    /// Keeps the records whose `keep` flag is set (non-finite points dropped by the reader).
    pub(super) fn retain_mask(&mut self, keep: &[bool]) {
        if self.records.is_empty() || self.record_len == 0 {
            return;
        }
        let len = self.record_len;
        let mut w = 0;
        for (i, &k) in keep.iter().enumerate() {
            if k {
                self.records.copy_within(i * len..(i + 1) * len, w * len);
                w += 1;
            }
        }
        self.records.truncate(w * len);
    }
}

/// Every EVLR of a LAS 1.4 file, read with the las crate's raw reader (its `Header` keeps only
/// the first one).
fn read_evlrs(path: &Path) -> Result<Vec<las::Vlr>> {
    use std::io::{Seek, SeekFrom};
    let mut f = BufReader::new(super::open(path)?);
    let raw =
        las::raw::Header::read_from(&mut f).map_err(|e| las_error(path, "header", true, e))?;
    let Some(evlr) = raw.evlr else {
        return Ok(Vec::new());
    };
    if evlr.number_of_evlrs == 0 {
        return Ok(Vec::new());
    }
    f.seek(SeekFrom::Start(evlr.start_of_first_evlr))
        .map_err(|e| Error::io(path, "cannot read", e))?;
    let mut out = Vec::new();
    for k in 0..evlr.number_of_evlrs {
        let v = las::raw::Vlr::read_from(&mut f, true).map_err(|e| {
            las_error(
                path,
                format!(
                    "EVLR {k} of {} at byte {}",
                    evlr.number_of_evlrs, evlr.start_of_first_evlr
                ),
                true,
                e,
            )
        })?;
        out.push(las::Vlr::new(v));
    }
    Ok(out)
}

/// Streams the positions of a LAS/LAZ/COPC file in chunks of [`CHUNK`] points, in file
/// order, to `f`, without holding the cloud (the tiles of a cloud larger than memory are cut
/// from it this way: `tiles`). Returns the point count, the format's description and the
/// header's bounding box (min, max).
pub(crate) fn stream_positions(
    path: &Path,
    f: &mut (dyn FnMut(&[[f64; 3]]) -> Result<()> + Send),
) -> Result<(u64, String, [[f64; 3]; 2])> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .stack_size(DECODER_STACK)
        .build()
        .map_err(|e| {
            Error::io(
                path,
                "cannot start the threads that decode it",
                std::io::Error::other(e.to_string()),
            )
        })?;
    pool.install(|| {
        let file = super::open(path)?;
        let file_len = file.metadata().map(|m| m.len()).unwrap_or(0);
        super::las_check::check(path, &file, file_len)?;
        let mut reader = unpanicked(path, "header", || {
            Reader::new(BufReader::with_capacity(1 << 17, file))
        })?
        .map_err(|e| las_error(path, "header", true, e))?;
        let header = reader.header().clone();
        let n = header.number_of_points();
        let kind = if header.copc_info_vlr().is_some() {
            "COPC LAZ"
        } else if header.point_format().is_compressed {
            "LAZ"
        } else {
            "LAS"
        };
        let description = format!("{kind} {}", header.version());
        let b = header.bounds();
        let bounds = [[b.min.x, b.min.y, b.min.z], [b.max.x, b.max.y, b.max.z]];
        let mut pd = PointDataBuilder::new().for_header(&header).build();
        let progress = if n >= super::PROGRESS_MIN_POINTS {
            Progress::start("read", n, "points")
        } else {
            Progress::hidden()
        };
        let mut positions: Vec<[f64; 3]> = Vec::with_capacity(CHUNK as usize);
        let mut done = 0u64;
        while done < n {
            let want = CHUNK.min(n - done);
            let place = || format!("points {done}..{} of {n}", done + want);
            let got = unpanicked(path, place(), || reader.fill_points(want, &mut pd))?
                .map_err(|e| las_error(path, place(), false, e))?;
            if got == 0 {
                return Err(Error::malformed(
                    path,
                    format!("point {done} of {n}"),
                    "no more points can be decoded: the file is truncated or its header \
                     declares more points than it holds",
                ));
            }
            positions.clear();
            positions.extend(pd.x().zip(pd.y()).zip(pd.z()).map(|((x, y), z)| [x, y, z]));
            f(&positions)?;
            done += got;
            progress.inc(got);
        }
        Ok((n, description, bounds))
    })
}

pub(crate) fn read(path: &Path) -> Result<Loaded> {
    read_lidar(path, false).map(|(loaded, _)| loaded)
}

/// Reads a LAS/LAZ file. With `keep_records` the raw point records are kept in the returned
/// [`Lidar`] and the cloud carries no attribute columns (the records hold them); without,
/// the cloud carries the attribute columns and the `Lidar` only the header and EVLRs.
pub(crate) fn read_lidar(path: &Path, keep_records: bool) -> Result<(Loaded, Lidar)> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .stack_size(DECODER_STACK)
        .build()
        .map_err(|e| {
            Error::io(
                path,
                "cannot start the threads that decode it",
                std::io::Error::other(e.to_string()),
            )
        })?;
    pool.install(|| read_lidar_on(path, keep_records))
}

/// Stack of the threads that decode LAS/LAZ (virtual: only the pages used are committed).
/// laz 0.13 decoded the GPS times of point formats 6-10 recursively, as deep as the data
/// leads it: a damaged 1 KB LAZ file (found by fuzzing) overflowed the 2 MB stacks of
/// rayon's threads and aborted the process; it needed less than 8 MB, and a later one more
/// than 64 MB. The vendored laz (vendor/README.md) reads them in a loop; the decoding keeps
/// its own pool of as many threads as the caller's, with 64 MB each, as a margin for the
/// rest of the decoder.
const DECODER_STACK: usize = 64 << 20;

/// [`read_lidar`] on the decoding pool's threads.
fn read_lidar_on(path: &Path, keep_records: bool) -> Result<(Loaded, Lidar)> {
    let file = super::open(path)?;
    let file_len = file.metadata().map(|m| m.len()).unwrap_or(0);
    // Counts and offsets against the file's size first: the crates allocate from them.
    let most_points = super::las_check::check(path, &file, file_len)?;
    let mut reader = unpanicked(path, "header", || {
        Reader::new(BufReader::with_capacity(1 << 17, file))
    })?
    .map_err(|e| las_error(path, "header", true, e))?;
    let header = reader.header().clone();
    let format = *header.point_format();
    let n = header.number_of_points();
    let t = *header.transforms();

    let kind = if header.copc_info_vlr().is_some() {
        "COPC LAZ"
    } else if format.is_compressed {
        "LAZ"
    } else {
        "LAS"
    };
    let code = format
        .to_u8()
        .map(|c| c.to_string())
        .unwrap_or_else(|_| "?".into());
    let description = format!("{kind} {}, point format {code}", header.version());

    // Do not trust the header's count for allocation (a corrupt count could ask for
    // terabytes): it was checked against the file above (a LAS point takes its record length,
    // a LAZ chunk holds a bounded number of points), and the vectors grow as points are
    // decoded beyond a few bytes a point of the file.
    let min_bytes = if format.is_compressed {
        2
    } else {
        u64::from(format.len()).max(1)
    };
    let capacity = n.min(most_points).min(file_len / min_bytes) as usize;
    let mut positions: Vec<[f64; 3]> = Vec::with_capacity(capacity);
    let mut columns = Columns::new(&format, if keep_records { 0 } else { capacity });
    let record_len = usize::from(format.len());
    let mut records: Vec<u8> = Vec::new();
    if keep_records {
        records.reserve(capacity.saturating_mul(record_len));
    }
    let mut pd = PointDataBuilder::new().for_header(&header).build();
    let progress = if n >= super::PROGRESS_MIN_POINTS {
        Progress::start("read", n, "points")
    } else {
        Progress::hidden()
    };
    let mut done = 0u64;
    while done < n {
        let want = CHUNK.min(n - done);
        let place = || format!("points {done}..{} of {n}", done + want);
        let got = unpanicked(path, place(), || reader.fill_points(want, &mut pd))?
            .map_err(|e| las_error(path, place(), false, e))?;
        if got == 0 {
            return Err(Error::malformed(
                path,
                format!("point {done} of {n}"),
                "no more points can be decoded: the file is truncated or its header \
                 declares more points than it holds",
            ));
        }
        positions.extend(pd.x().zip(pd.y()).zip(pd.z()).map(|((x, y), z)| [x, y, z]));
        if keep_records {
            records.extend_from_slice(pd.raw_bytes());
        } else {
            columns.append(&pd);
        }
        done += got;
        progress.inc(got);
    }

    // Double precision is needed on an axis when the file's grid (its scale) is finer than
    // the f32 step at the largest magnitude the axis reaches.
    let scales = [t.x.scale, t.y.scale, t.z.scale];
    let mut max_abs = [0.0f64; 3];
    for p in &positions {
        for k in 0..3 {
            max_abs[k] = max_abs[k].max(p[k].abs());
        }
    }
    let double_precision = (0..3).any(|k| scales[k].abs() < f32_step(max_abs[k]));

    let mut properties: Vec<PropertyInfo> = ["x", "y", "z"]
        .iter()
        .zip([t.x, t.y, t.z])
        .map(|(name, tr)| PropertyInfo {
            name: name.to_string(),
            ty: format!("int32 * {} + {}", tr.scale, tr.offset),
        })
        .collect();
    let attributes = if keep_records {
        Vec::new()
    } else {
        columns.into_attributes()
    };
    properties.extend(attributes.iter().map(|a| PropertyInfo {
        name: a.name.clone(),
        ty: a.values.ply_type().to_string(),
    }));
    // Every EVLR only for writing them back; otherwise the crate's first one (a WKT CRS in
    // an EVLR is the first) is enough, and a damaged later one does not stop a PLY run.
    let evlrs = if keep_records {
        read_evlrs(path)?
    } else {
        header.evlrs().clone()
    };
    let lidar = Lidar {
        path: path.to_path_buf(),
        header,
        evlrs,
        records,
        record_len,
    };
    let loaded = Loaded {
        cloud: Cloud {
            positions,
            attributes,
            source: Source {
                path: path.to_path_buf(),
                format: description,
                double_precision,
            },
            structure: None,
        },
        properties,
        other_elements: Vec::new(),
        details: Vec::new(),
    };
    Ok((loaded, lidar))
}
