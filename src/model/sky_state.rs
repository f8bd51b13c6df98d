//! The one grammar of a sky, as clients give it ([`SkySpec`]), and [`SkyState`], a sky
//! resolved for a site: its luminance distribution, the sun, the ground, and the patch
//! luminances the transfer's sky responses are weighted by.
//!
//! Units: luminance cd/m², illuminance lux, irradiance W/m², angles degrees (altitude above
//! the horizon, azimuth from north clockwise: 90 east, 180 south).

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::QueryError;
use crate::daylight::sky_luminance::{Sky, Sun};
use crate::daylight::sun::{self, LocalTime};
use crate::daylight::tregenza::Subdivision;
use crate::daylight::{perez, Site};

/// Largest horizontal or normal illuminance a sky may give, lux (the brightest measured
/// daylight is about 130,000 lx).
pub const MAX_DAYLIGHT_LUX: f64 = 200_000.0;
/// Largest irradiance, W/m² (the solar constant is 1,367 W/m²).
pub const MAX_IRRADIANCE: f64 = 1500.0;

/// Where the sun is: a position, or a local standard time at the scene's site.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct SunPosition {
    /// Degrees above the horizon, −90 … 90.
    pub altitude: f64,
    /// Degrees from north, clockwise (90 east, 180 south), 0 … 360.
    pub azimuth: f64,
}

/// A sky, as a request gives it. `sun` or `time` places the sun (for `cie_clear` and
/// `perez` one of them is required; the overcast and uniform skies have no sun and ignore
/// them).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum SkySpec {
    /// Uniform luminance; `horizontal_illuminance` lux on an unobstructed horizontal plane.
    Uniform {
        horizontal_illuminance: f64,
        #[serde(default, deserialize_with = "some")]
        #[cfg_attr(feature = "server", schema(nullable = false))]
        sun: Option<SunPosition>,
        #[serde(default, deserialize_with = "some")]
        #[cfg_attr(feature = "server", schema(nullable = false))]
        time: Option<String>,
    },
    /// CIE traditional overcast sky, L(γ) ∝ 1 + 2 sin γ; daylight factors are given
    /// against `horizontal_illuminance`.
    CieOvercast {
        horizontal_illuminance: f64,
        #[serde(default, deserialize_with = "some")]
        #[cfg_attr(feature = "server", schema(nullable = false))]
        sun: Option<SunPosition>,
        #[serde(default, deserialize_with = "some")]
        #[cfg_attr(feature = "server", schema(nullable = false))]
        time: Option<String>,
    },
    /// CIE clear sky with the sun: `horizontal_illuminance` is the sky's diffuse part
    /// alone, `direct_normal_illuminance` the sun's (lux).
    CieClear {
        horizontal_illuminance: f64,
        direct_normal_illuminance: f64,
        #[serde(default, deserialize_with = "some")]
        #[cfg_attr(feature = "server", schema(nullable = false))]
        sun: Option<SunPosition>,
        #[serde(default, deserialize_with = "some")]
        #[cfg_attr(feature = "server", schema(nullable = false))]
        time: Option<String>,
    },
    /// Perez all-weather sky from an hour's irradiance (W/m²), luminous efficacy after
    /// Perez 1990; `dew_point` (°C, default 11) sets the precipitable water.
    Perez {
        direct_normal_irradiance: f64,
        diffuse_horizontal_irradiance: f64,
        #[serde(default, deserialize_with = "some")]
        #[cfg_attr(feature = "server", schema(nullable = false))]
        dew_point: Option<f64>,
        #[serde(default, deserialize_with = "some")]
        #[cfg_attr(feature = "server", schema(nullable = false))]
        sun: Option<SunPosition>,
        #[serde(default, deserialize_with = "some")]
        #[cfg_attr(feature = "server", schema(nullable = false))]
        time: Option<String>,
    },
}

/// Present means a value, never `null`.
fn some<'de, D: serde::Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    T::deserialize(d).map(Some)
}

/// A sky resolved for a site.
#[derive(Debug, Clone)]
pub struct SkyState {
    /// `uniform`, `cie_overcast`, `cie_clear` or `perez`.
    pub kind: &'static str,
    pub sky: Sky,
    /// The sun, when it is up and shines.
    pub sun: Option<Sun>,
    /// The sun's position, when one was given or derived (also below the horizon).
    pub sun_position: Option<SunPosition>,
    /// The sky's (diffuse) illuminance on an unobstructed horizontal plane, lux.
    pub diffuse_horizontal: f64,
    /// Luminance of the ground outside the model, cd/m²: ρg · E_global_horizontal / π.
    pub ground_luminance: f64,
    /// The reference of daylight factors (the overcast sky's horizontal illuminance).
    pub df_reference: Option<f64>,
}

