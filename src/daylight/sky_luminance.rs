//! Sky luminance distributions, each scaled to a given horizontal illuminance from the sky
//! alone (the sun, when there is one, is separate: [`Sun`]).
//!
//! - Uniform: L constant, E_h = π L.
//! - CIE traditional overcast (Moon & Spencer 1942): L(γ) = L_z (1 + 2 sin γ) / 3, so
//!   E_h = (7π/9) L_z in closed form.
//! - CIE clear sky (CIE 1973; ISO 15469:2004 type 12):
//!   L/L_z = f(χ) φ(γ) / (f(Z_s) φ(90°)), with the gradation φ(γ) = 1 − exp(−0.32 / sin γ)
//!   and the indicatrix f(χ) = 0.91 + 10 exp(−3χ) + 0.45 cos² χ, where χ is the angle to
//!   the sun and Z_s the sun's zenith angle. L_z follows from E_h by quadrature
//!   ([`horizontal_integral`]).
//!
//! - Perez all-weather ([`super::perez`]), scaled like the CIE clear sky.
//!
//! Angles are radians inside: altitude γ above the horizon, azimuth from north clockwise.

use std::f64::consts::{FRAC_PI_2, PI};

/// The sun's disc: 0.533° across.
pub const SUN_DIAMETER_DEG: f64 = 0.533;

/// The sun as a light source: its position and its direct normal illuminance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sun {
    pub altitude: f64,
    pub azimuth: f64,
    /// Direct normal illuminance, lux.
    pub normal_illuminance: f64,
}

impl Sun {
    /// Solid angle of the disc, sr.
    pub fn solid_angle() -> f64 {
        let r = (SUN_DIAMETER_DEG / 2.0).to_radians();
        2.0 * PI * (1.0 - r.cos())
    }
}

/// A sky's luminance distribution, scaled.
#[derive(Debug, Clone, PartialEq)]
pub enum Sky {
    Uniform {
        luminance: f64,
    },
    CieOvercast {
        zenith: f64,
    },
    CieClear {
        zenith: f64,
        sun_altitude: f64,
        sun_azimuth: f64,
    },
    /// The Perez all-weather sky: `scale` × the relative luminance of
    /// [`super::perez::relative_luminance`].
    Perez {
        scale: f64,
        params: [f64; 5],
        sun_altitude: f64,
        sun_azimuth: f64,
    },
}

/// Unit direction (east, north, up) of a sky position.
fn dir(altitude: f64, azimuth: f64) -> [f64; 3] {
    [
        altitude.cos() * azimuth.sin(),
        altitude.cos() * azimuth.cos(),
        altitude.sin(),
    ]
}

/// Angle between two sky positions, radians.
fn angle(a: (f64, f64), b: (f64, f64)) -> f64 {
    let (p, q) = (dir(a.0, a.1), dir(b.0, b.1));
    (p[0] * q[0] + p[1] * q[1] + p[2] * q[2])
        .clamp(-1.0, 1.0)
        .acos()
}

fn indicatrix(chi: f64) -> f64 {
    0.91 + 10.0 * (-3.0 * chi).exp() + 0.45 * chi.cos().powi(2)
}

fn gradation(altitude: f64) -> f64 {
    if altitude <= 0.0 {
        return 0.0;
    }
    1.0 - (-0.32 / altitude.sin()).exp()
}

impl Sky {
    /// A uniform sky giving `horizontal_illuminance` lux on an unobstructed horizontal plane.
    pub fn uniform(horizontal_illuminance: f64) -> Sky {
        Sky::Uniform {
            luminance: horizontal_illuminance / PI,
        }
    }

    /// The CIE overcast sky for a horizontal illuminance, lux.
    pub fn cie_overcast(horizontal_illuminance: f64) -> Sky {
        Sky::CieOvercast {
            zenith: horizontal_illuminance * 9.0 / (7.0 * PI),
        }
    }

    /// The CIE clear sky (without the sun) for the sun's position (radians) and the sky's
    /// horizontal illuminance, lux.
    pub fn cie_clear(horizontal_illuminance: f64, sun_altitude: f64, sun_azimuth: f64) -> Sky {
        let unit = Sky::CieClear {
            zenith: 1.0,
            sun_altitude,
            sun_azimuth,
        };
        let e1 = integral(&unit, 120, 240);
        Sky::CieClear {
            zenith: if e1 > 0.0 {
                horizontal_illuminance / e1
            } else {
                0.0
            },
            sun_altitude,
            sun_azimuth,
        }
    }

    /// The Perez sky of an hour's conditions, the sun at `sun_azimuth` (radians), scaled to
    /// the conditions' diffuse horizontal illuminance.
    pub fn perez(c: &super::perez::Conditions, sun_azimuth: f64) -> Sky {
        let unit = Sky::Perez {
            scale: 1.0,
            params: c.params,
            sun_altitude: FRAC_PI_2 - c.sun_zenith,
            sun_azimuth,
        };
        let e1 = integral(&unit, 120, 240);
        Sky::Perez {
            scale: if e1 > 0.0 {
                c.diffuse_illuminance / e1
            } else {
                0.0
            },
            params: c.params,
            sun_altitude: FRAC_PI_2 - c.sun_zenith,
            sun_azimuth,
        }
    }

