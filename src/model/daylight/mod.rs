//! Daylight queries, and the point-gather cache every point query shares.
//!
//! A sky relights the scene as a weighted sum of the transfer's sky responses
//! ([`crate::transport::transfer::SkyColumns`]): each patch's illuminance is
//! `H = Σ_k L_k (D_k + I_k)` over the sky patches' mean luminances `L_k`, plus the sun:
//! its direct light with shadow rays at every patch, and its interreflected light through
//! the responses of the sky patches nearest to it. Radiosity is `B = ρ H`.
//!
//! A point's illuminance is exact where accuracy needs it: the direct sky is integrated
//! against the continuous sky luminance over the rays that leave the scene from the point
//! ([`SkyView`](crate::transport::sky_view::SkyView)), the sun gets one shadow ray, and
//! the interreflected light is gathered from `B` with the point's cached gather weights.
//!
//! The parts: [`gather`] is the point-gather cache every point query shares (a point set's
//! gather weights, sky views and daylight coefficients), [`patches`] a sky's daylight on
//! every patch with the sun's light, [`points`] the light at points, and this file the
//! answers built from them.

use std::collections::BTreeMap;

use glam::DVec3;
use serde::Serialize;

use super::daylight_metrics as metrics;
pub use super::daylight_metrics::DaylightFactors;
use super::grid::{self, GridStats};
use super::query::{GridAnswer, IlluminanceQuery};
use super::report::SurfaceIlluminance;
use super::sky_state::{SkyState, SunPosition};
use super::{Cancel, Lighting, Model, QueryError};
use crate::color::Rgb64;
use crate::daylight::Site;
use crate::transport::sky_view::{self, Reach};

mod electric;
mod gather;
mod patches;
mod points;

use electric::ElectricLight;
pub mod sun_on_patches;

pub use gather::{
    GatherCache, PointGather, GATHER_CACHE_MAX_BYTES, GATHER_CACHE_MIN_BYTES, GATHER_CACHE_POINTS,
    SUN_CACHE_ENTRIES,
};
pub use patches::PatchDaylight;
use patches::SunLight;
use points::PointLight;

/// One grid under a sky: illuminance statistics (lux) and, for the CIE overcast sky,
/// daylight factors.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct DaylightGrid {
    /// Illuminance statistics and values, lx.
    pub illuminance: GridAnswer,
    /// Null unless the sky is `cie_overcast`.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub daylight_factor: Option<DaylightFactors>,
}

/// One point under a sky.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct DaylightPoint {
    /// Luminous illuminance, lx (daylight plus any electric light asked for).
    pub lux: f64,
    /// Per channel, lx.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub rgb: Rgb64,
    /// 100 · E_daylight / E_horizontal, percent, for the CIE overcast sky; else null.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub daylight_factor: Option<f64>,
}

/// The sky as it was resolved.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct SkyInfo {
    /// `uniform`, `cie_overcast`, `cie_clear` or `perez`.
    #[serde(rename = "type")]
    pub kind: &'static str,
    /// The sun's position (degrees), when given or derived from a time; null otherwise.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub sun: Option<SunPosition>,
    /// The sun's direct normal illuminance, lx (0 without a sun above the horizon).
    pub direct_normal_illuminance: f64,
    /// The sky's diffuse illuminance on an unobstructed horizontal plane, lx.
    pub diffuse_horizontal_illuminance: f64,
    /// Diffuse plus direct on an unobstructed horizontal plane, lx.
    pub global_horizontal_illuminance: f64,
    /// Luminance of the ground outside the model, cd/m².
    pub ground_luminance: f64,
}

