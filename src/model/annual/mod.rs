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
//! Metrics ([`super::daylight_metrics`], with their thresholds and sources), over the
//! occupied hours (local standard time, hours whose middle lies in `[start, end)`):
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
use std::time::Instant;

use faer::{Accum, Mat, Par};
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::daylight_metrics::{self as metrics, PointHours};
pub use super::daylight_metrics::{En17037, Udi};
use super::{Cancel, Model, QueryError};
use crate::color::Rgb;
use crate::daylight::epw::{self, Weather};
use crate::daylight::tregenza::Subdivision;
use crate::transport::sky_view;

mod skies;

use skies::{hour_skies, HourSky, Year};

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

/// Where a year of weather comes from: the name of an EPW file in the scene's folder, or
/// the text of one.
#[derive(Debug, Clone)]
pub enum WeatherSource {
    File(String),
    Text(String),
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

/// A grid's illuminance per point and hour, lx: the matrix product (points × hours) and the
/// direct sun (per point, per hour).
struct Hourly {
    product: Mat<f32>,
    sun: Vec<Vec<f32>>,
}

impl Hourly {
    /// Point `r`'s illuminance in hour `h`, in all.
    fn at(&self, r: usize, h: usize) -> f32 {
        self.product[(r, h)] + self.sun[r][h]
    }

    /// Each point's counts over the occupied hours; `None` for a point `excluded`.
    fn point_hours(&self, excluded: &[bool], occupied: &[bool]) -> Vec<Option<PointHours>> {
        (0..self.sun.len())
            .map(|r| {
                (!excluded[r]).then(|| {
                    let hours = (0..occupied.len()).filter(|&h| occupied[h]);
                    PointHours::count(hours.map(|h| (self.at(r, h), self.sun[r][h])))
                })
            })
            .collect()
    }

    /// EN 17037's minimum level per daylight hour over the `measured` points: the hours
    /// that met the target level and those that met the minimum target level.
    fn en17037_hours(&self, skies: &[HourSky], measured: &[usize]) -> (usize, usize) {
        let (mut target, mut minimum) = (0usize, 0usize);
        let mut col = vec![0f32; measured.len()];
        for (h, s) in skies.iter().enumerate() {
            if !s.daylight || measured.is_empty() {
                continue;
            }
            for (c, &r) in col.iter_mut().zip(measured) {
                *c = self.at(r, h);
            }
            let (t, m) = metrics::en17037_hour(&mut col);
            target += usize::from(t);
            minimum += usize::from(m);
        }
        (target, minimum)
    }
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
                    let d = Rgb::splat(s.direct[i * s.k + k]);
                    let ind = Rgb::column(&s.indirect[k])[i];
                    *o = (r * (d + ind)).to_f64().luminance() as f32;
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
        if let Some(c) = super::lock(&self.annual_cache).get(&gi) {
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
        let mut cache = super::lock(&self.annual_cache);
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
        let w = &q.weather;
        let t0 = Instant::now();
        let skies = hour_skies(w, site.north, site.ground_reflectance, &sub);
        let sky_time = t0.elapsed();
        cancel.check()?;
        let year = Year::new(w, skies, sky_time, q.occupied, sub.patches.len());
        let mut grids = BTreeMap::new();
        for &gi in &q.grids {
            let answer = self.annual_grid(gi, &year, &sub, cancel)?;
            grids.insert(self.grids[gi].grid.id.clone(), answer);
        }
        Ok(AnnualAnswer {
            weather: WeatherInfo {
                city: w.location.city.clone(),
                latitude: w.location.latitude_deg,
                longitude: w.location.longitude_deg,
                timezone: w.location.timezone_h,
                hours: year.hours(),
                occupied_hours: year.occupied_hours,
                daylight_hours: year.daylight_hours,
            },
            grids,
        })
    }

    /// Grid `gi`'s annual metrics over `year`.
    fn annual_grid(
        &self,
        gi: usize,
        year: &Year,
        sub: &Subdivision,
        cancel: &Cancel,
    ) -> Result<AnnualGrid, QueryError> {
        let response = &self.grids[gi];
        let pts = self.grid_receivers(gi);
        let t1 = Instant::now();
        let coef = self.annual_coefficients(gi, &pts, sub, cancel)?;
        let t_coef = t1.elapsed();
        cancel.check()?;
        let hourly = self.hourly(&pts, &coef, year, cancel)?;
        let t_sun = t1.elapsed();
        let points = hourly.point_hours(&response.excluded, &year.occupied);
        let climate = metrics::climate_metrics(&points, year.occupied_hours);
        let measured: Vec<usize> = response.measured().collect();
        let (target, minimum) = hourly.en17037_hours(&year.skies, &measured);
        tracing::info!(
            "annual {}: {} points × {} h: skies {:.0} ms, coefficients {:.0} ms, product and sun {:.0} ms, metrics {:.0} ms",
            response.grid.id,
            pts.len(),
            year.hours(),
            year.sky_time.as_secs_f64() * 1e3,
            t_coef.as_secs_f64() * 1e3,
            (t_sun - t_coef).as_secs_f64() * 1e3,
            (t1.elapsed() - t_sun).as_secs_f64() * 1e3
        );
        Ok(AnnualGrid {
            name: response.grid.name.clone(),
            count: pts.len(),
            excluded: pts.len() - climate.measured,
            sda_300_50: climate.sda,
            ase_1000_250: climate.ase,
            udi: climate.udi,
            en17037: metrics::en17037(target, minimum, year.daylight_hours),
            hours_above_300: points.iter().map(|p| p.map(|p| p.sda_hours)).collect(),
        })
    }

    /// The illuminance at points `pts` every hour of `year`: daylight coefficients `coef`
    /// times the sky matrix, and the direct sun, exact per point and hour.
    fn hourly(
        &self,
        pts: &[(DVec3, DVec3)],
        coef: &Mat<f32>,
        year: &Year,
        cancel: &Cancel,
    ) -> Result<Hourly, QueryError> {
        let hours = year.hours();
        let mut product = Mat::<f32>::zeros(pts.len(), hours);
        faer::linalg::matmul::matmul(
            product.as_mut(),
            Accum::Replace,
            coef.as_ref(),
            year.matrix.as_ref(),
            1.0,
            Par::rayon(0),
        );
        cancel.check()?;
        let sun_hours: Vec<(usize, DVec3, f64)> = year
            .skies
            .iter()
            .enumerate()
            .filter_map(|(h, s)| s.sun.map(|(d, en)| (h, d, en)))
            .collect();
        let reach = self.reach();
        let sun: Vec<Vec<f32>> = pts
            .par_iter()
            .map(|&(x, n)| {
                if cancel.is_cancelled() {
                    return vec![];
                }
                let mut out = vec![0f32; hours];
                for &(h, d, en) in &sun_hours {
                    out[h] = self.sun_at(x, n, (d, en), reach) as f32;
                }
                out
            })
            .collect();
        cancel.check()?;
        Ok(Hourly { product, sun })
    }

    /// The weather of `source`: a file in the scene's folder ([`Model::weather_file`]) or
    /// EPW text, read.
    pub fn weather(&self, source: &WeatherSource) -> Result<Weather, QueryError> {
        match source {
            WeatherSource::File(name) => self.weather_file(name),
            WeatherSource::Text(text) => crate::daylight::epw::parse(text)
                .map_err(|m| QueryError::Invalid(format!("weather: {m}"))),
        }
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
