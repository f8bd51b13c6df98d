//! Textures averaged into reflectance: `map_Kd` of an MTL material.
//!
//! A PNG, JPEG or WebP texture is decoded within [`MAX_TEXTURE_PIXELS`] and
//! [`MAX_TEXTURE_SIDE`], its sRGB-encoded channels are converted to linear values, and the
//! mean is taken weighted by alpha (a fully transparent texel does not count; a texture
//! that is transparent everywhere counts every texel equally). Radiosity needs one
//! reflectance per patch; the mean is the texture's reflectance as seen from afar.

use crate::color::{Rgb, Rgb64};
use crate::input_limits::{MAX_TEXTURE_PIXELS, MAX_TEXTURE_SIDE};

/// The alpha-weighted mean linear RGB of the encoded image `bytes`, or why it cannot be
/// read.
pub(crate) fn mean_linear_rgb(bytes: &[u8]) -> Result<Rgb, String> {
    summary(bytes).map(|s| s.mean)
}

/// What a material takes from a texture: its colour as seen from afar, and how its alpha
/// is spread (for glTF's `alphaMode`).
#[derive(Debug, Clone)]
pub(crate) struct Summary {
    /// The alpha-weighted mean linear RGB.
    pub mean: Rgb,
    /// Texels per 8-bit alpha value.
    pub alpha: Box<[u64; 256]>,
}

impl Summary {
    /// The share of texels whose alpha times `factor` is at least `cutoff`: the opaque
    /// part of a glTF `MASK` material.
    pub fn coverage(&self, factor: f64, cutoff: f64) -> f64 {
        let (mut kept, mut count) = (0u64, 0u64);
        for (k, &c) in self.alpha.iter().enumerate() {
            if factor * (k as f64 / 255.0) >= cutoff {
                kept += c;
            }
            count += c;
        }
        if count == 0 {
            1.0
        } else {
            kept as f64 / count as f64
        }
    }
}

/// The [`Summary`] of the encoded image `bytes`, or why it cannot be read.
pub(crate) fn summary(bytes: &[u8]) -> Result<Summary, String> {
    let reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    match reader.format() {
        Some(image::ImageFormat::Png | image::ImageFormat::Jpeg | image::ImageFormat::WebP) => {}
        Some(f) => {
            return Err(format!(
                "{f:?} textures are not supported (PNG, JPEG or WebP)"
            ))
        }
        None => return Err("not a PNG, JPEG or WebP image".into()),
    }
    let (w, h) = reader.into_dimensions().map_err(|e| e.to_string())?;
    if w == 0 || h == 0 {
        return Err("the image is empty".into());
    }
    if w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE || w as u64 * h as u64 > MAX_TEXTURE_PIXELS {
        return Err(format!(
            "{w} × {h} texels: more than the limit of {MAX_TEXTURE_PIXELS} texels \
             ({MAX_TEXTURE_SIDE} a side)"
        ));
    }
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    // The decoded image at up to 8 bytes a texel, plus its RGBA8 copy.
    limits.max_alloc = Some(MAX_TEXTURE_PIXELS * 12);
    reader.limits(limits);
    let img = reader.decode().map_err(|e| e.to_string())?.to_rgba8();
    let lut: [f64; 256] = std::array::from_fn(|k| srgb_to_linear(k as f64 / 255.0));
    let (mut sum, mut weight, mut plain) = (Rgb64::ZERO, 0f64, Rgb64::ZERO);
    let mut alpha = Box::new([0u64; 256]);
    for px in img.pixels() {
        alpha[px[3] as usize] += 1;
        let a = px[3] as f64 / 255.0;
        let v = Rgb64::new(
            lut[px[0] as usize],
            lut[px[1] as usize],
            lut[px[2] as usize],
        );
        sum += a * v;
        plain += v;
        weight += a;
    }
    let texels = img.pixels().len() as f64;
    let mean = if weight > 0.0 {
        (sum / weight).to_f32()
    } else {
        (plain / texels).to_f32()
    };
    Ok(Summary { mean, alpha })
}

/// The sRGB transfer function inverted (IEC 61966-2-1).
fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png(w: u32, h: u32, px: impl Fn(u32, u32) -> [u8; 4]) -> Vec<u8> {
        let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(px(x, y)));
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    }

    #[test]
    fn mean_is_linear_and_alpha_weighted() {
        // Half the texels sRGB 188 (linear 0.5029), half `right`.
        let grey_left = |right: [u8; 4]| {
            png(
                4,
                2,
                |x, _| if x < 2 { [188, 188, 188, 255] } else { right },
            )
        };
        // The right half black: mean 0.2514.
        let m = mean_linear_rgb(&grey_left([0, 0, 0, 255])).unwrap();
        assert!(
            (m[0] as f64 - 0.5 * srgb_to_linear(188.0 / 255.0)).abs() < 1e-6,
            "{m:?}"
        );
        // The black half transparent: only the grey counts.
        let m = mean_linear_rgb(&grey_left([0, 0, 0, 0])).unwrap();
        assert!(
            (m[1] as f64 - srgb_to_linear(188.0 / 255.0)).abs() < 1e-6,
            "{m:?}"
        );
        // Pure colours stay apart.
        let red = png(1, 1, |_, _| [255, 0, 0, 255]);
        assert_eq!(mean_linear_rgb(&red).unwrap(), [1.0, 0.0, 0.0]);
    }

    #[test]
    fn coverage_counts_the_texels_at_or_above_the_cutoff() {
        // A leaf card: a quarter of the texels opaque, a quarter at alpha 128, half clear.
        let leaf = png(4, 1, |x, _| match x {
            0 => [40, 90, 30, 255],
            1 => [40, 90, 30, 128],
            _ => [0, 0, 0, 0],
        });
        let s = summary(&leaf).unwrap();
        assert_eq!(s.coverage(1.0, 0.5), 0.5);
        assert_eq!(s.coverage(1.0, 0.6), 0.25);
        // The factor scales the texels' alpha first.
        assert_eq!(s.coverage(0.5, 0.5), 0.25);
    }

    #[test]
    fn garbage_and_other_formats_are_refused() {
        assert!(mean_linear_rgb(b"not an image").is_err());
        let mut bmp = std::io::Cursor::new(Vec::new());
        image::RgbaImage::new(2, 2)
            .write_to(&mut bmp, image::ImageFormat::Png)
            .unwrap();
        // A truncated PNG.
        let bytes = bmp.into_inner();
        assert!(mean_linear_rgb(&bytes[..bytes.len() / 2]).is_err());
    }
}