/// Daylight answers, lux.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema), schema(as = DaylightResponse))]
pub struct DaylightAnswer {
    /// Always `"lx"`.
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::lx))]
    pub unit: &'static str,
    pub sky: SkyInfo,
    /// In request order.
    pub points: Vec<DaylightPoint>,
    /// By surface id.
    pub surfaces: BTreeMap<String, SurfaceIlluminance>,
    /// By grid id.
    pub grids: BTreeMap<String, DaylightGrid>,
    /// The maintenance factor MF of each light group; empty without electric light.
    pub maintenance_factors: BTreeMap<String, f64>,
    /// With electric light in the state, the same answers with each group's light × its
    /// MF (daylight unchanged); null without.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub maintained: Option<super::query::Maintained>,
}
impl Model {
    /// The scene's site, or why daylight cannot be asked of it.
    pub fn site(&self) -> Result<&Site, QueryError> {
        match (&self.baked.scene.site, &self.baked.transfer.sky) {
            (Some(s), Some(_)) => Ok(s),
            _ => Err(QueryError::Invalid(format!(
                "scene '{}' has no [site] in its scene.toml, so it has no daylight",
                self.baked.scene.id
            ))),
        }
    }

    /// The points of grid `gi` with the grid's normal.
    pub(super) fn grid_receivers(&self, gi: usize) -> Vec<(DVec3, DVec3)> {
        let grid = &self.grids[gi].grid;
        let n = DVec3::from_array(grid.normal);
        grid.points
            .iter()
            .map(|p| (DVec3::from_array(*p), n))
            .collect()
    }

    /// The sun's direct illuminance (lux) at point `x` (m) on a receiver facing `n`: the
    /// sun in unit scene direction `d` at normal illuminance `en`, with one shadow ray
    /// (through the glazing) out to `reach`.
    pub(super) fn sun_at(&self, x: DVec3, n: DVec3, (d, en): (DVec3, f64), reach: Reach) -> f64 {
        sky_view::point_sun_direct(&self.baked.bvh, &self.baked.glazing, x, n, d, en, reach)
    }

    pub(super) fn reach(&self) -> Reach {
        let (lo, hi) = self.baked.scene.bounds();
        Reach::new(lo, hi)
    }

    /// A length beyond the scene, m (for escape rays).
    pub fn reach_length(&self) -> f64 {
        self.reach().length()
    }

    /// Peak bytes a daylight query may allocate.
    pub fn daylight_bytes(&self, q: &IlluminanceQuery) -> u64 {
        let grid_points: u64 = q.grids.iter().map(|&g| self.grids[g].len() as u64).sum();
        let per_point = 8 * self.patches() as u64 + 64 * 1024;
        64 * self.patches() as u64 + per_point * (q.points.len() as u64 + grid_points)
    }

    /// Daylight (plus the electric light of a lighting state: group weights, a per-patch
    /// emission, or luminaires placed for the request) on surfaces, at points and on grids.
    pub fn daylight(
        &self,
        sky: &SkyState,
        electric: Option<&Lighting>,
        q: &IlluminanceQuery,
        cancel: &Cancel,
    ) -> Result<DaylightAnswer, QueryError> {
        let (site, l, sun_light) = self.sky_light(sky)?;
        let Some(lighting) = electric else {
            let light = PointLight::new(self, sky, site, &l, &sun_light, None);
            return self.daylight_once(&light, q, cancel);
        };
        let el = ElectricLight::new(self, lighting)?;
        let light = PointLight::new(self, sky, site, &l, &sun_light, Some(&el));
        let mut answer = self.daylight_once(&light, q, cancel)?;
        // The maintained answer: the electric light under the maintenance factors, the
        // daylight unchanged (the sky, the sun and the gathers are the first's).
        let factors = self.factors(q);
        let groups = self.baked.scene.lights.iter().map(|g| g.id.clone());
        let maintained = match lighting {
            Lighting::Groups(w) => {
                answer.maintenance_factors = groups.zip(factors.groups.clone()).collect();
                let wm = super::compliance::maintained_weights(w, &factors.groups);
                ElectricLight::owned(self, Lighting::Groups(wm))?
            }
            Lighting::Emission(_) => {
                answer.maintenance_factors = [("emission".to_string(), factors.emission)].into();
                el.scaled(factors.emission)
            }
            Lighting::Placed(p) => {
                answer.maintenance_factors = groups
                    .zip(factors.groups.clone())
                    .chain([("placed".to_string(), factors.emission)])
                    .collect();
                match p.common_factor(&factors.groups, factors.emission) {
                    Some(mf) => el.scaled(mf),
                    None => {
                        let pm = p.maintained(&factors.groups, factors.emission);
                        ElectricLight::owned(self, Lighting::Placed(pm))?
                    }
                }
            }
        };
        let light = PointLight::new(self, sky, site, &l, &sun_light, Some(&maintained));
        let m = self.daylight_once(&light, q, cancel)?;
        answer.maintained = Some(super::query::Maintained {
            points: m
                .points
                .iter()
                .map(|p| super::report::Lux::new(p.rgb))
                .collect(),
            surfaces: m.surfaces,
            grids: m
                .grids
                .into_iter()
                .map(|(k, g)| (k, g.illuminance))
                .collect(),
        });
        Ok(answer)
    }

