//! The Perez all-weather sky: luminous efficacy of the direct and diffuse parts (Perez et
//! al. 1990, "Modeling daylight availability and irradiance components from direct and
//! global irradiance", Solar Energy 44(5), eqs. 1–3, 7, 8 and table 4) and the relative
//! sky luminance distribution (Perez, Seals & Michalsky 1993, "All-weather model for sky
//! luminance distribution", Solar Energy 50(3), eq. 1, eqs. 6–8 and table 1, with the
//! erratum in 51(5)).
//!
//! Inputs are the hour's direct normal and diffuse horizontal irradiance (W/m²), the sun's
//! zenith angle Z, the day of the year (extraterrestrial irradiance) and the dew point
//! (precipitable water W = exp(0.07 T_d − 0.075) cm). From them:
//! - sky clearness ε = ((D + I)/D + 1.041 Z³) / (1 + 1.041 Z³), Z in radians, in eight bins;
//! - sky brightness Δ = D · m / I₀, with the Kasten (1966) air mass m;
//! - diffuse efficacy a + b W + c cos Z + d ln Δ, direct efficacy
//!   max(0, a + b W + c e^(5.73 Z − 5) + d Δ), lm/W;
//! - the relative luminance lv(ζ, γ) = (1 + a e^(b / cos ζ)) (1 + c e^(d γ) + e cos² γ) of a
//!   sky element at zenith angle ζ and angle γ from the sun, scaled so the sky gives the
//!   diffuse illuminance on a horizontal plane.
//!
//! Clamps, as Radiance's `gendaylit`/`gendaymtx` apply them: ε ≤ 12 and, for 1.065 < ε < 2.8,
//! Δ ≥ 0.2 in the distribution; Z ≤ 90° (a sun below the horizon lights the sky as one on
//! it); cos ζ ≥ 0.01 so elements at the horizon stay finite.

use std::f64::consts::FRAC_PI_2;

/// Solar constant, W/m².
pub const SOLAR_CONSTANT: f64 = 1367.0;

/// Upper bounds of the eight clearness bins (the last is open).
const EPSILON_BINS: [f64; 7] = [1.065, 1.230, 1.500, 1.950, 2.800, 4.500, 6.200];

/// Table 1 of Perez 1993: per bin, a1..a4, b1..b4, c1..c4, d1..d4, e1..e4.
#[rustfmt::skip]
const DISTRIBUTION: [[f64; 20]; 8] = [
    [1.3525, -0.2576, -0.2690, -1.4366, -0.7670, 0.0007, 1.2734, -0.1233, 2.8000, 0.6004,
     1.2375, 1.0000, 1.8734, 0.6297, 0.9738, 0.2809, 0.0356, -0.1246, -0.5718, 0.9938],
    [-1.2219, -0.7730, 1.4148, 1.1016, -0.2054, 0.0367, -3.9128, 0.9156, 6.9750, 0.1774,
     6.4477, -0.1239, -1.5798, -0.5081, -1.7812, 0.1080, 0.2624, 0.0672, -0.2190, -0.4285],
    [-1.1000, -0.2515, 0.8952, 0.0156, 0.2782, -0.1812, -4.5000, 1.1766, 24.7219, -13.0812,
     -37.7000, 34.8438, -5.0000, 1.5218, 3.9229, -2.6204, -0.0156, 0.1597, 0.4199, -0.5562],
    [-0.5484, -0.6654, -0.2672, 0.7117, 0.7234, -0.6219, -5.6812, 2.6297, 33.3389, -18.3000,
     -62.2500, 52.0781, -3.5000, 0.0016, 1.1477, 0.1062, 0.4659, -0.3296, -0.0876, -0.0329],
    [-0.6000, -0.3566, -2.5000, 2.3250, 0.2937, 0.0496, -5.6812, 1.8415, 21.0000, -4.7656,
     -21.5906, 7.2492, -3.5000, -0.1554, 1.4062, 0.3988, 0.0032, 0.0766, -0.0656, -0.1294],
    [-1.0156, -0.3670, 1.0078, 1.4051, 0.2875, -0.5328, -3.8500, 3.3750, 14.0000, -0.9999,
     -7.1406, 7.5469, -3.4000, -0.1078, -1.0750, 1.5702, -0.0672, 0.4016, 0.3017, -0.4844],
    [-1.0000, 0.0211, 0.5025, -0.5119, -0.3000, 0.1922, 0.7023, -1.6317, 19.0000, -5.0000,
     1.2438, -1.9094, -4.0000, 0.0250, 0.3844, 0.2656, 1.0468, -0.3788, -2.4517, 1.4656],
    [-1.0500, 0.0289, 0.4260, 0.3590, -0.3250, 0.1156, 0.7781, 0.0025, 31.0625, -14.5000,
     -46.1148, 55.3750, -7.2312, 0.4050, 13.3500, 0.6234, 1.5000, -0.6426, 1.8564, 0.5636],
];

