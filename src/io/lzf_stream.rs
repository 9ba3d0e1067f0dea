//! LZF decompression (liblzf's format, the body of a PCD `binary_compressed` file), in
//! pieces: [`decode`] turns input bytes into output bytes until an output mark is reached or
//! the input buffer runs low, so a caller can decode a large stream through a small window
//! (the last 8 KB of output, the farthest an LZF back reference reaches, plus a chunk) and
//! read the input in chunks; [`decompress`] decodes a whole buffer at once.
//!
//! Input: LZF tokens (a literal run: a byte `n - 1 < 32` then `n` bytes; a back reference:
//! 3 bits of length and 13 bits of distance, an extra length byte when the 3 bits are 7).
//! Output: the decoded bytes, or an [`LzfError`] naming the input offset of the bad token.
//!
//! Own decoder, not the `lzf` crate's `decompress`: that one copies back references byte by
//! byte and each literal run with a memcpy of its length, into a zeroed buffer of the whole
//! output. Here a literal run is copied as a fixed 8, 16 or 32 bytes and a back reference 4,
//! 8 or 16 bytes at a time (past the end of the run, into slack the caller provides, later
//! overwritten), into a window the caller reuses. Measured on the 160 MB body of the
//! 10,000,000-point file of scripts/bench_read_pcd.sh (60 million tokens) on a machine busy
//! with other builds: `examples/pcd_read lzf` (both into a new buffer of the whole body,
//! medians of 5, alternating) 0.65 s against the crate's 0.94 s; decoding into a buffer
//! already mapped, best of 5, 0.37-0.40 s (a first version copying 32-byte literals and
//! 8/16-byte references 0.46-0.64 s, one choosing between literal and reference bytes without
//! a branch 0.50 s) against the crate's 0.64-0.92 s. Safe code only: every copy is a
//! bounds-checked slice, and each token is checked before it is copied (its back reference within the output so far,
//! its length within the declared size, its bytes within the input), so a hostile stream
//! gives an error, never a read or write outside the buffers.

/// The farthest back an LZF back reference reaches (13 bits of distance, plus one).
pub(crate) const WINDOW: usize = 8192;

/// The most bytes one token produces (a back reference of 7 + 255 + 2).
const MAX_TOKEN_OUT: usize = 264;

/// Output slack past a decoding mark that [`decode`] needs: a token started before the mark
/// may run [`MAX_TOKEN_OUT`] past it, and the fixed-size copies overshoot by up to 31 bytes.
pub(crate) const SLACK: usize = MAX_TOKEN_OUT + 32;

/// The most input bytes one token takes (a length byte and a run of 32 literals).
pub(crate) const MAX_TOKEN_IN: usize = 33;

/// A damaged LZF stream: what is wrong and at which input byte (from the stream's start).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct LzfError {
    /// Offset of the bad token in the whole input stream.
    pub at: u64,
    pub what: String,
}

impl std::fmt::Display for LzfError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} (LZF token at byte {} of the stream)",
            self.what, self.at
        )
    }
}

/// Where a piece of decoding stands.
pub(crate) struct Cursor {
    /// Next input byte to read, in the current input buffer.
    pub input: usize,
    /// Next output byte to write, in the output buffer.
    pub output: usize,
    /// Bytes the stream may still produce (the declared size minus what was produced).
    pub room: usize,
    /// Input bytes consumed before the current input buffer (for error offsets).
    pub consumed_before: u64,
}

