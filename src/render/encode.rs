//! Encoders: 8-bit PNG and strip-parallel JPEG, linear OpenEXR and PFM.

use rayon::prelude::*;

use crate::color::Rgb;

/// Output encodings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    Png,
    Jpeg,
    /// Linear OpenEXR, f32 RGB radiance in W/(m²·sr)-like units (lm/(m²·sr)).
    Exr,
    /// Linear portable float map, the same values as EXR (the command line only).
    Pfm,
}

impl Format {
    pub fn content_type(self) -> &'static str {
        match self {
            Format::Png => "image/png",
            Format::Jpeg => "image/jpeg",
            Format::Exr => "image/x-exr",
            Format::Pfm => "image/x-portable-floatmap",
        }
    }
}

/// Encodes 8-bit sRGB pixels as PNG (fast compression) or JPEG (quality 90).
pub fn encode_8bit(rgb: &[u8], w: u32, h: u32, format: Format) -> Result<Vec<u8>, String> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    match format {
        Format::Png => image::codecs::png::PngEncoder::new_with_quality(
            &mut out,
            image::codecs::png::CompressionType::Fast,
            image::codecs::png::FilterType::Sub,
        )
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8),
        Format::Jpeg => return encode_jpeg(rgb, w, h),
        Format::Exr | Format::Pfm => return Err("EXR and PFM are written from linear data".into()),
    }
    .map_err(|e| e.to_string())?;
    Ok(out)
}

/// JPEG quality of 8-bit answers.
const JPEG_QUALITY: u8 = 90;

