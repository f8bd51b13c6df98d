//! Colour temperature: the linear sRGB colour of a blackbody at a temperature in kelvin
//! (1000–40000 K), scaled to luminance 1.

use crate::color::Rgb;

/// Linear sRGB colour of a blackbody at `kelvin` (1000–40000 K), with luminance 1.
///
/// Planck's law integrated against the CIE 1931 2° colour-matching functions (the
/// analytic multi-lobe fit of Wyman, Sloan and Shirley, 2013) at 5 nm, then XYZ → linear
/// sRGB. Negative components (very low CCTs are outside sRGB) are clipped.
pub(crate) fn cct_to_rgb(kelvin: f64) -> Rgb {
    let g = |x: f64, mu: f64, s1: f64, s2: f64| {
        let t = (x - mu) / if x < mu { s1 } else { s2 };
        (-0.5 * t * t).exp()
    };
    let (mut xx, mut yy, mut zz) = (0.0, 0.0, 0.0);
    let mut nm = 380.0f64;
    while nm <= 780.0 {
        let l = nm * 1e-9;
        let planck = 1.0 / (l.powi(5) * ((1.438_776_9e-2 / (l * kelvin)).exp() - 1.0));
        let x = 1.056 * g(nm, 599.8, 37.9, 31.0) + 0.362 * g(nm, 442.0, 16.0, 26.7)
            - 0.065 * g(nm, 501.1, 20.4, 26.2);
        let y = 0.821 * g(nm, 568.8, 46.9, 40.5) + 0.286 * g(nm, 530.9, 16.3, 31.1);
        let z = 1.217 * g(nm, 437.0, 11.8, 36.0) + 0.681 * g(nm, 459.0, 26.0, 13.8);
        xx += planck * x;
        yy += planck * y;
        zz += planck * z;
        nm += 5.0;
    }
    let (x, y, z) = (xx / yy, 1.0, zz / yy);
    let r = 3.2406 * x - 1.5372 * y - 0.4986 * z;
    let gg = -0.9689 * x + 1.8758 * y + 0.0415 * z;
    let b = 0.0557 * x - 0.2040 * y + 1.0570 * z;
    let rgb = [r.max(0.0), gg.max(0.0), b.max(0.0)];
    let lum = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    Rgb(rgb.map(|c| (c / lum) as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blackbody_colours_have_unit_luminance_and_warm_to_cool_order() {
        let warm = cct_to_rgb(2700.0);
        let d65 = cct_to_rgb(6504.0);
        assert!(warm[0] > warm[2]);
        assert!((warm.luminance() - 1.0).abs() < 1e-5);
        // 6504 K is close to the sRGB white point: near-equal channels.
        assert!((d65[0] / d65[2] - 1.0).abs() < 0.12, "{d65:?}");
    }
}