/// Decodes tokens from `input[c.input..]` into `out[c.output..]` until `c.output` reaches
/// `stop`, or the input holds fewer than [`MAX_TOKEN_IN`] bytes and `last` is false (the
/// caller then moves the unread bytes to the front, reads more and calls again), or the
/// input is used up. `out` must reach [`SLACK`] bytes past `stop`. Every byte of
/// `out[..c.output]` is taken as earlier output (a back reference may reach any of it).
pub(crate) fn decode(
    input: &[u8],
    last: bool,
    out: &mut [u8],
    stop: usize,
    c: &mut Cursor,
) -> Result<(), LzfError> {
    assert!(out.len() >= stop + SLACK, "lzf output buffer without slack");
    let (mut i, mut o, mut room) = (c.input, c.output, c.room);
    let before = c.consumed_before;
    let err = |i: usize, what: String| LzfError {
        at: before + i as u64,
        what,
    };
    let result = loop {
        if o >= stop {
            break Ok(());
        }
        let left = input.len() - i;
        if left < MAX_TOKEN_IN + 2 {
            if !last || left == 0 {
                break Ok(());
            }
            // The last few bytes of the stream: exact copies, every length checked.
            match tail_token(input, i, out, o, room) {
                Ok((ni, n)) => {
                    i = ni;
                    o += n;
                    room -= n;
                    continue;
                }
                Err(what) => break Err(err(i, what)),
            }
        }
        let ctrl = input[i] as usize;
        if ctrl < 32 {
            let n = ctrl + 1;
            if n > room {
                break Err(err(i, too_long(n, room)));
            }
            // At least 35 input bytes are left and the output has slack: copy a fixed 8, 16
            // or 32 (short runs are the rule in sensor data; a wider copy than needed costs
            // a store the next tokens' loads then wait for).
            if n <= 8 {
                out[o..o + 8].copy_from_slice(&input[i + 1..i + 9]);
            } else if n <= 16 {
                out[o..o + 16].copy_from_slice(&input[i + 1..i + 17]);
            } else {
                out[o..o + 32].copy_from_slice(&input[i + 1..i + 33]);
            }
            i += 1 + n;
            o += n;
            room -= n;
        } else {
            let mut len = ctrl >> 5;
            let mut j = i + 1;
            if len == 7 {
                len += input[j] as usize;
                j += 1;
            }
            let d = ((ctrl & 31) << 8) + input[j] as usize + 1;
            j += 1;
            let n = len + 2;
            if d > o {
                break Err(err(i, before_start(d, o)));
            }
            if n > room {
                break Err(err(i, too_long(n, room)));
            }
            copy_back(out, o, d, n);
            i = j;
            o += n;
            room -= n;
        }
    };
    c.input = i;
    c.output = o;
    c.room = room;
    result
}

/// Copies the `n` bytes `d` back from `o` to `o` (they may overlap it). In pieces of 4, 8
/// or 16 bytes no longer than `d`: each piece reads only bytes already written, and the
/// last one writes up to 15 bytes past `o + n` (slack).
#[inline(always)]
fn copy_back(out: &mut [u8], o: usize, d: usize, n: usize) {
    let r = o - d;
    // Most back references are 3 or 4 bytes: one 8- or 4-byte copy when the distance
    // allows it.
    if n <= 8 && d >= 8 {
        out.copy_within(r..r + 8, o);
    } else if n <= 4 && d >= 4 {
        out.copy_within(r..r + 4, o);
    } else if d >= 16 {
        let mut k = 0;
        while k < n {
            out.copy_within(r + k..r + k + 16, o + k);
            k += 16;
        }
    } else if d >= 8 {
        let mut k = 0;
        while k < n {
            out.copy_within(r + k..r + k + 8, o + k);
            k += 8;
        }
    } else {
        for k in 0..n {
            out[o + k] = out[r + k];
        }
    }
}

/// One token near the end of the input, decoded with exact copies: the next input offset
/// and the bytes produced, or what is wrong.
fn tail_token(
    input: &[u8],
    i: usize,
    out: &mut [u8],
    o: usize,
    room: usize,
) -> Result<(usize, usize), String> {
    let ctrl = input[i] as usize;
    if ctrl < 32 {
        let n = ctrl + 1;
        if n > room {
            return Err(too_long(n, room));
        }
        let Some(run) = input.get(i + 1..i + 1 + n) else {
            return Err(format!(
                "a literal run of {n} bytes with {} bytes of input left: the data is truncated",
                input.len() - i - 1
            ));
        };
        out[o..o + n].copy_from_slice(run);
        return Ok((i + 1 + n, n));
    }
    let mut len = ctrl >> 5;
    let mut j = i + 1;
    let truncated = || "a back reference cut off by the end of the input: the data is truncated";
    if len == 7 {
        len += *input.get(j).ok_or_else(truncated)? as usize;
        j += 1;
    }
    let d = ((ctrl & 31) << 8) + *input.get(j).ok_or_else(truncated)? as usize + 1;
    let n = len + 2;
    if d > o {
        return Err(before_start(d, o));
    }
    if n > room {
        return Err(too_long(n, room));
    }
    for k in 0..n {
        out[o + k] = out[o - d + k];
    }
    Ok((j + 1, n))
}

