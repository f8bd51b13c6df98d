//! Photometric RGB triples and the luminous value of a triple.
//!
//! Every light quantity in relight is a linear RGB triple in photometric units:
//! exitance and radiosity in lm/m², illuminance in lux (= lm/m²), flux in lm.
//! The luminous (photopic) value of a triple is its Rec. 709 / sRGB luminance
//! `Y = 0.2126 R + 0.7152 G + 0.0722 B`, so a "white" triple `[v, v, v]` has `Y = v`.

/// A linear RGB triple. Its unit depends on the quantity it holds (see module docs).
pub type Rgb = [f32; 3];

/// Rec. 709 luminance weights: the luminous value of an RGB triple.
pub const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// Luminous value Y of a linear RGB triple (lm/m² for exitance, lux for illuminance).
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    LUMA[0] * c[0] + LUMA[1] * c[1] + LUMA[2] * c[2]
}

/// Luminous value in f64, for sums over many patches.
#[inline]
pub fn luminance64(c: [f64; 3]) -> f64 {
    LUMA[0] as f64 * c[0] + LUMA[1] as f64 * c[1] + LUMA[2] as f64 * c[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_has_its_own_luminance() {
        assert!((luminance([3.0, 3.0, 3.0]) - 3.0).abs() < 1e-6);
        assert!((luminance([1.0, 0.0, 0.0]) - 0.2126).abs() < 1e-7);
    }
}
