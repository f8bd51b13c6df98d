//! A year of weather as sky vectors: per hour, the Perez sky at the sky patches' centres
//! (scaled to the diffuse horizontal illuminance), the ground, and the sun spread over its
//! nearest patches, with the sun's exact direction for its direct light; the hours'
//! vectors as one sky matrix, and which hours are occupied.

use std::time::Duration;

use faer::Mat;
use glam::DVec3;

use crate::daylight::epw::{self, Weather};
use crate::daylight::sun::{self, LocalTime};
use crate::daylight::tregenza::Subdivision;
use crate::daylight::{perez, Site};
use crate::model::daylight::sun_on_patches::sky_direction;

/// One hour's sky: patch luminances, the sun spread over patches, and the exact sun.
pub(super) struct HourSky {
    /// Sky and ground (index 0) luminance, then the sun's spread (2K values, cd/m²).
    vector: Vec<f32>,
    /// The sun's scene direction and normal illuminance, lux.
    pub(super) sun: Option<(DVec3, f64)>,
    pub(super) daylight: bool,
}

/// The hours' skies.
pub(super) fn hour_skies(
    w: &Weather,
    north: DVec3,
    ground: f64,
    sub: &Subdivision,
) -> Vec<HourSky> {
    let site = Site::new(
        w.location.latitude_deg,
        w.location.longitude_deg,
        w.location.timezone_h,
        north,
        ground,
    )
    .unwrap_or_else(|_| Site::new(0.0, 0.0, 0.0, DVec3::NEG_Z, 0.2).expect("a valid site"));
    let year = if w.hours.len() == 8784 { 2024 } else { 2026 };
    let centres: Vec<(f64, f64)> = sub.patches.iter().map(|p| p.centre()).collect();
    // Sequential: 8,760 small skies take about 60 ms on one core, steadily; spread over
    // rayon's pool the same work measured 32 ms on a server's first request and 430 ms on
    // every later one.
    w.hours
        .iter()
        .map(|h| hour_sky(h, &site, year, ground, sub, &centres))
        .collect()
}

/// The sky of weather row `h` in `year` at `site` (ground reflectance `ground`); the sky
/// patches' `centres`. Dark for a row without a valid time or without diffuse light.
fn hour_sky(
    h: &epw::Hour,
    site: &Site,
    year: i32,
    ground: f64,
    sub: &Subdivision,
    centres: &[(f64, f64)],
) -> HourSky {
    let k = sub.patches.len();
    let mut vector = vec![0f32; 2 * k];
    let t = LocalTime::new(year, h.month, h.day, h.hour as f64 - 0.5);
    let Ok(t) = t else {
        return HourSky {
            vector,
            sun: None,
            daylight: false,
        };
    };
    let p = sun::position(site, &t);
    let alt = p.altitude_deg.to_radians();
    let daylight = alt > 0.0;
    let dew = h.dew_point_c.unwrap_or(perez::DEFAULT_DEW_POINT_C);
    let Some(c) = perez::conditions(
        h.irradiance.direct_normal,
        h.irradiance.diffuse_horizontal,
        alt,
        t.day_of_year(),
        dew,
    ) else {
        return HourSky {
            vector,
            sun: None,
            daylight,
        };
    };
    let az = p.azimuth_deg.to_radians();
    perez_patches(&c, az, sub, centres, &mut vector[1..k]);
    let direct = if daylight { c.direct_illuminance } else { 0.0 };
    vector[0] = (ground * (c.diffuse_illuminance + direct * alt.sin().max(0.0))
        / std::f64::consts::PI) as f32;
    let mut sun = None;
    if direct > 0.0 {
        let s = crate::daylight::sky_luminance::Sun {
            altitude: alt,
            azimuth: az,
            normal_illuminance: direct,
        };
        for (p, l) in crate::model::sky_state::sun_patches(&s, sub) {
            vector[k + p] += l as f32;
        }
        sun = Some((site.direction(p.altitude_deg, p.azimuth_deg), direct));
    }
    HourSky {
        vector,
        sun,
        daylight,
    }
}

/// The Perez sky of conditions `c` (the sun at azimuth `sun_azimuth`, radians) at the sky
/// patches' centres (`centres`, the ground first), cd/m², into `out` (one per sky patch):
/// scaled so that the patches give the diffuse horizontal illuminance.
fn perez_patches(
    c: &perez::Conditions,
    sun_azimuth: f64,
    sub: &Subdivision,
    centres: &[(f64, f64)],
    out: &mut [f32],
) {
    let sun_alt = std::f64::consts::FRAC_PI_2 - c.sun_zenith;
    let rel: Vec<f64> = centres[1..]
        .iter()
        .map(|&(a, z)| {
            let gamma = angle((a, z), (sun_alt, sun_azimuth));
            perez::relative_luminance(&c.params, std::f64::consts::FRAC_PI_2 - a, gamma)
        })
        .collect();
    let eh: f64 = rel
        .iter()
        .zip(&sub.patches[1..])
        .map(|(l, p)| l * p.solid_angle * p.centre().0.sin())
        .sum();
    let scale = if eh > 0.0 {
        c.diffuse_illuminance / eh
    } else {
        0.0
    };
    for (o, l) in out.iter_mut().zip(&rel) {
        *o = (l * scale) as f32;
    }
}

/// Angle between two sky positions (altitude, azimuth), radians.
fn angle(a: (f64, f64), b: (f64, f64)) -> f64 {
    let d = |(al, az): (f64, f64)| sky_direction(al, az);
    d(a).dot(d(b)).clamp(-1.0, 1.0).acos()
}

/// The year's skies as every grid shares them.
pub(super) struct Year {
    pub(super) skies: Vec<HourSky>,
    /// The sky matrix, 2K × hours.
    pub(super) matrix: Mat<f32>,
    /// Per hour: whether it is occupied.
    pub(super) occupied: Vec<bool>,
    pub(super) occupied_hours: usize,
    /// Hours with the sun above the horizon.
    pub(super) daylight_hours: usize,
    /// How long the skies took.
    pub(super) sky_time: Duration,
}

impl Year {
    /// The skies of weather `w` (taking `sky_time`) with the occupied hours of the day
    /// `[start, end)`, for `k` sky patches.
    pub(super) fn new(
        w: &Weather,
        skies: Vec<HourSky>,
        sky_time: Duration,
        (start, end): (f64, f64),
        k: usize,
    ) -> Year {
        let occupied: Vec<bool> = w
            .hours
            .iter()
            .map(|h| {
                let mid = h.hour as f64 - 0.5;
                mid >= start && mid < end
            })
            .collect();
        Year {
            occupied_hours: occupied.iter().filter(|&&o| o).count(),
            daylight_hours: skies.iter().filter(|s| s.daylight).count(),
            matrix: Mat::<f32>::from_fn(2 * k, skies.len(), |r, c| skies[c].vector[r]),
            occupied,
            skies,
            sky_time,
        }
    }

    pub(super) fn hours(&self) -> usize {
        self.skies.len()
    }
}