/// Table 4 of Perez 1990, diffuse luminous efficacy (eq. 7): a, b, c, d per bin.
const DIFFUSE_EFFICACY: [[f64; 4]; 8] = [
    [97.24, -0.46, 12.00, -8.91],
    [107.22, 1.15, 0.59, -3.95],
    [104.97, 2.96, -5.53, -8.77],
    [102.39, 5.59, -13.95, -13.90],
    [100.71, 5.94, -22.75, -23.74],
    [106.42, 3.83, -36.15, -28.83],
    [141.88, 1.90, -53.24, -14.03],
    [152.23, 0.35, -45.27, -7.98],
];

/// Table 4 of Perez 1990, direct luminous efficacy (eq. 8): a, b, c, d per bin.
const DIRECT_EFFICACY: [[f64; 4]; 8] = [
    [57.20, -4.55, -2.98, 117.12],
    [98.99, -3.46, -1.21, 12.38],
    [109.83, -4.90, -1.71, -8.81],
    [110.34, -5.84, -1.99, -4.56],
    [106.36, -3.97, -1.75, -6.16],
    [107.19, -1.25, -1.51, -26.73],
    [105.75, 0.77, -1.26, -34.44],
    [101.18, 1.58, -1.10, -8.29],
];

/// Dew point assumed when the weather gives none, °C (Radiance's default).
pub const DEFAULT_DEW_POINT_C: f64 = 11.0;

/// One hour's sky conditions, derived from irradiance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conditions {
    /// Sky clearness ε (1 overcast … 12 clear).
    pub clearness: f64,
    /// Sky brightness Δ.
    pub brightness: f64,
    /// Clearness bin, 0 … 7.
    pub bin: usize,
    /// Diffuse horizontal illuminance, lux.
    pub diffuse_illuminance: f64,
    /// Direct normal illuminance, lux (0 with the sun below the horizon).
    pub direct_illuminance: f64,
    /// The distribution's parameters a … e.
    pub params: [f64; 5],
    /// The sun's zenith angle used, radians (≤ π/2).
    pub sun_zenith: f64,
}

/// Extraterrestrial normal irradiance on day `day` of the year, W/m² (Spencer 1971).
pub fn extraterrestrial(day: u32) -> f64 {
    let b = 2.0 * std::f64::consts::PI * (day as f64 - 1.0) / 365.0;
    SOLAR_CONSTANT
        * (1.00011
            + 0.034221 * b.cos()
            + 0.00128 * b.sin()
            + 0.000719 * (2.0 * b).cos()
            + 0.000077 * (2.0 * b).sin())
}

/// Relative optical air mass (Kasten 1966) at zenith angle `z` (radians, ≤ π/2).
fn air_mass(z: f64) -> f64 {
    1.0 / (z.cos() + 0.15 * (93.885 - z.to_degrees()).powf(-1.253))
}