    /// [`Model::daylight`] without the maintained answers, for the light of one sky and one
    /// set of group weights.
    fn daylight_once(
        &self,
        light: &PointLight,
        q: &IlluminanceQuery,
        cancel: &Cancel,
    ) -> Result<DaylightAnswer, QueryError> {
        let points = light
            .at_points(&q.points, cancel)?
            .into_iter()
            .map(|(e, daylight)| DaylightPoint {
                lux: e.luminance(),
                rgb: e,
                daylight_factor: light.daylight_factor(daylight),
            })
            .collect();
        let mut grids = BTreeMap::new();
        for &gi in &q.grids {
            cancel.check()?;
            let answer = self.daylight_grid(gi, light, cancel)?;
            grids.insert(self.grids[gi].grid.id.clone(), answer);
        }
        cancel.check()?;
        Ok(DaylightAnswer {
            unit: "lx",
            sky: SkyInfo::of(light.sky),
            points,
            surfaces: self.daylight_surfaces(&q.surfaces, light.l, light.sun_light, light.electric),
            grids,
            maintenance_factors: BTreeMap::new(),
            maintained: None,
        })
    }

    /// Grid `gi` under the sky of `light`: its illuminance and, for the CIE overcast sky,
    /// its daylight factors.
    fn daylight_grid(
        &self,
        gi: usize,
        light: &PointLight,
        cancel: &Cancel,
    ) -> Result<DaylightGrid, QueryError> {
        let response = &self.grids[gi];
        let pts = self.grid_receivers(gi);
        let (values, dfs): (Vec<f32>, Vec<f32>) = light
            .at_points(&pts, cancel)?
            .into_iter()
            .map(|(e, daylight)| {
                let df = light.daylight_factor(daylight).unwrap_or(0.0);
                (e.luminance() as f32, df as f32)
            })
            .unzip();
        let excluded = &response.excluded;
        let stats: GridStats = grid::stats(values, excluded);
        let daylight_factor =
            (light.sky.df_reference).map(|_| metrics::daylight_factors(&dfs, excluded));
        Ok(DaylightGrid {
            illuminance: super::query::grid_answer(&response.grid, stats),
            daylight_factor,
        })
    }

    /// Illuminance statistics of `surfaces` under sky patch luminances `l` and the sun's
    /// light, plus the electric light `el`.
    fn daylight_surfaces(
        &self,
        surfaces: &[usize],
        l: &[f64],
        sun_light: &SunLight,
        el: Option<&ElectricLight>,
    ) -> BTreeMap<String, SurfaceIlluminance> {
        if surfaces.is_empty() {
            return BTreeMap::new();
        }
        // Per-patch illuminance for the surfaces' statistics.
        let mut h = self.sky_patches(l, sun_light, true).h;
        if let Some(el) = el {
            for (a, b) in h.iter_mut().zip(&el.h) {
                *a += b * el.scale as f32;
            }
        }
        self.surface_stats(surfaces, &h)
    }
}

impl SkyInfo {
    /// The sky as it was resolved.
    fn of(sky: &SkyState) -> SkyInfo {
        let en = sky.sun.map_or(0.0, |s| s.normal_illuminance);
        SkyInfo {
            kind: sky.kind,
            sun: sky.sun_position,
            direct_normal_illuminance: en,
            diffuse_horizontal_illuminance: sky.diffuse_horizontal,
            global_horizontal_illuminance: sky.diffuse_horizontal
                + sky.sun.map_or(0.0, |s| en * s.altitude.sin()),
            ground_luminance: sky.ground_luminance,
        }
    }
}