fn lux(x: f64, what: &str) -> Result<f64, QueryError> {
    if x.is_finite() && (0.0..=MAX_DAYLIGHT_LUX).contains(&x) {
        Ok(x)
    } else {
        Err(QueryError::Invalid(format!(
            "sky.{what} = {x}: use 0 … {MAX_DAYLIGHT_LUX} lx"
        )))
    }
}

fn irradiance(x: f64, what: &str) -> Result<f64, QueryError> {
    if x.is_finite() && (0.0..=MAX_IRRADIANCE).contains(&x) {
        Ok(x)
    } else {
        Err(QueryError::Invalid(format!(
            "sky.{what} = {x}: use 0 … {MAX_IRRADIANCE} W/m²"
        )))
    }
}

impl SkySpec {
    /// The sky's type name.
    pub fn kind(&self) -> &'static str {
        match self {
            SkySpec::Uniform { .. } => "uniform",
            SkySpec::CieOvercast { .. } => "cie_overcast",
            SkySpec::CieClear { .. } => "cie_clear",
            SkySpec::Perez { .. } => "perez",
        }
    }

    fn placement(&self) -> (Option<SunPosition>, Option<&str>) {
        match self {
            SkySpec::Uniform { sun, time, .. }
            | SkySpec::CieOvercast { sun, time, .. }
            | SkySpec::CieClear { sun, time, .. }
            | SkySpec::Perez { sun, time, .. } => (*sun, time.as_deref()),
        }
    }

    /// The sun's position from `sun` or `time`, and the day of the year (for Perez).
    fn sun_position(&self, site: &Site) -> Result<Option<(SunPosition, u32)>, QueryError> {
        match self.placement() {
            (Some(_), Some(_)) => Err(QueryError::Invalid(
                "sky: give the sun's position (sun) or a time, not both".into(),
            )),
            (Some(p), None) => {
                if !(p.altitude.is_finite() && (-90.0..=90.0).contains(&p.altitude)) {
                    return Err(QueryError::Invalid(format!(
                        "sky.sun.altitude = {}: use −90 … 90 degrees",
                        p.altitude
                    )));
                }
                if !(p.azimuth.is_finite() && (0.0..=360.0).contains(&p.azimuth)) {
                    return Err(QueryError::Invalid(format!(
                        "sky.sun.azimuth = {}: use 0 … 360 degrees from north, clockwise",
                        p.azimuth
                    )));
                }
                // Day of the year: the equinox, for Perez's extraterrestrial irradiance.
                Ok(Some((p, 80)))
            }
            (None, Some(t)) => {
                let t = LocalTime::parse(t)
                    .map_err(|m| QueryError::Invalid(format!("sky.time: {m}")))?;
                let p = sun::position(site, &t);
                Ok(Some((
                    SunPosition {
                        altitude: p.altitude_deg,
                        azimuth: p.azimuth_deg,
                    },
                    t.day_of_year(),
                )))
            }
            (None, None) => Ok(None),
        }
    }

    /// Resolves the sky for `site`: checks every number, places the sun, scales the
    /// distribution.
    pub fn resolve(&self, site: &Site) -> Result<SkyState, QueryError> {
        let placed = self.sun_position(site)?;
        let need_sun = || {
            placed.ok_or_else(|| {
                QueryError::Invalid(format!(
                    "sky of type {}: give the sun (altitude, azimuth) or a time",
                    self.kind()
                ))
            })
        };
        let (sky, sun, diffuse, df_reference) = match *self {
            SkySpec::Uniform {
                horizontal_illuminance,
                ..
            } => {
                let e = lux(horizontal_illuminance, "horizontal_illuminance")?;
                (Sky::uniform(e), None, e, None)
            }
            SkySpec::CieOvercast {
                horizontal_illuminance,
                ..
            } => {
                let e = lux(horizontal_illuminance, "horizontal_illuminance")?;
                (Sky::cie_overcast(e), None, e, Some(e))
            }
            SkySpec::CieClear {
                horizontal_illuminance,
                direct_normal_illuminance,
                ..
            } => {
                let e = lux(horizontal_illuminance, "horizontal_illuminance")?;
                let en = lux(direct_normal_illuminance, "direct_normal_illuminance")?;
                let (p, _) = need_sun()?;
                // A sun at or below the horizon: the sky as with the sun on it, no disc.
                let alt = p.altitude.max(0.0).to_radians();
                let sky = Sky::cie_clear(e, alt, p.azimuth.to_radians());
                (sky, sun_of(p, en), e, None)
            }
            SkySpec::Perez {
                direct_normal_irradiance,
                diffuse_horizontal_irradiance,
                dew_point,
                ..
            } => {
                let dni = irradiance(direct_normal_irradiance, "direct_normal_irradiance")?;
                let dhi = irradiance(
                    diffuse_horizontal_irradiance,
                    "diffuse_horizontal_irradiance",
                )?;
                let dew = match dew_point {
                    Some(d) if d.is_finite() && (-90.0..=60.0).contains(&d) => d,
                    Some(d) => {
                        return Err(QueryError::Invalid(format!(
                            "sky.dew_point = {d}: use −90 … 60 °C"
                        )))
                    }
                    None => perez::DEFAULT_DEW_POINT_C,
                };
                let (p, day) = need_sun()?;
                match perez::conditions(dni, dhi, p.altitude.to_radians(), day, dew) {
                    None => (Sky::uniform(0.0), None, 0.0, None),
                    Some(c) => (
                        Sky::perez(&c, p.azimuth.to_radians()),
                        sun_of(p, c.direct_illuminance),
                        c.diffuse_illuminance,
                        None,
                    ),
                }
            }
        };
        let global = diffuse + sun.map_or(0.0, |s| s.normal_illuminance * s.altitude.sin());
        Ok(SkyState {
            kind: self.kind(),
            sky,
            sun,
            sun_position: placed.map(|(p, _)| p),
            diffuse_horizontal: diffuse,
            ground_luminance: site.ground_reflectance * global / std::f64::consts::PI,
            df_reference,
        })
    }
}

