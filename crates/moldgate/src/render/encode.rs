//! The PNG file of a picture: 8-bit RGB, one IDAT chunk whose deflate stream is compressed in
//! bands of rows on all threads.
//!
//! Each band of [`BAND_ROWS`] rows is filtered (the "up" filter: each byte less the one above
//! it, which on these pictures, flat backgrounds and smoothly shaded parts, compresses as well
//! as choosing a filter per row) straight from the canvas's RGBA bytes, and compressed on
//! its own at deflate level 1 into blocks that end on a byte boundary (a sync flush), the
//! last band's blocks ending the stream. The bands' blocks laid end to end are one deflate
//! stream (a band's matches reach back only into its own rows); the zlib wrapper's Adler-32
//! is the bands' checksums combined. The bands are fixed by the picture's height, not by the
//! threads, so the bytes are the same on any number of threads.

use super::pool::{Pool, Pooled};
use miniz_oxide::deflate::core::{
    compress_to_output, create_comp_flags_from_zip_params, CompressorOxide, TDEFLFlush, TDEFLStatus,
};

/// Rows of pixels compressed together (a band of a 1600-pixel picture is 300 kB filtered).
pub const BAND_ROWS: usize = 64;

/// Deflate level of the bands: level 1 takes 86 % off the encoding at the crate's default
/// level for a file 30 % larger (docs/performance.md).
const LEVEL: i32 = 1;

/// The PNG file of an opaque picture given as RGBA bytes, rows of `width` pixels (the alpha
/// bytes are left out).
pub fn png(rgba: &[u8], width: u32, height: u32) -> Result<Vec<u8>, String> {
    use rayon::prelude::*;
    let (w, h) = (width as usize, height as usize);
    if rgba.len() != 4 * w * h {
        return Err(format!(
            "{} bytes for a picture of {width}x{height} pixels",
            rgba.len()
        ));
    }
    let bands = h.div_ceil(BAND_ROWS);
    // Each running task's buffer of filtered rows is made once ([`Pooled`]).
    let pool: Pool<Vec<u8>> = Pool::default();
    let compressed: Vec<(Vec<u8>, u32, usize)> = (0..bands)
        .into_par_iter()
        .map_init(
            || Pooled::take(&pool),
            |filtered, band| {
                let rows = band * BAND_ROWS..((band + 1) * BAND_ROWS).min(h);
                filter_up(rgba, w, rows, filtered);
                let adler = simd_adler32::adler32(&filtered.as_slice());
                let flush = if band + 1 == bands {
                    TDEFLFlush::Finish
                } else {
                    TDEFLFlush::Sync
                };
                deflate(filtered, flush).map(|bytes| (bytes, adler, filtered.len()))
            },
        )
        .collect::<Result<_, String>>()?;
    let mut zlib = Vec::with_capacity(6 + compressed.iter().map(|c| c.0.len()).sum::<usize>());
    // CMF: deflate with a 32 KiB window; FLG: the fastest level, and the check bits that make
    // the pair a multiple of 31.
    zlib.extend_from_slice(&[0x78, 0x01]);
    let mut adler = 1;
    for (bytes, band_adler, len) in &compressed {
        zlib.extend_from_slice(bytes);
        adler = adler32_combine(adler, *band_adler, *len);
    }
    zlib.extend_from_slice(&adler.to_be_bytes());

    let mut out = Vec::with_capacity(zlib.len() + 64);
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    writer
        .write_chunk(png::chunk::IDAT, &zlib)
        .map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())?;
    Ok(out)
}

/// Into `out` (emptied first), the filtered rows `rows` of the RGBA picture, `w` pixels
/// wide: each row its filter type (2, "up") and its RGB bytes less those of the row above
/// (zero above the first row).
fn filter_up(rgba: &[u8], w: usize, rows: std::ops::Range<usize>, out: &mut Vec<u8>) {
    out.clear();
    out.reserve(rows.len() * (3 * w + 1));
    for y in rows {
        let row = &rgba[4 * w * y..4 * w * (y + 1)];
        out.push(2);
        if y == 0 {
            out.extend(row.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]));
        } else {
            let above = &rgba[4 * w * (y - 1)..4 * w * y];
            out.extend(
                row.chunks_exact(4)
                    .zip(above.chunks_exact(4))
                    .flat_map(|(p, q)| {
                        [
                            p[0].wrapping_sub(q[0]),
                            p[1].wrapping_sub(q[1]),
                            p[2].wrapping_sub(q[2]),
                        ]
                    }),
            );
        }
    }
}