    /// Luminance, cd/m², towards a sky position (radians); 0 below the horizon.
    pub fn luminance(&self, altitude: f64, azimuth: f64) -> f64 {
        if altitude < 0.0 {
            return 0.0;
        }
        match *self {
            Sky::Uniform { luminance } => luminance,
            Sky::CieOvercast { zenith } => zenith * (1.0 + 2.0 * altitude.sin()) / 3.0,
            Sky::CieClear {
                zenith,
                sun_altitude,
                sun_azimuth,
            } => {
                let chi = angle((altitude, azimuth), (sun_altitude, sun_azimuth));
                let zs = FRAC_PI_2 - sun_altitude;
                zenith * indicatrix(chi) * gradation(altitude)
                    / (indicatrix(zs) * gradation(FRAC_PI_2))
            }
            Sky::Perez {
                scale,
                ref params,
                sun_altitude,
                sun_azimuth,
            } => {
                let gamma = angle((altitude, azimuth), (sun_altitude, sun_azimuth));
                scale * super::perez::relative_luminance(params, FRAC_PI_2 - altitude, gamma)
            }
        }
    }
}

/// ∫ L sin γ dω over the sky hemisphere (the illuminance on a horizontal plane, lux), by
/// the midpoint rule on a 0.25° × 0.5° grid in altitude and azimuth. For the smooth CIE
/// skies its error is below 0.01 % (checked against the overcast sky's closed form).
pub fn horizontal_integral(sky: &Sky) -> f64 {
    integral(sky, 360, 720)
}

/// [`horizontal_integral`] on an `na` × `nz` grid.
fn integral(sky: &Sky, na: usize, nz: usize) -> f64 {
    let (da, dz) = (FRAC_PI_2 / na as f64, 2.0 * PI / nz as f64);
    // The skies with a sun are symmetric about the sun's vertical plane: half of each
    // ring, from the sun's azimuth on, counts twice (the same points as a full ring
    // started there).
    let (start, steps, twice) = match sky {
        Sky::CieClear { sun_azimuth, .. } | Sky::Perez { sun_azimuth, .. } => {
            (*sun_azimuth, nz / 2, 2.0)
        }
        _ => (0.0, nz, 1.0),
    };
    let mut sum = 0.0;
    for i in 0..na {
        let g = (i as f64 + 0.5) * da;
        let w = g.sin() * g.cos() * da * dz;
        let mut ring = 0.0;
        for j in 0..steps {
            ring += sky.luminance(g, start + (j as f64 + 0.5) * dz);
        }
        sum += w * twice * ring;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_and_overcast_skies_integrate_to_their_illuminance() {
        for sky in [Sky::uniform(10_000.0), Sky::cie_overcast(10_000.0)] {
            let e = horizontal_integral(&sky);
            assert!((e - 10_000.0).abs() < 1.0, "{sky:?}: {e}");
        }
        // The overcast zenith is three times as bright as the horizon.
        let s = Sky::cie_overcast(10_000.0);
        let ratio = s.luminance(FRAC_PI_2, 0.0) / s.luminance(0.0, 1.0);
        assert!((ratio - 3.0).abs() < 1e-12);
        assert_eq!(s.luminance(-0.1, 0.0), 0.0);
    }

    #[test]
    fn clear_sky_is_scaled_and_brightest_around_the_sun() {
        let (alt, az) = (40f64.to_radians(), PI);
        let s = Sky::cie_clear(15_000.0, alt, az);
        let e = horizontal_integral(&s);
        assert!((e - 15_000.0).abs() < 0.5, "{e}");
        // Near the sun it outshines the zenith.
        let Sky::CieClear { zenith, .. } = s else {
            unreachable!()
        };
        assert!((s.luminance(FRAC_PI_2, 0.0) - zenith).abs() < 1e-9 * zenith);
        let near = s.luminance(alt + 0.05, az);
        assert!(near > 3.0 * zenith, "{near} vs {zenith}");
        // 90° from the sun, across the zenith (altitude 50°, north), it is darker than the
        // zenith: f(90°) φ(50°) / (f(50°) φ(90°)) = 0.68.
        let anti = s.luminance(FRAC_PI_2 - alt, 0.0);
        assert!(anti < zenith, "{anti} vs {zenith}");
        // Symmetric about the sun's vertical plane.
        let (l, r) = (s.luminance(0.3, az - 0.7), s.luminance(0.3, az + 0.7));
        assert!((l - r).abs() < 1e-9 * l);
    }

    #[test]
    fn the_sun_disc_solid_angle() {
        // 0.533° across: 6.80e-5 sr.
        assert!(
            (Sun::solid_angle() - 6.80e-5).abs() < 0.01e-5,
            "{}",
            Sun::solid_angle()
        );
    }
}
