//! The light at points under one sky: the direct sky through each point's sky view, the
//! sun by one shadow ray, and the reflected light through the gather weights and daylight
//! coefficients of the point-gather cache.

use glam::DVec3;
use rayon::prelude::*;

use super::electric::ElectricLight;
use super::gather::PointGather;
use super::patches::SunLight;
use crate::color::Rgb64;
use crate::daylight::Site;
use crate::model::sky_state::SkyState;
use crate::model::{Cancel, Model, QueryError};
use crate::transport::sky_view::Reach;
use crate::transport::transfer::SkyColumns;

/// What the light at a point needs under one sky: the sky patch luminances and the sun's
/// light, the electric light of group weights `w` when asked.
pub(super) struct PointLight<'a> {
    model: &'a Model,
    pub(super) sky: &'a SkyState,
    site: &'a Site,
    cols: &'a SkyColumns,
    /// Sky patch luminances, cd/m² (0 the ground).
    pub(super) l: &'a [f64],
    /// The sun's light: its spread over the sky patches and its direct light on patches.
    pub(super) sun_light: &'a SunLight,
    /// [`Model::sun_reflected`].
    sun_b: Option<Vec<f32>>,
    /// The sun's scene direction and normal illuminance.
    sun: Option<(DVec3, f64)>,
    reach: Reach,
    /// The electric light added, if any.
    pub(super) electric: Option<&'a ElectricLight<'a>>,
}

impl<'a> PointLight<'a> {
    pub(super) fn new(
        model: &'a Model,
        sky: &'a SkyState,
        site: &'a Site,
        l: &'a [f64],
        sun_light: &'a SunLight,
        electric: Option<&'a ElectricLight<'a>>,
    ) -> PointLight<'a> {
        let t = &model.baked.transfer;
        PointLight {
            model,
            sky,
            site,
            cols: t.sky.as_ref().expect("site() checks the sky responses"),
            l,
            sun_light,
            sun_b: model.sun_reflected(sun_light),
            sun: sky.sun_direction(site),
            reach: model.reach(),
            electric,
        }
    }

    /// The light at point `x` (m) facing `nrm` with gather `g`: (all light, daylight
    /// alone), RGB lux.
    fn at(&self, g: &PointGather, x: DVec3, nrm: DVec3) -> (Rgb64, f64) {
        let m = self.model;
        let mut e = g.reflected(
            self.cols,
            &m.baked.transfer.rho,
            self.l,
            &self.sun_light.spread,
        );
        if let Some(b) = &self.sun_b {
            e += g.gather(b);
        }
        let mut direct = g.direct_sky(self.sky, self.site);
        if let Some(sun) = self.sun {
            direct += m.sun_at(x, nrm, sun, self.reach);
        }
        e += Rgb64::splat(direct);
        let daylight = e.luminance();
        if let Some(el) = self.electric {
            e += (g.gather(&el.b) + el.direct_at(m, x, nrm)) * el.scale;
        }
        (e, daylight)
    }

    /// The light at `points` (position m, unit normal), gathered in parallel: (all light,
    /// daylight alone) per point, as [`PointLight::at`].
    pub(super) fn at_points(
        &self,
        points: &[(DVec3, DVec3)],
        cancel: &Cancel,
    ) -> Result<Vec<(Rgb64, f64)>, QueryError> {
        let gathers = self.model.gathers(points, cancel)?;
        Ok(points
            .par_iter()
            .zip(gathers.par_iter())
            .map(|(&(x, nrm), g)| self.at(g, x, nrm))
            .collect())
    }

    /// The daylight factor of `daylight` lux, percent, under the CIE overcast sky.
    pub(super) fn daylight_factor(&self, daylight: f64) -> Option<f64> {
        self.sky
            .df_reference
            .map(|r| 100.0 * daylight / r.max(1e-9))
    }
}
