//! The one grammar of a sky, as clients give it ([`SkySpec`]), and [`SkyState`], a sky
//! resolved for a site: its luminance distribution, the sun, the ground, and the patch
//! luminances the transfer's sky responses are weighted by.
//!
//! Units: luminance cd/m², illuminance lux, irradiance W/m², angles degrees (altitude above
//! the horizon, azimuth from north clockwise: 90 east, 180 south).

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::daylight::sun_on_patches::nearest_sky_patches;
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

/// Declares the sky enum with the optional `sun` and `time` (never `null`) after each
/// variant's own fields: every sky takes them.
macro_rules! placed_by_sun_or_time {
    ($(#[$m:meta])* pub enum $name:ident {
        $($(#[$vm:meta])* $variant:ident { $($fields:tt)* },)*
    }) => {
        $(#[$m])*
        pub enum $name {
            $($(#[$vm])* $variant {
                $($fields)*
                #[serde(default, deserialize_with = "some")]
                #[cfg_attr(feature = "server", schema(nullable = false))]
                sun: Option<SunPosition>,
                #[serde(default, deserialize_with = "some")]
                #[cfg_attr(feature = "server", schema(nullable = false))]
                time: Option<String>,
            },)*
        }
    };
}

placed_by_sun_or_time! {
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
        },
        /// CIE traditional overcast sky, L(γ) ∝ 1 + 2 sin γ; daylight factors are given
        /// against `horizontal_illuminance`.
        CieOvercast {
            horizontal_illuminance: f64,
        },
        /// CIE clear sky with the sun: `horizontal_illuminance` is the sky's diffuse part
        /// alone, `direct_normal_illuminance` the sun's (lux).
        CieClear {
            horizontal_illuminance: f64,
            direct_normal_illuminance: f64,
        },
        /// Perez all-weather sky from an hour's irradiance (W/m²), luminous efficacy after
        /// Perez 1990; `dew_point` (°C, default 11) sets the precipitable water.
        Perez {
            direct_normal_irradiance: f64,
            diffuse_horizontal_irradiance: f64,
            #[serde(default, deserialize_with = "some")]
            #[cfg_attr(feature = "server", schema(nullable = false))]
            dew_point: Option<f64>,
        },
    }
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

/// `x` when it lies in 0 … `max` (`unit`), else why not: `sky.{what}` is out of range.
fn in_range(x: f64, max: f64, unit: &str, what: &str) -> Result<f64, QueryError> {
    if x.is_finite() && (0.0..=max).contains(&x) {
        Ok(x)
    } else {
        Err(QueryError::Invalid(format!(
            "sky.{what} = {x}: use 0 … {max} {unit}"
        )))
    }
}

fn lux(x: f64, what: &str) -> Result<f64, QueryError> {
    in_range(x, MAX_DAYLIGHT_LUX, "lx", what)
}

fn irradiance(x: f64, what: &str) -> Result<f64, QueryError> {
    in_range(x, MAX_IRRADIANCE, "W/m²", what)
}

/// A dew point, °C, checked (−90 … 60); [`perez::DEFAULT_DEW_POINT_C`] when none is given.
fn dew_point(d: Option<f64>) -> Result<f64, QueryError> {
    match d {
        Some(d) if d.is_finite() && (-90.0..=60.0).contains(&d) => Ok(d),
        Some(d) => Err(QueryError::Invalid(format!(
            "sky.dew_point = {d}: use −90 … 60 °C"
        ))),
        None => Ok(perez::DEFAULT_DEW_POINT_C),
    }
}

/// A sky's luminance distribution, its sun, its diffuse horizontal illuminance (lux) and
/// the reference of its daylight factors.
type Distribution = (Sky, Option<Sun>, f64, Option<f64>);

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
        let (sky, sun, diffuse, df_reference) = self.distribution(placed)?;
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

    /// The sky's distribution with the sun `placed` ([`SkySpec::sun_position`]), its
    /// numbers checked.
    fn distribution(&self, placed: Option<(SunPosition, u32)>) -> Result<Distribution, QueryError> {
        let need_sun = || {
            placed.ok_or_else(|| {
                QueryError::Invalid(format!(
                    "sky of type {}: give the sun (altitude, azimuth) or a time",
                    self.kind()
                ))
            })
        };
        Ok(match *self {
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
                dew_point: dew,
                ..
            } => {
                let dni = irradiance(direct_normal_irradiance, "direct_normal_irradiance")?;
                let dhi = irradiance(
                    diffuse_horizontal_irradiance,
                    "diffuse_horizontal_irradiance",
                )?;
                let dew = dew_point(dew)?;
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
    let mut near = nearest_sky_patches(sub, s.altitude, s.azimuth);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::sky_view;

    /// Mannheim; north is −z; ground reflectance 0.2.
    fn site() -> Site {
        Site::new(49.49, 8.47, 1.0, DVec3::NEG_Z, 0.2).unwrap()
    }

    fn spec(v: serde_json::Value) -> SkySpec {
        serde_json::from_value(v).unwrap()
    }

    fn resolved(v: serde_json::Value) -> SkyState {
        spec(v).resolve(&site()).unwrap()
    }

    fn error(v: serde_json::Value) -> String {
        spec(v).resolve(&site()).unwrap_err().to_string()
    }

    /// A CIE clear sky of 10,000 lx with a sun of 60,000 lx at `altitude` degrees, due
    /// south.
    fn clear(altitude: f64) -> SkyState {
        resolved(
            serde_json::json!({"type": "cie_clear", "horizontal_illuminance": 10000,
            "direct_normal_illuminance": 60000, "sun": {"altitude": altitude, "azimuth": 180}}),
        )
    }

    #[test]
    fn a_uniform_sky_has_luminance_e_over_pi_and_ground_rho_e_over_pi() {
        let pi = std::f64::consts::PI;
        let s = resolved(serde_json::json!({"type": "uniform", "horizontal_illuminance": 10000}));
        assert_eq!(s.kind, "uniform");
        assert_eq!(s.diffuse_horizontal, 10000.0);
        assert_eq!(s.ground_luminance, 0.2 * 10000.0 / pi);
        assert!(s.sun.is_none() && s.df_reference.is_none());
        let l = s.patch_luminances(&sky_view::subdivision());
        assert_eq!(l.len(), 146);
        assert_eq!(l[0], s.ground_luminance);
        for &v in &l[1..] {
            assert!((v - 10000.0 / pi).abs() < 1e-9 * v, "{v}");
        }
    }

    #[test]
    fn the_overcast_sky_is_the_daylight_factor_reference_and_has_no_sun() {
        let s = resolved(
            serde_json::json!({"type": "cie_overcast", "horizontal_illuminance": 12000,
            "sun": {"altitude": 30, "azimuth": 180}}),
        );
        assert_eq!(s.df_reference, Some(12000.0));
        assert!(s.sun.is_none());
        // The position is kept for the answer.
        assert_eq!(
            s.sun_position,
            Some(SunPosition {
                altitude: 30.0,
                azimuth: 180.0
            })
        );
    }

    #[test]
    fn a_clear_sky_adds_the_sun_to_the_global_illuminance() {
        let s = clear(30.0);
        let sun = s.sun.unwrap();
        assert_eq!(sun.normal_illuminance, 60000.0);
        // Global: 10000 + 60000 sin 30° = 40000 lx; the ground ρ E / π.
        let global = 10000.0 + 60000.0 * 30f64.to_radians().sin();
        assert_eq!(s.ground_luminance, 0.2 * global / std::f64::consts::PI);
        // Its scene direction: due south (+z, north being −z), 30° up.
        let (d, en) = s.sun_direction(&site()).unwrap();
        assert_eq!(en, 60000.0);
        assert!(
            (d - DVec3::new(0.0, 0.5, 0.75f64.sqrt())).length() < 1e-12,
            "{d}"
        );
        // Below the horizon: no sun.
        let s = clear(-5.0);
        assert!(s.sun.is_none());
        assert_eq!(s.ground_luminance, 0.2 * 10000.0 / std::f64::consts::PI);
    }

    #[test]
    fn resolve_names_what_is_wrong() {
        use serde_json::json;
        assert_eq!(
            error(
                json!({"type": "cie_clear", "horizontal_illuminance": 1, "direct_normal_illuminance": 1})
            ),
            "sky of type cie_clear: give the sun (altitude, azimuth) or a time"
        );
        assert_eq!(
            error(json!({"type": "uniform", "horizontal_illuminance": 3e5})),
            "sky.horizontal_illuminance = 300000: use 0 … 200000 lx"
        );
        assert_eq!(
            error(json!({"type": "perez", "direct_normal_irradiance": 2000,
                "diffuse_horizontal_irradiance": 100, "sun": {"altitude": 30, "azimuth": 180}})),
            "sky.direct_normal_irradiance = 2000: use 0 … 1500 W/m²"
        );
        assert_eq!(
            error(
                json!({"type": "perez", "direct_normal_irradiance": 200, "dew_point": 61,
                "diffuse_horizontal_irradiance": 100, "sun": {"altitude": 30, "azimuth": 180}})
            ),
            "sky.dew_point = 61: use −90 … 60 °C"
        );
        assert!(error(json!({"type": "uniform", "horizontal_illuminance": 1,
            "sun": {"altitude": 91, "azimuth": 0}}))
        .starts_with("sky.sun.altitude = 91"));
        assert!(error(json!({"type": "uniform", "horizontal_illuminance": 1,
            "sun": {"altitude": 10, "azimuth": 0}, "time": "2026-06-21T12:00"}))
        .contains("not both"));
    }

    #[test]
    fn a_perez_sky_without_diffuse_light_is_dark() {
        let s = resolved(
            serde_json::json!({"type": "perez", "direct_normal_irradiance": 500,
            "diffuse_horizontal_irradiance": 0, "sun": {"altitude": 30, "azimuth": 180}}),
        );
        assert_eq!((s.diffuse_horizontal, s.ground_luminance), (0.0, 0.0));
        assert!(s.sun.is_none());
    }

    #[test]
    fn the_sun_is_spread_over_its_four_nearest_patches_keeping_its_illuminance() {
        let sub = sky_view::subdivision();
        let sun = Sun {
            altitude: 0.6,
            azimuth: 2.5,
            normal_illuminance: 80000.0,
        };
        let spread = sun_patches(&sun, &sub);
        assert_eq!(spread.len(), 4);
        // Each patch's share, lux: the patch the sun is in comes first and carries the
        // most; the shares add up to the sun's normal illuminance.
        let share: Vec<f64> = spread
            .iter()
            .map(|&(k, l)| l * sub.patches[k].solid_angle)
            .collect();
        assert_eq!(spread[0].0, sub.patch_of(0.6, 2.5));
        assert!(share.iter().all(|&e| e > 0.0 && e <= share[0]), "{share:?}");
        let e: f64 = share.iter().sum();
        assert!((e - 80000.0).abs() < 1e-9 * 80000.0, "{e}");
    }
}
