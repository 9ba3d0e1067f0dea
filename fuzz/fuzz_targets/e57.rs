//! E57 through `sharpedge::io::read` and `read_for_output` with an E57 output (every record
//! kept), then `write_e57` of what was read with its first point marked moved (the encoding
//! of moved coordinates into the file's record types). Every 1024-byte page gets its CRC
//! recomputed first: a mutated page would otherwise stop at the checksum, and the fuzzer
//! would never reach the XML or the compressed vectors behind it (the CRC check itself has
//! its own test with a real corrupt file). Passes when the calls return.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use sharpedge::io::{CloudFormat, NonFinite, Original, ReadOptions, read, read_for_output, write_e57};

const PAGE: usize = 1024;

/// CRC-32C (Castagnoli), bitwise: the checksum E57 pages carry, stored big endian.
fn crc32c(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0x82F6_3B78 } else { crc >> 1 };
        }
    }
    !crc
}

fuzz_target!(
    init: {
        // As for las: the library turns a panic inside the e57 crate into an error, which
        // libfuzzer-sys's hook would abort on first. A panic that escapes still aborts.
        drop(std::panic::take_hook());
    },
    |data: &[u8]| {
    let mut bytes = data.to_vec();
    if bytes.len() % PAGE == 0 {
        for page in bytes.chunks_exact_mut(PAGE) {
            let crc = crc32c(&page[..PAGE - 4]);
            page[PAGE - 4..].copy_from_slice(&crc.to_be_bytes());
        }
    }
    let path = common::write_input("input.e57", &bytes);
    if read(&path, &ReadOptions::default()).is_err() {
        return;
    }
    let Ok((cloud, Some(Original::E57(file)))) = read_for_output(
        &path,
        &ReadOptions { non_finite: NonFinite::Drop },
        CloudFormat::E57,
    ) else {
        return;
    };
    let mut moved = vec![false; cloud.len()];
    if let Some(m) = moved.first_mut() {
        *m = true;
    }
    let out = common::write_input("output.e57", b"");
    let _ = write_e57(&out, &file, &cloud.positions, &moved);
    }
);