fn too_long(n: usize, room: usize) -> String {
    format!(
        "a token of {n} bytes where the declared size leaves {room}: the data decodes to more than the declared size"
    )
}

fn before_start(d: usize, o: usize) -> String {
    format!(
        "a back reference {d} bytes back after {o} bytes of output: it points before the start of the data"
    )
}

/// Decompresses a whole LZF buffer that must decode to exactly `size` bytes.
pub(crate) fn decompress(input: &[u8], size: usize) -> Result<Vec<u8>, LzfError> {
    let mut out = vec![0u8; size + SLACK];
    let mut c = Cursor {
        input: 0,
        output: 0,
        room: size,
        consumed_before: 0,
    };
    decode(input, true, &mut out, size, &mut c)?;
    if c.output != size || c.input != input.len() {
        return Err(LzfError {
            at: c.input as u64,
            what: if c.output != size {
                format!(
                    "the data ends after {} of the {size} bytes it should decode to: it is \
                     truncated or the size is wrong",
                    c.output
                )
            } else {
                format!(
                    "{} bytes of input are left after the {size} bytes it should decode to",
                    input.len() - c.input
                )
            },
        });
    }
    out.truncate(size);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::SmallRng;
    use rand::{RngExt, SeedableRng};

    /// Data LZF finds repeats in at every distance and length, with random stretches.
    fn sample(n: usize, seed: u64) -> Vec<u8> {
        let mut rng = SmallRng::seed_from_u64(seed);
        let mut v: Vec<u8> = Vec::with_capacity(n);
        while v.len() < n {
            match rng.random_range(0..4) {
                0 => {
                    let k = rng.random_range(1..200);
                    v.extend((0..k).map(|_| rng.random::<u8>()));
                }
                1 if !v.is_empty() => {
                    let d = rng.random_range(1..=v.len().min(9000));
                    let k = rng.random_range(1..300);
                    for _ in 0..k {
                        v.push(v[v.len() - d]);
                    }
                }
                2 => {
                    let b = rng.random::<u8>();
                    v.extend(std::iter::repeat_n(b, rng.random_range(1..400)));
                }
                _ => {
                    // Quantised floats, as a sensor's coordinates.
                    for _ in 0..rng.random_range(1..50) {
                        let x = rng.random_range(0..1024) as f32 / 1024.0;
                        v.extend_from_slice(&x.to_le_bytes());
                    }
                }
            }
        }
        v.truncate(n);
        v
    }

    #[test]
    fn decodes_what_the_crate_compresses() {
        for (n, seed) in [
            (1, 1),
            (2, 2),
            (33, 3),
            (1000, 4),
            (100_000, 5),
            (2_000_000, 6),
        ] {
            let data = sample(n, seed);
            let packed = lzf::compress(&data).unwrap_or_else(|_| literals(&data));
            assert_eq!(decompress(&packed, n).unwrap(), data, "{n} bytes");
            assert_eq!(lzf::decompress(&packed, n).unwrap(), data);
        }
    }

    #[test]
    fn random_bytes_decode_like_the_crate() {
        // Incompressible data (the crate's compressor gives up: literal runs only) and
        // random token streams: the same bytes or an error wherever the crate errs.
        let mut rng = SmallRng::seed_from_u64(7);
        let data: Vec<u8> = (0..50_000).map(|_| rng.random()).collect();
        assert_eq!(decompress(&literals(&data), data.len()).unwrap(), data);
        for _ in 0..2000 {
            let len = rng.random_range(1..200);
            let junk: Vec<u8> = (0..len).map(|_| rng.random()).collect();
            let size = rng.random_range(1..3000);
            let ours = decompress(&junk, size);
            match lzf::decompress(&junk, size) {
                Ok(v) if v.len() == size => assert_eq!(ours.unwrap(), v),
                _ => assert!(ours.is_err(), "{junk:?}"),
            }
        }
    }

    fn literals(data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        for run in data.chunks(32) {
            out.push((run.len() - 1) as u8);
            out.extend_from_slice(run);
        }
        out
    }

    #[test]
    fn streamed_through_a_small_window_decodes_the_same() {
        let data = sample(300_000, 8);
        let packed = lzf::compress(&data).unwrap();
        // Input in pieces of 1000 bytes, output through a window of 8 KB + 4 KB.
        let chunk = 4096;
        let mut out = vec![0u8; WINDOW + chunk + SLACK];
        let mut got = Vec::new();
        let mut inbuf: Vec<u8> = Vec::new();
        let mut fed = 0;
        let mut c = Cursor {
            input: 0,
            output: 0,
            room: data.len(),
            consumed_before: 0,
        };
        let mut flushed = 0;
        loop {
            // Refill: keep the unread bytes, append the next piece.
            inbuf.drain(..c.input);
            c.consumed_before += c.input as u64;
            c.input = 0;
            let next = (fed + 1000).min(packed.len());
            inbuf.extend_from_slice(&packed[fed..next]);
            fed = next;
            let last = fed == packed.len();
            let stop = WINDOW + chunk;
            decode(&inbuf, last, &mut out, stop, &mut c).unwrap();
            got.extend_from_slice(&out[flushed..c.output]);
            flushed = c.output;
            if c.output >= stop {
                let keep = c.output - WINDOW;
                out.copy_within(keep..c.output, 0);
                c.output = WINDOW;
                flushed = WINDOW;
            }
            if last && c.input == inbuf.len() {
                break;
            }
        }
        assert_eq!(got, data);
        assert_eq!(c.room, 0);
    }

    #[test]
    fn hostile_streams_give_errors() {
        let e = |input: &[u8], size: usize| decompress(input, size).unwrap_err().to_string();
        // A back reference at the start, and one past the output so far (in the fast path
        // too: enough input after it).
        assert!(e(&[0x20, 0x00], 10).contains("before the start"));
        let mut far = vec![3, 1, 2, 3, 4, 0x20 | 31, 0xff];
        far.extend_from_slice(&[31; 64]);
        assert!(e(&far, 5000).contains("8192 bytes back after 4 bytes"));
        // Every distance beyond the output so far, after 100 literal bytes.
        for d in 101..=8192usize {
            let mut s = vec![31];
            s.extend_from_slice(&[7; 32]);
            s.extend_from_slice(&[31]);
            s.extend_from_slice(&[8; 32]);
            s.extend_from_slice(&[31]);
            s.extend_from_slice(&[9; 32]);
            s.extend_from_slice(&[3, 1, 2, 3, 4]);
            let d1 = d - 1;
            s.extend_from_slice(&[0x20 | (d1 >> 8) as u8, d1 as u8]);
            s.extend_from_slice(&[0; 40]);
            let msg = e(&s, 10_000);
            assert!(msg.contains("before the start"), "{d}: {msg}");
            assert!(msg.contains("at byte 104"), "{msg}");
        }
        // A literal run and a back reference longer than the declared size.
        assert!(e(&[31; 40], 10).contains("more than the declared size"));
        assert!(e(&[1, 5, 6, 0xe0, 200, 0], 20).contains("more than the declared size"));
        // Truncated tokens: a literal run, a length byte, a distance byte cut off.
        assert!(e(&[9, 1, 2, 3], 10).contains("truncated"));
        assert!(e(&[0, 1, 0xe0], 300).contains("truncated"));
        assert!(e(&[0, 1, 0x20], 300).contains("truncated"));
        // Too little data for the size, and bytes left over after it.
        assert!(e(&[1, 5, 6], 3).contains("ends after 2 of the 3 bytes"));
        assert!(e(&[1, 5, 6, 0, 7], 2).contains("2 bytes of input are left"));
        assert!(decompress(&[], 0).unwrap().is_empty());
    }

    #[test]
    fn fuzzed_streams_never_panic() {
        let mut rng = SmallRng::seed_from_u64(9);
        let data = sample(20_000, 10);
        let packed = lzf::compress(&data).unwrap();
        for _ in 0..3000 {
            let mut s = packed.clone();
            for _ in 0..rng.random_range(1..5) {
                let at = rng.random_range(0..s.len());
                s[at] = rng.random();
            }
            s.truncate(rng.random_range(1..=s.len()));
            let size = if rng.random_bool(0.5) {
                data.len()
            } else {
                rng.random_range(0..40_000)
            };
            let ours = decompress(&s, size);
            match lzf::decompress(&s, size) {
                Ok(v) if v.len() == size => assert_eq!(ours.unwrap(), v),
                _ => assert!(ours.is_err()),
            }
        }
    }
}