/// The sun of a position and normal illuminance, when it is up and shines.
fn sun_of(p: SunPosition, normal_illuminance: f64) -> Option<Sun> {
    (p.altitude > 0.0 && normal_illuminance > 0.0).then(|| Sun {
        altitude: p.altitude.to_radians(),
        azimuth: p.azimuth.to_radians(),
        normal_illuminance,
    })
}

impl SkyState {
    /// Luminance (cd/m²) towards scene direction `d` at `site`: the sky above the horizon,
    /// the ground below.
    pub fn luminance(&self, site: &Site, d: DVec3) -> f64 {
        let (alt, az) = site.sky_position(d);
        if alt < 0.0 {
            self.ground_luminance
        } else {
            self.sky.luminance(alt.to_radians(), az.to_radians())
        }
    }

    /// Mean luminance of every patch of `sub` (index 0 the ground), cd/m², from 8 × 8
    /// equal-solid-angle samples per sky patch.
    pub fn patch_luminances(&self, sub: &Subdivision) -> Vec<f64> {
        const S: usize = 8;
        let mut out = Vec::with_capacity(sub.patches.len());
        out.push(self.ground_luminance);
        for p in &sub.patches[1..] {
            let (s0, s1) = (p.altitude.0.sin(), p.altitude.1.sin());
            let mut sum = 0.0;
            for a in 0..S {
                let alt = (s0 + (s1 - s0) * (a as f64 + 0.5) / S as f64).asin();
                for z in 0..S {
                    let az = p.azimuth - 0.5 * p.width + p.width * (z as f64 + 0.5) / S as f64;
                    sum += self.sky.luminance(alt, az);
                }
            }
            out.push(sum / (S * S) as f64);
        }
        out
    }

    /// The sun spread over the sky patches nearest to it, for its interreflected light
    /// (as Radiance's `gendaymtx` does): (patch, luminance cd/m²) pairs whose
    /// luminance × solid angle sums to the sun's normal illuminance.
    pub fn sun_patches(&self, sub: &Subdivision) -> Vec<(usize, f64)> {
        self.sun.map_or_else(Vec::new, |s| sun_patches(&s, sub))
    }

    /// The sun's unit scene direction at `site`.
    pub fn sun_direction(&self, site: &Site) -> Option<(DVec3, f64)> {
        self.sun.map(|s| {
            (
                site.direction(s.altitude.to_degrees(), s.azimuth.to_degrees()),
                s.normal_illuminance,
            )
        })
    }
}

/// The sun spread over the four sky patches nearest to it, for its interreflected light
/// (as Radiance's `gendaymtx` does): (patch, luminance cd/m²) pairs whose
/// luminance × solid angle sums to the sun's normal illuminance.
pub fn sun_patches(s: &Sun, sub: &Subdivision) -> Vec<(usize, f64)> {
    let dir = |alt: f64, az: f64| DVec3::new(alt.cos() * az.sin(), alt.cos() * az.cos(), alt.sin());
    let sd = dir(s.altitude, s.azimuth);
    let mut near: Vec<(f64, usize)> = sub.patches[1..]
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (a, z) = p.centre();
            (dir(a, z).dot(sd), i + 1)
        })
        .collect();
    near.sort_by(|a, b| b.0.total_cmp(&a.0));
    near.truncate(4);
    let w: Vec<f64> = near.iter().map(|(c, _)| 1.0 / (1.002 - c)).collect();
    let total: f64 = w.iter().sum();
    near.iter()
        .zip(&w)
        .map(|(&(_, k), &wk)| {
            (
                k,
                s.normal_illuminance * wk / total / sub.patches[k].solid_angle,
            )
        })
        .collect()
}