/// `data` as raw deflate blocks at [`LEVEL`], ended by `flush` (a sync flush: on a byte
/// boundary with the stream left open; finish: the stream's last block).
fn deflate(data: &[u8], flush: TDEFLFlush) -> Result<Vec<u8>, String> {
    // No zlib header (negative window bits): the bands are parts of one stream.
    let mut compressor = CompressorOxide::new(create_comp_flags_from_zip_params(LEVEL, -15, 0));
    let mut out = Vec::with_capacity(data.len() / 4);
    let (status, read) = compress_to_output(&mut compressor, data, flush, |bytes| {
        out.extend_from_slice(bytes);
        true
    });
    let done = match flush {
        TDEFLFlush::Finish => status == TDEFLStatus::Done,
        _ => status == TDEFLStatus::Okay,
    };
    if !done || read != data.len() {
        return Err(format!(
            "deflate stopped at {read} of {} bytes ({status:?})",
            data.len()
        ));
    }
    Ok(out)
}

/// The Adler-32 of two byte strings one after the other, from the checksum `a` of the first,
/// `b` of the second and the second's length (zlib's `adler32_combine`).
fn adler32_combine(a: u32, b: u32, len_b: usize) -> u32 {
    const BASE: u64 = 65521;
    let rem = len_b as u64 % BASE;
    let (a1, a2) = (u64::from(a & 0xffff), u64::from(a >> 16));
    let (b1, b2) = (u64::from(b & 0xffff), u64::from(b >> 16));
    // s1 = a1 + b1 - 1, s2 = a2 + b2 + rem * a1 - rem (mod BASE), every term kept positive.
    let s1 = (a1 + b1 + BASE - 1) % BASE;
    let s2 = (a2 + b2 + rem * a1 % BASE + BASE - rem) % BASE;
    (s2 << 16 | s1) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A seeded byte generator (xorshift).
    fn bytes(n: usize, seed: u64) -> Vec<u8> {
        let mut x = seed | 1;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x >> 24) as u8
            })
            .collect()
    }

    #[test]
    fn combined_checksums_are_the_checksum_of_the_whole() {
        let data = bytes(300_000, 7);
        for split in [0, 1, 5551, 5552, 65_521, 65_522, 150_000, 299_999, 300_000] {
            let (a, b) = data.split_at(split);
            assert_eq!(
                adler32_combine(
                    simd_adler32::adler32(&a),
                    simd_adler32::adler32(&b),
                    b.len()
                ),
                simd_adler32::adler32(&data.as_slice()),
                "{split}"
            );
        }
    }

    /// The file decodes, with the png crate, to the RGB of the picture, for heights that are
    /// and are not whole numbers of bands, and for pictures of noise (stored blocks) and of
    /// flat colour (long matches).
    #[test]
    fn the_file_decodes_to_the_picture() {
        for (w, h, noise) in [
            (37, 1, true),
            (64, BAND_ROWS, false),
            (101, BAND_ROWS + 1, true),
            (800, 3 * BAND_ROWS - 5, false),
            (300, 2 * BAND_ROWS + 9, true),
        ] {
            let mut rgba = if noise {
                bytes(4 * w * h, (w * h) as u64)
            } else {
                (0..4 * w * h)
                    .map(|i| ((i / 4 / w / 9) * 40) as u8)
                    .collect()
            };
            rgba.iter_mut().skip(3).step_by(4).for_each(|a| *a = 255);
            let file = png(&rgba, w as u32, h as u32).unwrap();
            let decoder = png::Decoder::new(std::io::Cursor::new(&file));
            let mut reader = decoder.read_info().unwrap();
            let mut buf = vec![0; reader.output_buffer_size().unwrap()];
            let info = reader.next_frame(&mut buf).unwrap();
            assert_eq!((info.width, info.height), (w as u32, h as u32));
            assert_eq!(info.color_type, png::ColorType::Rgb);
            let rgb: Vec<u8> = rgba
                .chunks_exact(4)
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect();
            assert!(buf[..info.buffer_size()] == rgb[..], "{w}x{h}");
            // The zlib stream's checksum holds (miniz_oxide's inflate checks it; the png
            // crate's may not): the one IDAT chunk follows the signature and the IHDR.
            let idat_len = u32::from_be_bytes(file[33..37].try_into().unwrap()) as usize;
            assert_eq!(&file[37..41], b"IDAT");
            let inflated =
                miniz_oxide::inflate::decompress_to_vec_zlib(&file[41..41 + idat_len]).unwrap();
            assert_eq!(inflated.len(), h * (3 * w + 1), "{w}x{h}");
        }
        assert!(png(&[0; 12], 2, 2).is_err());
    }
}