/// The conditions of an hour with direct normal irradiance `dni` and diffuse horizontal
/// irradiance `dhi` (W/m², ≥ 0), the sun at altitude `sun_altitude` (radians), on `day` of
/// the year, with dew point `dew_point_c`. None when there is no diffuse light (night).
pub fn conditions(
    dni: f64,
    dhi: f64,
    sun_altitude: f64,
    day: u32,
    dew_point_c: f64,
) -> Option<Conditions> {
    if dhi.is_nan() || dhi <= 0.0 {
        return None;
    }
    let dni = if sun_altitude > 0.0 {
        dni.max(0.0)
    } else {
        0.0
    };
    let z = (FRAC_PI_2 - sun_altitude).clamp(0.0, FRAC_PI_2);
    let z3 = 1.041 * z.powi(3);
    let clearness = (((dhi + dni) / dhi + z3) / (1.0 + z3)).clamp(1.0, 12.0);
    let brightness = dhi * air_mass(z) / extraterrestrial(day);
    let bin = EPSILON_BINS
        .iter()
        .position(|&hi| clearness < hi)
        .unwrap_or(7);
    let w = (0.07 * dew_point_c.clamp(-60.0, 40.0) - 0.075).exp();
    let [a, b, c, d] = DIFFUSE_EFFICACY[bin];
    let diffuse_eff = (a + b * w + c * z.cos() + d * brightness.max(1e-4).ln()).max(0.0);
    let [a, b, c, d] = DIRECT_EFFICACY[bin];
    let direct_eff = (a + b * w + c * (5.73 * z - 5.0).exp() + d * brightness).max(0.0);
    Some(Conditions {
        clearness,
        brightness,
        bin,
        diffuse_illuminance: dhi * diffuse_eff,
        direct_illuminance: dni * direct_eff,
        params: distribution_params(z, clearness, brightness, bin),
        sun_zenith: z,
    })
}

/// The distribution's a … e for sun zenith `z`, clearness, brightness and bin (eqs. 6–8).
fn distribution_params(z: f64, clearness: f64, brightness: f64, bin: usize) -> [f64; 5] {
    let delta = if clearness > 1.065 && clearness < 2.8 {
        brightness.max(0.2)
    } else {
        brightness
    };
    let x = &DISTRIBUTION[bin];
    let lin = |i: usize| x[4 * i] + x[4 * i + 1] * z + delta * (x[4 * i + 2] + x[4 * i + 3] * z);
    let mut p = [lin(0), lin(1), lin(2), lin(3), lin(4)];
    if bin == 0 {
        p[2] = (delta * (x[8] + x[9] * z)).powf(x[10]).exp() - x[11];
        p[3] = -(delta * (x[12] + x[13] * z)).exp() + x[14] + delta * x[15];
    }
    p
}

/// Relative luminance of a sky element at zenith angle `zeta` and angle `gamma` from the
/// sun (radians), never negative.
pub fn relative_luminance(p: &[f64; 5], zeta: f64, gamma: f64) -> f64 {
    let cz = zeta.cos().max(0.01);
    let cg = gamma.cos();
    ((1.0 + p[0] * (p[1] / cz).exp()) * (1.0 + p[2] * (p[3] * gamma).exp() + p[4] * cg * cg))
        .max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overcast_and_clear_hours_fall_in_their_bins_with_plausible_efficacy() {
        // Overcast: all diffuse.
        let c = conditions(0.0, 200.0, 0.6, 172, 11.0).unwrap();
        assert_eq!(c.bin, 0);
        assert!((c.clearness - 1.0).abs() < 1e-12);
        let eff = c.diffuse_illuminance / 200.0;
        assert!((100.0..130.0).contains(&eff), "diffuse efficacy {eff}");
        assert_eq!(c.direct_illuminance, 0.0);
        // Clear summer noon: ε far above 6.2, direct efficacy about 100 lm/W.
        let c = conditions(850.0, 90.0, 1.1, 172, 11.0).unwrap();
        assert_eq!(c.bin, 7, "ε = {}", c.clearness);
        let eff = c.direct_illuminance / 850.0;
        assert!((90.0..110.0).contains(&eff), "direct efficacy {eff}");
        // The clear sky is brightest near the sun and darkest about 90° away from it.
        let near = relative_luminance(&c.params, 0.5, 0.05);
        let far = relative_luminance(&c.params, 0.5, 1.6);
        assert!(near > 5.0 * far, "{near} vs {far}");
        // Night: no sky.
        assert!(conditions(0.0, 0.0, -0.2, 1, 11.0).is_none());
    }

    #[test]
    fn extraterrestrial_irradiance_peaks_in_january() {
        assert!(extraterrestrial(3) > 1400.0 && extraterrestrial(185) < 1330.0);
    }
}
