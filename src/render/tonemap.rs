//! Exposure and tone mapping: linear radiance to 8-bit sRGB through one log-spaced table.

use rayon::prelude::*;

use crate::color::Rgb;

/// Tone mapping of linear radiance after exposure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ToneMap {
    /// Clip at 1.
    Clamp,
    /// ACES filmic curve (Narkowicz fit): soft shoulder, keeps highlights.
    Filmic,
}

/// Exposure (stops) that maps the log-average luminance of the lit pixels to middle grey
/// (0.18), like a camera's auto exposure. 0 for a black image.
pub fn auto_exposure(img: &[Rgb]) -> f32 {
    // Every 5th pixel is plenty for a mean of logarithms.
    let (sum, count) = img
        .par_chunks(4096)
        .map(|chunk| {
            chunk
                .iter()
                .step_by(5)
                .map(|p| p.luminance())
                .filter(|&y| y > 0.0)
                .fold((0f64, 0usize), |(s, c), y| (s + (y as f64).ln(), c + 1))
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if count == 0 {
        return 0.0;
    }
    let avg = (sum / count as f64).exp();
    ((0.18 / avg).log2() as f32).clamp(-40.0, 40.0)
}

/// The tone curve alone, from a linear value after exposure to a linear display value in
/// [0, 1] (before the sRGB transfer function).
pub fn tone_curve(x: f32, tm: ToneMap) -> f32 {
    match tm {
        ToneMap::Clamp => x.clamp(0.0, 1.0),
        ToneMap::Filmic => aces(x.max(0.0)),
    }
}

fn srgb_oetf(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

fn aces(x: f32) -> f32 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
}

/// The tone table covers values (after exposure) from 2^LUT_LO_EXP, below which every
/// curve gives code 0, to 2^LUT_HI_EXP = 16, above which every curve gives white.
const LUT_LO_EXP: i32 = -16;
const LUT_HI_EXP: i32 = 4;
/// Mantissa bits kept in the index: steps of 2^-10 ≈ 0.1 %, far below one 8-bit code.
const LUT_MANT_BITS: u32 = 10;
const LUT_SIZE: usize = ((LUT_HI_EXP - LUT_LO_EXP) as usize) << LUT_MANT_BITS;
const LUT_SHIFT: u32 = 23 - LUT_MANT_BITS;

/// Index into the tone table: the top bits of the float (exponent and 10 mantissa bits),
/// i.e. a log-spaced table reached without any arithmetic. Negative and NaN map to 0.
#[inline]
fn lut_index(v: f32) -> usize {
    let lo = 2f32.powi(LUT_LO_EXP).to_bits() >> LUT_SHIFT;
    let b = v.max(0.0).to_bits() >> LUT_SHIFT;
    (b.saturating_sub(lo) as usize).min(LUT_SIZE - 1)
}

/// The tone curve followed by the sRGB transfer function, as 8-bit codes indexed by
/// [`lut_index`]; built once per curve.
fn tone_lut(tm: ToneMap) -> &'static [u8] {
    static LUTS: std::sync::OnceLock<[Vec<u8>; 2]> = std::sync::OnceLock::new();
    let luts = LUTS.get_or_init(|| {
        let lo = 2f32.powi(LUT_LO_EXP).to_bits() >> LUT_SHIFT;
        [ToneMap::Clamp, ToneMap::Filmic].map(|tm| {
            (0..LUT_SIZE as u32)
                .map(|i| {
                    // The middle of the bucket.
                    let v = f32::from_bits(((lo + i) << LUT_SHIFT) | (1 << (LUT_SHIFT - 1)));
                    let t = match tm {
                        ToneMap::Clamp => v.min(1.0),
                        ToneMap::Filmic => aces(v),
                    };
                    (srgb_oetf(t) * 255.0 + 0.5) as u8
                })
                .collect()
        })
    });
    &luts[tm as usize]
}

/// 8-bit sRGB pixels from linear values, scaled by 2^exposure. The whole curve (tone map,
/// then the sRGB transfer function) is one log-spaced table, which keeps the steep dark
/// end finely resolved.
pub fn tonemap(img: &[Rgb], exposure: f32, tm: ToneMap) -> Vec<u8> {
    tonemap_pixels(img.len(), |i| img[i], Some(exposure), tm).0
}

/// 8-bit sRGB pixels `0..n` from a linear pixel source, in one pass: exposure (auto from
/// every 16th pixel when None), tone curve, sRGB. Returns the pixels and the stops used.
pub(super) fn tonemap_pixels(
    n: usize,
    pixel: impl Fn(usize) -> Rgb + Sync,
    exposure: Option<f32>,
    tm: ToneMap,
) -> (Vec<u8>, f32) {
    let ev = exposure.unwrap_or_else(|| {
        let sample: Vec<Rgb> = (0..n).into_par_iter().step_by(16).map(&pixel).collect();
        auto_exposure(&sample)
    });
    let lut = tone_lut(tm);
    let k = ev.exp2();
    let mut out = vec![0u8; 3 * n];
    out.par_chunks_mut(3 * 4096)
        .enumerate()
        .for_each(|(blk, o)| {
            for (j, o) in o.chunks_exact_mut(3).enumerate() {
                let p = pixel(blk * 4096 + j);
                for c in 0..3 {
                    o[c] = lut[lut_index(p[c] * k)];
                }
            }
        });
    (out, ev)
}