/// Baseline JPEG (quality 90, 4:2:0), encoded in horizontal strips in parallel.
///
/// Each strip is a JPEG of its own with a restart marker after every MCU row, so its
/// entropy-coded data is independent of the others (restarts reset the DC predictors).
/// The strips share every table, so the first strip's headers (with the full height)
/// followed by all strips' entropy data, joined and renumbered with RST markers, is one
/// valid JPEG that decodes to exactly the pixels a single-threaded encode gives.
fn encode_jpeg(rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>, String> {
    let (strips, strip_rows) = jpeg_strips(h, rayon::current_num_threads());
    let encode = |y0: u32, y1: u32, restart: bool| -> Result<Vec<u8>, String> {
        let mut out = Vec::with_capacity((w * (y1 - y0)) as usize / 4);
        let mut enc = jpeg_encoder::Encoder::new(&mut out, JPEG_QUALITY);
        enc.set_sampling_factor(jpeg_encoder::SamplingFactor::F_2_2);
        if restart {
            enc.set_restart_interval(w.div_ceil(16) as u16);
        }
        let rows = &rgb[(3 * w * y0) as usize..(3 * w * y1) as usize];
        enc.encode(
            rows,
            w as u16,
            (y1 - y0) as u16,
            jpeg_encoder::ColorType::Rgb,
        )
        .map_err(|e| e.to_string())?;
        Ok(out)
    };
    if strips <= 1 {
        return encode(0, h, false);
    }
    let parts: Vec<Vec<u8>> = (0..strips)
        .into_par_iter()
        .map(|s| encode(s * strip_rows, ((s + 1) * strip_rows).min(h), true))
        .collect::<Result<_, _>>()?;
    let mut out = Vec::with_capacity(parts.iter().map(Vec::len).sum::<usize>() + 16);
    for (s, part) in parts.iter().enumerate() {
        let (sof, data) = jpeg_layout(part).ok_or("JPEG strip without SOF0/SOS")?;
        let entropy = part
            .get(data..part.len().saturating_sub(2))
            .filter(|_| part.ends_with(&[0xFF, 0xD9]))
            .ok_or("JPEG strip without EOI")?;
        let first_row = s as u32 * strip_rows / 16;
        if s == 0 {
            out.extend_from_slice(&part[..data]);
            out[sof + 5..sof + 7].copy_from_slice(&(h as u16).to_be_bytes());
            out.extend_from_slice(entropy);
        } else {
            out.extend_from_slice(&[0xFF, 0xD0 + ((first_row - 1) % 8) as u8]);
            let mut prev_ff = false;
            for &b in entropy {
                let b = if prev_ff && (0xD0..=0xD7).contains(&b) {
                    0xD0 + ((b - 0xD0) as u32 + first_row) as u8 % 8
                } else {
                    b
                };
                out.push(b);
                prev_ff = b == 0xFF;
            }
        }
    }
    out.extend_from_slice(&[0xFF, 0xD9]);
    Ok(out)
}

/// How to cut an image of height `h` into strips for `threads` threads: the number of
/// strips and the rows per strip (a multiple of the 16-row MCU). Every strip is non-empty:
/// `(strips − 1) · rows < h ≤ strips · rows`.
pub fn jpeg_strips(h: u32, threads: usize) -> (u32, u32) {
    let mcu_rows = h.div_ceil(16).max(1);
    let wanted = (threads.clamp(1, 8) as u32).min(mcu_rows);
    let per = mcu_rows.div_ceil(wanted);
    (mcu_rows.div_ceil(per), per * 16)
}

/// Offsets of the SOF0 marker and of the first entropy-coded byte after SOS.
fn jpeg_layout(j: &[u8]) -> Option<(usize, usize)> {
    let mut i = 2; // after SOI
    let mut sof = None;
    while i + 4 <= j.len() {
        if j[i] != 0xFF {
            return None;
        }
        let len = u16::from_be_bytes([j[i + 2], j[i + 3]]) as usize;
        match j[i + 1] {
            0xC0 => sof = Some(i),
            0xDA => return Some((sof?, i + 2 + len)),
            _ => {}
        }
        i += 2 + len;
    }
    None
}

/// Encodes linear RGB as OpenEXR (32-bit float).
pub fn encode_exr(img: &[Rgb], w: u32, h: u32) -> Result<Vec<u8>, String> {
    use image::ImageEncoder;
    let mut out = std::io::Cursor::new(Vec::new());
    image::codecs::openexr::OpenExrEncoder::new(&mut out)
        .write_image(
            bytemuck::cast_slice(img),
            w,
            h,
            image::ExtendedColorType::Rgb32F,
        )
        .map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

/// Writes linear RGB as PFM (little-endian, bottom row first), as the reference images.
pub fn encode_pfm(img: &[Rgb], w: u32, h: u32) -> Vec<u8> {
    let mut out = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    for y in (0..h as usize).rev() {
        for p in &img[y * w as usize..(y + 1) * w as usize] {
            for c in p.iter() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The strip-parallel JPEG decodes to exactly the pixels of a one-piece encode.
    #[test]
    fn strip_parallel_jpeg_decodes_like_a_single_encode() {
        for (w, h) in [(1024u32, 768u32), (333, 250), (64, 17)] {
            let rgb: Vec<u8> = (0..w * h)
                .flat_map(|i| {
                    let (x, y) = (i % w, i / w);
                    let n = (i.wrapping_mul(2_654_435_761) >> 27) as u8;
                    [
                        (x * 255 / w) as u8,
                        (y * 255 / h) as u8 ^ n,
                        ((x + y) % 256) as u8,
                    ]
                })
                .collect();
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(3)
                .build()
                .unwrap();
            let fast = pool.install(|| encode_jpeg(&rgb, w, h)).unwrap();
            let mut single = Vec::new();
            let mut enc = jpeg_encoder::Encoder::new(&mut single, JPEG_QUALITY);
            enc.set_sampling_factor(jpeg_encoder::SamplingFactor::F_2_2);
            enc.encode(&rgb, w as u16, h as u16, jpeg_encoder::ColorType::Rgb)
                .unwrap();
            let decode = |b: &[u8]| {
                image::load_from_memory_with_format(b, image::ImageFormat::Jpeg)
                    .unwrap()
                    .to_rgb8()
            };
            // Restart markers run RST0, RST1, ..., RST7, RST0, ... once per MCU row boundary.
            let (_, data) = jpeg_layout(&fast).unwrap();
            let rst: Vec<u8> = fast[data..]
                .windows(2)
                .filter(|p| p[0] == 0xFF && (0xD0..=0xD7).contains(&p[1]))
                .map(|p| p[1] - 0xD0)
                .collect();
            assert_eq!(rst.len() as u32, h.div_ceil(16) - 1, "{w}x{h}");
            assert!(
                rst.iter().enumerate().all(|(k, &m)| m as usize == k % 8),
                "{rst:?}"
            );
            let (a, b) = (decode(&fast), decode(&single));
            assert_eq!(a.dimensions(), (w, h));
            assert!(a.as_raw() == b.as_raw(), "{w}x{h}: pixels differ");
        }
    }

    #[test]
    fn jpeg_strip_split_panicked_with_more_threads_than_strips() {
        // Every height and thread count: strips are non-empty and cover the image.
        for threads in 1..=16 {
            for h in 1..=600u32 {
                let (strips, rows) = jpeg_strips(h, threads);
                assert!(strips >= 1 && rows % 16 == 0, "h {h} threads {threads}");
                assert!(
                    (strips - 1) * rows < h && h <= strips * rows,
                    "h {h} threads {threads}"
                );
            }
        }
        // The heights of the report, encoded for real on 1..16 threads.
        for threads in 1..=16 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for h in [1u32, 15, 17, 130, 150, 200] {
                let w = 40;
                let rgb: Vec<u8> = (0..3 * w * h).map(|i| (i % 251) as u8).collect();
                let jpeg = pool.install(|| encode_jpeg(&rgb, w, h)).unwrap();
                let img = image::load_from_memory_with_format(&jpeg, image::ImageFormat::Jpeg)
                    .unwrap()
                    .to_rgb8();
                assert_eq!(img.dimensions(), (w, h), "threads {threads}");
            }
        }
    }
}
