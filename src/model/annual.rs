//! Annual, climate-based daylight metrics on calculation grids, from an EPW weather file.
//!
//! Every hour of the year is one matrix product: per grid point, daylight coefficients
//! `[C | S]` (2K numbers, lux per cd/m²) times the hour's sky vector `[L | s]`:
//! - `C_k` is what sky patch k at unit luminance gives the point: its direct view of the
//!   patch (the point's traced [`SkyView`] binned into patches) plus the interreflected
//!   light gathered from the transfer's sky responses;
//! - `S_k` is the interreflected part alone, for the sun spread over its nearest patches
//!   (`s`, as Radiance's `gendaymtx` spreads it);
//! - `L_k` is the hour's Perez sky at the patch centres, scaled to the diffuse horizontal
//!   illuminance, and the ground (ρg · E_global_horizontal / π).
//!
//! The sun's direct light is exact: one shadow ray per point and sunlit hour. The sun's
//! position is computed at the middle of each hour (EPW rows are the hours ending then) for
//! the weather file's location, in the scene's orientation (its `north`).
//!
//! Metrics, over the occupied hours (local standard time, hours whose middle lies in
//! `[start, end)`):
//! - sDA300/50 %: the share of points with at least 300 lx for at least half the hours;
//! - ASE1000,250h: the share of points with direct sunlight alone of at least 1000 lx for
//!   more than 250 hours;
//! - UDI: the mean share of hours below 100 lx, 100–3000 lx and above 3000 lx;
//! - per point, the hours with at least 300 lx.
//!
//! And EN 17037's minimum level over the daylight hours (sun above the horizon): the share
//! of hours in which half the grid gets at least 300 lx, and 95 % of it at least 100 lx;
//! the check passes when both shares are at least 50 %. No blinds or dynamic shading are
//! modelled.

use std::collections::BTreeMap;
use std::sync::Arc;

use faer::{Accum, Mat, Par};
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::{Cancel, Model, QueryError};
use crate::color::luminance64;
use crate::daylight::epw::{self, Weather};
use crate::daylight::sun::{self, LocalTime};
use crate::daylight::tregenza::Subdivision;
use crate::daylight::{perez, Site};
use crate::transport::sky_view;

/// Most grid points one annual request may ask for (its hourly values take
/// 35 kB each).
pub const MAX_ANNUAL_POINTS: usize = 5000;

/// Most bytes of daylight coefficients a scene keeps (about 7,000 grid points).
pub const ANNUAL_CACHE_BYTES: usize = 8 << 20;

/// What to compute.
#[derive(Debug, Clone)]
pub struct AnnualQuery {
    pub weather: Arc<Weather>,
    pub grids: Vec<usize>,
    /// Occupied hours of the day, [start, end) in hours (8.0, 18.0).
    pub occupied: (f64, f64),
}

/// The weather used.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct WeatherInfo {
    pub city: String,
    /// Degrees north.
    pub latitude: f64,
    /// Degrees east.
    pub longitude: f64,
    /// Hours east of UTC.
    pub timezone: f64,
    /// Rows of the file (8,760 or 8,784).
    pub hours: usize,
    /// Hours in the occupied period.
    pub occupied_hours: usize,
    /// Hours with the sun above the horizon.
    pub daylight_hours: usize,
}

/// Useful daylight illuminance: the mean share of occupied hours per band, percent.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct Udi {
    pub below_100: f64,
    pub from_100_to_3000: f64,
    pub above_3000: f64,
}

/// EN 17037's minimum-level check.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct En17037 {
    /// Share of daylight hours with at least 300 lx over half the grid, percent.
    pub hours_300_lx_over_50_percent: f64,
    /// Share of daylight hours with at least 100 lx over 95 % of the grid, percent.
    pub hours_100_lx_over_95_percent: f64,
    /// Both shares at least 50 %.
    pub minimum_level_met: bool,
}

/// One grid's annual metrics.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct AnnualGrid {
    pub name: String,
    pub count: usize,
    /// sDA300/50 %, percent of points.
    pub sda_300_50: f64,
    /// ASE1000,250h, percent of points.
    pub ase_1000_250: f64,
    pub udi: Udi,
    pub en17037: En17037,
    /// Points left out of the metrics (inside objects; null in `hours_above_300`).
    pub excluded: usize,
    /// Per point, occupied hours with at least 300 lx, in grid order; null for points
    /// left out.
    #[cfg_attr(feature = "server", schema(value_type = Vec<Option<u32>>))]
    pub hours_above_300: Vec<Option<u32>>,
}

/// Annual answers.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema), schema(as = AnnualResponse))]
pub struct AnnualAnswer {
    pub weather: WeatherInfo,
    /// By grid id.
    pub grids: BTreeMap<String, AnnualGrid>,
}

