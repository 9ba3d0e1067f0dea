//! Checks a LAS/LAZ file's counts and offsets against its size before the `las` and `laz`
//! crates see it, so that no count in a file makes them allocate more than the file could
//! hold.
//!
//! Input: the path and length of a file whose header the las crate is about to read.
//! Output: `Ok(bound)`, the most points the file can hold (for sizing the point vectors), or
//! an [`Error::Malformed`] naming the field, its value and the bytes that are there.
//!
//! We validate here rather than patching the dependencies: las 0.11 and laz 0.13 allocate from
//! header fields before checking them against the data (laz's `ChunkTable::read` reserves
//! 16 bytes a chunk for a chunk count read from the file, and 47-62 GB were asked for by
//! 1 KB files; the parallel decompressor sizes its buffers from the table's byte counts and
//! the chunk size; las reserves an EVLR's declared length). A patched dependency would have
//! to be carried as a fork until upstream takes it; these checks cost a few small reads and
//! keep the crates as released. What is checked:
//! * LAS: points x record length fit between the point data offset and the end of the file.
//! * every EVLR's data fits in the file;
//! * LAZ: the laszip VLR's items add up to the record length; the chunk table offset (at the
//!   start of the point data, or in the last 8 bytes when the writer could not go back) lies
//!   in the file; every chunk starts with one raw point, so the chunk count is at most the
//!   compressed bytes / record length; the chunks' byte counts add up to at most the
//!   compressed bytes; a chunk's points are at most [`MAX_POINTS_PER_BYTE`] a compressed byte
//!   (or a small buffer's worth); in layered chunks (formats 6-10) the layer sizes add up to
//!   at most the chunk's bytes; and the header's point count is at most what the chunks hold.

use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use crate::error::{Error, Result};

/// The most points one compressed byte of a LAZ chunk may stand for. LASzip's arithmetic
/// coder spends a little on every point even when nothing changes: 2,000,000 identical
/// points compressed to 141 points a byte (format 0), 98 (format 6), 83 (format 3) with the
/// laz crate's writer. 1024 leaves a wide margin for other writers while bounding what a
/// small file can decode to.
const MAX_POINTS_PER_BYTE: u64 = 1024;

/// Decoding buffers of a chunk up to this size are allowed whatever its compressed size:
/// a one-point LAZ file still declares the default 50,000-point chunks.
const SMALL_CHUNK_BYTES: u64 = 64 << 20;

/// The LAS point count as the las crate reads it: LAS 1.4's 64-bit count when the legacy
/// 32-bit field is zero.
fn point_count(raw: &las::raw::Header) -> u64 {
    let legacy = u64::from(raw.number_of_point_records);
    match raw.large_file {
        Some(lf) if legacy == 0 => lf.number_of_point_records,
        _ => legacy,
    }
}

fn malformed(path: &Path, place: impl Into<String>, what: impl Into<String>) -> Error {
    Error::malformed(path, place, what)
}

fn read_u64_at<R: Read + Seek>(f: &mut R, pos: u64) -> std::io::Result<u64> {
    let mut b = [0u8; 8];
    f.seek(SeekFrom::Start(pos))?;
    f.read_exact(&mut b)?;
    Ok(u64::from_le_bytes(b))
}

/// Checks the file (see the module comment); returns the most points it can hold.
/// Reads through `file`, the handle the crates will read next (not the path again: a file
/// replaced between the check and the read would be read unchecked), and leaves it at its
/// start.
pub(super) fn check(path: &Path, file: &std::fs::File, file_len: u64) -> Result<u64> {
    let checked = check_from(path, file, file_len);
    let mut file = file;
    file.seek(SeekFrom::Start(0))
        .map_err(|e| Error::io(path, "cannot read", e))?;
    checked
}

fn check_from(path: &Path, file: &std::fs::File, file_len: u64) -> Result<u64> {
    let mut f = BufReader::new(file);
    f.seek(SeekFrom::Start(0))
        .map_err(|e| Error::io(path, "cannot read", e))?;
    let raw =
        las::raw::Header::read_from(&mut f).map_err(|e| las_error(path, "header", true, e))?;
    // The VLRs follow what was read as the header, whatever its size field says.
    let vlrs_at = f
        .stream_position()
        .map_err(|e| Error::io(path, "cannot read", e))?;
    if las::point::Format::new(raw.point_data_record_format).is_err() {
        // The las crate names the bad point format itself.
        return Ok(point_count(&raw));
    }
    let n = point_count(&raw);
    let record_len = u64::from(raw.point_data_record_length);
    let data_start = u64::from(raw.offset_to_point_data);
    let compressed = raw.point_data_record_format & 0x80 != 0;
    let short = |e: std::io::Error| {
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            None
        } else {
            Some(Error::io(path, "cannot read", e))
        }
    };

    // The las crate computes the end of the points as offset + count x length in u64.
    let Some(points_bytes) = n
        .checked_mul(record_len)
        .filter(|b| b.checked_add(data_start).is_some())
    else {
        return Err(malformed(
            path,
            "header",
            format!(
                "the header declares {n} points of {record_len} bytes: more than any file can \
                 hold (a damaged header)"
            ),
        ));
    };
    let after_data = file_len.saturating_sub(data_start);
    let mut bound = n;
    if !compressed && points_bytes > after_data {
        let whole = after_data / record_len.max(1);
        return Err(malformed(
            path,
            format!("point {whole} of {n}"),
            format!(
                "the point data ends early: the header declares {n} points of {record_len} \
                 bytes from byte {data_start} ({points_bytes} bytes), but the file has \
                 {after_data} bytes there: the file is truncated or damaged, or its header \
                 declares more points than it holds"
            ),
        ));
    }

    if let Some(evlr) = raw
        .evlr
        .filter(|e| e.number_of_evlrs > 0 && e.start_of_first_evlr > 0)
    {
        let mut pos = evlr.start_of_first_evlr;
        for k in 0..evlr.number_of_evlrs {
            // 60 bytes of EVLR header, its data length at byte 20.
            let place = || format!("EVLR {k} of {} at byte {pos}", evlr.number_of_evlrs);
            let len = match read_u64_at(&mut f, pos.saturating_add(20)) {
                Ok(len) => len,
                Err(e) => {
                    return Err(short(e).unwrap_or_else(|| {
                        malformed(
                            path,
                            place(),
                            "the file ends inside this EVLR's header: it is truncated, or the \
                             header's EVLR offset or count is wrong",
                        )
                    }));
                }
            };
            let end = pos.saturating_add(60).saturating_add(len);
            if end > file_len {
                return Err(malformed(
                    path,
                    place(),
                    format!(
                        "the EVLR declares {len} bytes of data, but the file ends at byte \
                         {file_len}: it is truncated or the EVLR is damaged"
                    ),
                ));
            }
            pos = end;
        }
    }

    if compressed {
        bound = check_laz(&mut f, path, &raw, vlrs_at, n, file_len)?;
    }
    Ok(bound)
}