/// One hour's sky: patch luminances, the sun spread over patches, and the exact sun.
struct HourSky {
    /// Sky and ground (index 0) luminance, then the sun's spread (2K values, cd/m²).
    vector: Vec<f32>,
    /// The sun's scene direction and normal illuminance, lux.
    sun: Option<(DVec3, f64)>,
    daylight: bool,
}

/// The hours' skies.
fn hour_skies(w: &Weather, north: DVec3, ground: f64, sub: &Subdivision) -> Vec<HourSky> {
    let k = sub.patches.len();
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
        .map(|h| {
            let mut vector = vec![0f32; 2 * k];
            let t = LocalTime::new(year, h.month, h.day, h.hour as f64 - 0.5);
            let Ok(t) = t else {
                return HourSky {
                    vector,
                    sun: None,
                    daylight: false,
                };
            };
            let p = sun::position(&site, &t);
            let alt = p.altitude_deg.to_radians();
            let daylight = alt > 0.0;
            let dew = h.dew_point_c.unwrap_or(perez::DEFAULT_DEW_POINT_C);
            let Some(c) = perez::conditions(
                h.direct_normal_irradiance,
                h.diffuse_horizontal_irradiance,
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
            // The Perez sky at the patch centres, scaled so the patches give the diffuse
            // horizontal illuminance.
            let az = p.azimuth_deg.to_radians();
            let sun_alt = std::f64::consts::FRAC_PI_2 - c.sun_zenith;
            let rel: Vec<f64> = centres[1..]
                .iter()
                .map(|&(a, z)| {
                    let gamma = angle((a, z), (sun_alt, az));
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
            for (i, l) in rel.iter().enumerate() {
                vector[i + 1] = (l * scale) as f32;
            }
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
                for (p, l) in super::sky_state::sun_patches(&s, sub) {
                    vector[k + p] += l as f32;
                }
                sun = Some((site.direction(p.altitude_deg, p.azimuth_deg), direct));
            }
            HourSky {
                vector,
                sun,
                daylight,
            }
        })
        .collect()
}

/// Angle between two sky positions (altitude, azimuth), radians.
fn angle(a: (f64, f64), b: (f64, f64)) -> f64 {
    let d = |(al, az): (f64, f64)| DVec3::new(al.cos() * az.sin(), al.cos() * az.cos(), al.sin());
    d(a).dot(d(b)).clamp(-1.0, 1.0).acos()
}

impl Model {
    /// Per patch and sky patch, the luminous radiosity at unit sky-patch luminance
    /// (n × K): `Y(ρ (D_k + I_k))`.
    fn sky_radiosity(&self) -> &[f32] {
        self.annual_radiosity.get_or_init(|| {
            let t = &self.baked.transfer;
            let Some(s) = &t.sky else {
                return vec![];
            };
            let mut out = vec![0f32; t.n * s.k];
            out.par_chunks_mut(s.k).enumerate().for_each(|(i, row)| {
                let r = t.rho[i];
                for (k, o) in row.iter_mut().enumerate() {
                    let d = s.direct[i * s.k + k];
                    let ind = &s.indirect[k][3 * i..3 * i + 3];
                    *o = luminance64(std::array::from_fn(|c| (r[c] * (d + ind[c])) as f64)) as f32;
                }
            });
            out
        })
    }

    /// A grid's daylight coefficients `[C | S]` (points × 2K), cached per grid while they
    /// fit in [`ANNUAL_CACHE_BYTES`].
    fn annual_coefficients(
        &self,
        gi: usize,
        pts: &[(DVec3, DVec3)],
        sub: &Subdivision,
        cancel: &Cancel,
    ) -> Result<Arc<Mat<f32>>, QueryError> {
        if let Some(c) = self
            .annual_cache
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get(&gi)
        {
            return Ok(c.clone());
        }
        let site = self.site()?;
        let k = sub.patches.len();
        let radiosity = self.sky_radiosity();
        let gathers = self.gathers(pts, cancel)?;
        let rows: Vec<Vec<f32>> = gathers
            .par_iter()
            .map(|g| {
                let mut row = vec![0f32; 2 * k];
                for &(j, wj) in &g.weights {
                    let r = &radiosity[j as usize * k..(j as usize + 1) * k];
                    for (o, &v) in row[k..].iter_mut().zip(r) {
                        *o += wj * v;
                    }
                }
                let direct = g
                    .view
                    .as_ref()
                    .map(|v| v.binned(site, sub))
                    .unwrap_or_else(|| vec![0.0; k]);
                for i in 0..k {
                    row[i] = direct[i] + row[k + i];
                }
                row
            })
            .collect();
        cancel.check()?;
        let coef = Arc::new(Mat::<f32>::from_fn(pts.len(), 2 * k, |r, c| rows[r][c]));
        let mut cache = self.annual_cache.lock().unwrap_or_else(|p| p.into_inner());
        let held: usize = cache.values().map(|m| 4 * m.nrows() * m.ncols()).sum();
        if held + 4 * pts.len() * 2 * k <= ANNUAL_CACHE_BYTES {
            cache.insert(gi, coef.clone());
        }
        Ok(coef)
    }

    /// Peak bytes of an annual query over `grids` and `hours` hours of weather: the hourly
    /// values and direct sun per point, the sky matrix, the gathers.
    pub fn annual_bytes(&self, grids: &[usize], hours: usize) -> u64 {
        let points: u64 = grids.iter().map(|&g| self.grids[g].len() as u64).sum();
        let hours = hours as u64;
        points * hours * 9
            + hours * 2400
            + (4 << 20)
            + self.daylight_bytes(&super::query::IlluminanceQuery {
                grids: grids.to_vec(),
                ..Default::default()
            })
    }

    /// The annual metrics of the query's grids.
    pub fn annual(&self, q: &AnnualQuery, cancel: &Cancel) -> Result<AnnualAnswer, QueryError> {
        let site = self.site()?;
        let total: usize = q.grids.iter().map(|&g| self.grids[g].len()).sum();
        if total > MAX_ANNUAL_POINTS {
            return Err(QueryError::Invalid(format!(
                "the grids have {total} points; an annual request may ask for at most {MAX_ANNUAL_POINTS}"
            )));
        }
        let sub = sky_view::subdivision();
        let k = sub.patches.len();
        let w = &q.weather;
        let t0 = std::time::Instant::now();
        let skies = hour_skies(w, site.north, site.ground_reflectance, &sub);
        let t_sky = t0.elapsed();
        cancel.check()?;
        let hours = skies.len();
        let occupied: Vec<bool> = w
            .hours
            .iter()
            .map(|h| {
                let mid = h.hour as f64 - 0.5;
                mid >= q.occupied.0 && mid < q.occupied.1
            })
            .collect();
        let occ_hours = occupied.iter().filter(|&&o| o).count();
        let day_hours = skies.iter().filter(|s| s.daylight).count();
        // The sky matrix, 2K × hours.
        let sky_m = Mat::<f32>::from_fn(2 * k, hours, |r, c| skies[c].vector[r]);
        let reach = self.reach();
        let mut grids = BTreeMap::new();
        for &gi in &q.grids {
            let grid = &self.grids[gi].grid;
            let pts = self.grid_receivers(gi);
            let t1 = std::time::Instant::now();
            let coef = self.annual_coefficients(gi, &pts, &sub, cancel)?;
            let t_gather = t1.elapsed();
            let p = pts.len();
            cancel.check()?;
            let t_coef = t_gather;
            let mut e = Mat::<f32>::zeros(p, hours);
            faer::linalg::matmul::matmul(
                e.as_mut(),
                Accum::Replace,
                coef.as_ref(),
                sky_m.as_ref(),
                1.0,
                Par::rayon(0),
            );
            cancel.check()?;
            // The direct sun, exact per point and hour; the columns of `e` are per hour.
            let sun_hours: Vec<(usize, DVec3, f64)> = skies
                .iter()
                .enumerate()
                .filter_map(|(h, s)| s.sun.map(|(d, en)| (h, d, en)))
                .collect();
            let direct_sun: Vec<Vec<f32>> = pts
                .par_iter()
                .map(|&(x, n)| {
                    if cancel.is_cancelled() {
                        return vec![];
                    }
                    let mut out = vec![0f32; hours];
                    for &(h, d, en) in &sun_hours {
                        out[h] = sky_view::point_sun_direct(
                            &self.baked.bvh,
                            &self.baked.glazing,
                            x,
                            n,
                            d,
                            en,
                            reach,
                        ) as f32;
                    }
                    out
                })
                .collect();
            cancel.check()?;
            let t_sun = t1.elapsed();
            // Per point metrics.
            let mut sda = 0usize;
            let mut ase = 0usize;
            let mut udi = [0f64; 3];
            let mut above_300 = Vec::with_capacity(p);
            let excluded = &self.grids[gi].excluded;
            let measured: Vec<usize> = self.grids[gi].measured().collect();
            let m = measured.len();
            for (r, ds) in direct_sun.iter().enumerate() {
                if excluded[r] {
                    above_300.push(None);
                    continue;
                }
                let (mut n300, mut nsun, mut bands) = (0u32, 0u32, [0u32; 3]);
                for h in 0..hours {
                    if !occupied[h] {
                        continue;
                    }
                    let v = e[(r, h)] + ds[h];
                    n300 += u32::from(v >= 300.0);
                    nsun += u32::from(ds[h] >= 1000.0);
                    bands[if v < 100.0 {
                        0
                    } else if v <= 3000.0 {
                        1
                    } else {
                        2
                    }] += 1;
                }
                if occ_hours > 0 && 2 * n300 as usize >= occ_hours {
                    sda += 1;
                }
                if nsun > 250 {
                    ase += 1;
                }
                for b in 0..3 {
                    udi[b] += bands[b] as f64 / occ_hours.max(1) as f64;
                }
                above_300.push(Some(n300));
            }
            // EN 17037 per daylight hour: the median and the 5th percentile of the grid.
            let (mut h300, mut h100) = (0usize, 0usize);
            let mut col = vec![0f32; m];
            for (h, s) in skies.iter().enumerate() {
                if !s.daylight || m == 0 {
                    continue;
                }
                for (c, &r) in col.iter_mut().zip(&measured) {
                    *c = e[(r, h)] + direct_sun[r][h];
                }
                col.sort_by(f32::total_cmp);
                // At least half the points ≥ 300: the point at rank ⌊m/2⌋ from the top.
                if col[m - m.div_ceil(2)] >= 300.0 {
                    h300 += 1;
                }
                // At least 95 % ≥ 100.
                if col[m - (0.95 * m as f64).ceil() as usize] >= 100.0 {
                    h100 += 1;
                }
            }
            tracing::info!(
                "annual {}: {p} points × {hours} h: skies {:.0} ms, coefficients {:.0} ms, product and sun {:.0} ms, metrics {:.0} ms",
                grid.id,
                t_sky.as_secs_f64() * 1e3,
                t_gather.as_secs_f64() * 1e3,
                (t_sun - t_coef).as_secs_f64() * 1e3,
                (t1.elapsed() - t_sun).as_secs_f64() * 1e3
            );
            let pct = |a: usize, b: usize| 100.0 * a as f64 / b.max(1) as f64;
            let (s300, s100) = (pct(h300, day_hours), pct(h100, day_hours));
            grids.insert(
                grid.id.clone(),
                AnnualGrid {
                    name: grid.name.clone(),
                    count: p,
                    excluded: p - m,
                    sda_300_50: pct(sda, m),
                    ase_1000_250: pct(ase, m),
                    udi: Udi {
                        below_100: 100.0 * udi[0] / m.max(1) as f64,
                        from_100_to_3000: 100.0 * udi[1] / m.max(1) as f64,
                        above_3000: 100.0 * udi[2] / m.max(1) as f64,
                    },
                    en17037: En17037 {
                        hours_300_lx_over_50_percent: s300,
                        hours_100_lx_over_95_percent: s100,
                        minimum_level_met: s300 >= 50.0 && s100 >= 50.0,
                    },
                    hours_above_300: above_300,
                },
            );
        }
        Ok(AnnualAnswer {
            weather: WeatherInfo {
                city: w.location.city.clone(),
                latitude: w.location.latitude_deg,
                longitude: w.location.longitude_deg,
                timezone: w.location.timezone_h,
                hours,
                occupied_hours: occ_hours,
                daylight_hours: day_hours,
            },
            grids,
        })
    }

    /// The weather file `name` in the scene's folder: a plain file name ending in `.epw`,
    /// a regular file inside the folder, at most [`epw::MAX_EPW_BYTES`].
    pub fn weather_file(&self, name: &str) -> Result<Weather, QueryError> {
        let bad = |m: String| {
            QueryError::Invalid(format!("weather '{}': {m}", super::error::shorten(name)))
        };
        let plain = !name.is_empty()
            && name.len() <= 255
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-' | ' '))
            && !name.starts_with('.')
            && name.to_ascii_lowercase().ends_with(".epw");
        if !plain {
            return Err(bad(
                "give the name of an .epw file in the scene's folder (letters, digits, . _ - and spaces), or the EPW text itself".into(),
            ));
        }
        let dir = std::fs::canonicalize(&self.baked.scene.dir)
            .map_err(|_| bad("the scene's folder cannot be read".into()))?;
        let path = dir.join(name);
        let real = std::fs::canonicalize(&path)
            .map_err(|_| bad("no such file in the scene's folder".into()))?;
        if !real.starts_with(&dir) {
            return Err(bad("is outside the scene's folder".into()));
        }
        let bytes =
            crate::scene::read_file_bounded(&real, epw::MAX_EPW_BYTES as u64).map_err(&bad)?;
        epw::parse_bytes(&bytes).map_err(bad)
    }
}