/// The LAZ checks; returns the most points the chunks can hold.
fn check_laz<R: Read + Seek>(
    f: &mut R,
    path: &Path,
    raw: &las::raw::Header,
    vlrs_at: u64,
    n: u64,
    file_len: u64,
) -> Result<u64> {
    let record_len = u64::from(raw.point_data_record_length);
    let data_start = u64::from(raw.offset_to_point_data);
    let io = |e: std::io::Error| Error::io(path, "cannot read", e);
    // The laszip VLR, found as the las crate finds it: the first VLR (read one after the
    // other from the end of the header) whose user id is `laszip encoded` and record id
    // 22204. Without one the las crate says so itself.
    let mut pos = vlrs_at;
    let mut vlr = None;
    let mut compressor = 0u16;
    for _ in 0..raw.number_of_variable_length_records {
        // 54 bytes of VLR header: reserved, user id (16), record id, length, description.
        let mut h = [0u8; 54];
        f.seek(SeekFrom::Start(pos)).map_err(io)?;
        if f.read_exact(&mut h).is_err() {
            break;
        }
        let len = u64::from(u16::from_le_bytes([h[20], h[21]]));
        let user = &h[2..18];
        let user = &user[..user.iter().position(|&c| c == 0).unwrap_or(16)];
        let record_id = u16::from_le_bytes([h[18], h[19]]);
        if user == b"laszip encoded" && record_id == 22204 {
            let mut data = vec![0u8; len as usize];
            if f.read_exact(&mut data).is_err() {
                break;
            }
            compressor = data
                .get(..2)
                .map_or(0, |c| u16::from_le_bytes([c[0], c[1]]));
            vlr = laz::LazVlr::read_from(&data[..]).ok();
            break;
        }
        pos += 54 + len;
    }
    let Some(vlr) = vlr else {
        return Ok(n);
    };
    let items: u64 = vlr.items().iter().map(|i| u64::from(i.size())).sum();
    if items != record_len || record_len == 0 {
        return Err(malformed(
            path,
            "header, laszip VLR",
            format!(
                "the LAZ items add up to {items} bytes a point, but the header's point record \
                 length is {record_len}: a damaged file"
            ),
        ));
    }

    // The chunk table offset, as laz reads it: at the start of the point data, or, when that
    // is not past it, in the last 8 bytes of the file.
    let compressed_start = data_start + 8;
    let mut table = read_u64_at(f, data_start).map_err(|e| {
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            malformed(
                path,
                format!("byte {data_start}"),
                "the file ends where its compressed points should start: it is truncated",
            )
        } else {
            io(e)
        }
    })? as i64;
    if table <= data_start as i64 && file_len >= 8 {
        table = read_u64_at(f, file_len - 8).map_err(io)? as i64;
    }
    if table <= data_start as i64 {
        // laz reports the missing chunk table itself.
        return Ok(n);
    }
    let table = table as u64;
    if table < compressed_start || table.saturating_add(8) > file_len {
        return Err(malformed(
            path,
            format!("byte {data_start}"),
            format!(
                "the LAZ chunk table is said to start at byte {table}, but it must lie \
                 between the compressed points (from byte {compressed_start}) and the end of \
                 the file ({file_len} bytes): the file is truncated or damaged"
            ),
        ));
    }
    let compressed_bytes = table - compressed_start;
    let mut head = [0u8; 8];
    f.seek(SeekFrom::Start(table)).map_err(io)?;
    f.read_exact(&mut head).map_err(io)?;
    let chunks = u64::from(u32::from_le_bytes([head[4], head[5], head[6], head[7]]));
    // Every chunk starts with one point stored raw.
    let most_chunks = compressed_bytes / record_len;
    if chunks > most_chunks {
        return Err(malformed(
            path,
            format!("LAZ chunk table at byte {table}"),
            format!(
                "the chunk table declares {chunks} chunks, but the {compressed_bytes} bytes of \
                 compressed points hold at most {most_chunks} (each chunk starts with one \
                 {record_len}-byte point): the file is damaged"
            ),
        ));
    }
    if chunks == 0 {
        if n > 0 {
            return Err(malformed(
                path,
                format!("LAZ chunk table at byte {table}"),
                format!("the chunk table has no chunks, but the header declares {n} points"),
            ));
        }
        return Ok(0);
    }
    f.seek(SeekFrom::Start(table)).map_err(io)?;
    let variable = vlr.uses_variable_size_chunks();
    let entries = laz::laszip::ChunkTable::read(f, variable).map_err(|e| {
        malformed(
            path,
            format!("LAZ chunk table at byte {table}"),
            format!("cannot decode the chunk table ({e}): the file is truncated or damaged"),
        )
    })?;
    let total: u64 = entries
        .as_ref()
        .iter()
        .fold(0u64, |s, e| s.saturating_add(e.byte_count));
    if total > compressed_bytes {
        return Err(malformed(
            path,
            format!("LAZ chunk table at byte {table}"),
            format!(
                "the chunks add up to {total} bytes, but only {compressed_bytes} bytes of \
                 compressed points lie before the table: the file is damaged"
            ),
        ));
    }
    // The decoder sizes a chunk's buffer for its declared points before decoding it.
    let small = SMALL_CHUNK_BYTES / record_len;
    let mut capacity = 0u64;
    for (i, e) in entries.as_ref().iter().enumerate() {
        let points = if variable {
            e.point_count
        } else {
            u64::from(vlr.chunk_size())
        };
        let most = e.byte_count.saturating_mul(MAX_POINTS_PER_BYTE).max(small);
        if points > most {
            return Err(malformed(
                path,
                format!("LAZ chunk {i} of {chunks}"),
                format!(
                    "the chunk declares {points} points in {} compressed bytes, more than a \
                     LAZ chunk can hold (at most {MAX_POINTS_PER_BYTE} points a byte): the \
                     file is damaged",
                    e.byte_count
                ),
            ));
        }
        capacity = capacity.saturating_add(points);
    }
    if compressor == LAYERED_CHUNKED {
        check_layers(
            f,
            path,
            &vlr,
            entries.as_ref(),
            compressed_start,
            record_len,
        )?;
    }
    if n > capacity {
        return Err(malformed(
            path,
            "header",
            format!(
                "the header declares {n} points, but the LAZ chunk table's {chunks} chunks \
                 hold at most {capacity}: the file is truncated or its header is damaged"
            ),
        ));
    }
    Ok(n)
}

/// laszip's compressor code of layered chunks (point formats 6 to 10).
const LAYERED_CHUNKED: u16 = 3;

/// Layered chunks (point formats 6-10) start with the first point raw, a point count and one
/// u32 size a layer; laz reserves every layer's size before reading it, so the sizes must
/// add up to at most the chunk's bytes. The layers of each laz item as laz 0.13 reads them.
fn check_layers<R: Read + Seek>(
    f: &mut R,
    path: &Path,
    vlr: &laz::LazVlr,
    entries: &[laz::laszip::ChunkTableEntry],
    compressed_start: u64,
    record_len: u64,
) -> Result<()> {
    use laz::laszip::LazItemType as T;
    let layers: u64 = vlr
        .items()
        .iter()
        .map(|i| match i.item_type() {
            T::Point14 => 9,
            T::RGBNIR14 => 2,
            T::RGB14 | T::WavePacket14 => 1,
            T::Byte14(n) => u64::from(n),
            // Not layered: laz refuses the item before reading any chunk.
            _ => 0,
        })
        .sum();
    let head = record_len + 4 + 4 * layers;
    let mut start = compressed_start;
    let mut sizes = vec![0u8; 4 * layers as usize];
    for (i, e) in entries.iter().enumerate() {
        // A chunk too short for its own sizes ends inside them: laz says so without
        // reserving anything.
        if e.byte_count >= head {
            f.seek(SeekFrom::Start(start + record_len + 4))
                .map_err(|e| Error::io(path, "cannot read", e))?;
            f.read_exact(&mut sizes)
                .map_err(|e| Error::io(path, "cannot read", e))?;
            let total: u64 = sizes
                .chunks_exact(4)
                .map(|b| u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
                .sum();
            if total > e.byte_count - head {
                return Err(malformed(
                    path,
                    format!("LAZ chunk {i} of {} at byte {start}", entries.len()),
                    format!(
                        "the chunk's layers declare {total} bytes, but it has {} bytes after \
                         their sizes: the file is damaged",
                        e.byte_count - head
                    ),
                ));
            }
        }
        start += e.byte_count;
    }
    Ok(())
}

/// True when the error comes from data ending too early (a short read somewhere below).
fn is_short_read(e: &las::Error) -> bool {
    if let las::Error::Io(io) = e {
        return io.kind() == std::io::ErrorKind::UnexpectedEof;
    }
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        if let Some(io) = s.downcast_ref::<std::io::Error>() {
            return io.kind() == std::io::ErrorKind::UnexpectedEof;
        }
        source = s.source();
    }
    // The laz crate's error wraps the I/O error without exposing it as a source.
    e.to_string().contains("failed to fill whole buffer")
}

/// A las/laz error as the library's: an I/O failure of the disk, or a malformed file (short
/// or garbled), placed at `place`.
pub(super) fn las_error(
    path: &Path,
    place: impl Into<String>,
    in_header: bool,
    e: las::Error,
) -> Error {
    // A failing disk is an I/O error of the file; a short or garbled file is malformed.
    if let las::Error::Io(io) = &e
        && !matches!(
            io.kind(),
            std::io::ErrorKind::UnexpectedEof | std::io::ErrorKind::InvalidData
        )
    {
        return Error::io(
            path,
            "cannot read",
            std::io::Error::new(io.kind(), io.to_string()),
        );
    }
    let what = match (is_short_read(&e), in_header) {
        (true, true) => "the file ends inside its header, records or LAZ chunk table: it is \
                         truncated"
            .to_string(),
        (true, false) => "the point data ends early: the file is truncated or damaged, or \
                          its header declares more points than it holds"
            .to_string(),
        (false, _) => format!("{e} (not a valid LAS/LAZ file, or a damaged one)"),
    };
    Error::malformed(path, place, what)
}
