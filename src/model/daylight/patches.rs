//! A sky's daylight on every patch: the transfer's sky responses weighted by the sky
//! patches' luminances, and the sun's light on the patches (direct by shadow rays,
//! interreflected by one solve, or carried by the sky patches around it).

use std::sync::Arc;

use glam::DVec3;

use crate::color::Rgb;
use crate::daylight::Site;
use crate::model::daylight::sun_on_patches::{fit_sun_spread, SunOnPatches};
use crate::model::sky_state::SkyState;
use crate::model::{Model, QueryError};
use crate::transport::sky_view;
use crate::transport::transfer::weighted_sum;

/// The sun's light on the patches for one sky (lux): direct (n), interreflected when
/// solved exactly (n × 3), else the sky patches it is spread over for its
/// interreflection, (patch, luminance cd/m²).
#[derive(Default)]
pub(super) struct SunLight {
    pub(super) direct: Option<Vec<f32>>,
    pub(super) interreflected: Option<Vec<f32>>,
    pub(super) spread: Vec<(usize, f64)>,
}

/// A sky's daylight on every patch: illuminance `h` (lux) and radiosity `b` (lm/m²),
/// n × 3 interleaved.
pub struct PatchDaylight {
    pub h: Vec<f32>,
    pub b: Vec<f32>,
}

impl Model {
    /// Per-patch daylight for sky patch luminances `l` (cd/m², index 0 the ground) and the
    /// sun's light `sun` ([`SunLight`]).
    pub(super) fn sky_patches(
        &self,
        l: &[f64],
        sun: &SunLight,
        with_direct_sun: bool,
    ) -> PatchDaylight {
        let t = &self.baked.transfer;
        let s = t.sky.as_ref().expect("callers check the site");
        let n = t.n;
        // Interreflected: the sky patches' luminances, plus the sun's share where its
        // interreflection is not solved exactly.
        let mut w: Vec<Rgb> = l.iter().map(|&x| Rgb::splat(x as f32)).collect();
        for &(k, lum) in &sun.spread {
            w[k] += Rgb::splat(lum as f32);
        }
        let mut h = vec![0f32; 3 * n];
        weighted_sum(s.indirect.iter().map(|c| c.as_slice()), &w, &mut h);
        if let Some(ind) = &sun.interreflected {
            for (a, b) in h.iter_mut().zip(ind) {
                *a += b;
            }
        }
        let sun_direct = if with_direct_sun {
            sun.direct.as_deref()
        } else {
            None
        };
        // Direct: the sky patches, then the sun.
        for (i, hi) in Rgb::column_mut(&mut h).iter_mut().enumerate() {
            let row = &s.direct[i * s.k..(i + 1) * s.k];
            let mut d: f64 = row.iter().zip(l).map(|(&a, &b)| a as f64 * b).sum();
            if let Some(sd) = sun_direct {
                d += sd[i] as f64;
            }
            *hi += Rgb::splat(d as f32);
        }
        let b = Rgb::column(&h)
            .iter()
            .zip(&t.rho)
            .flat_map(|(&h, &r)| (h * r).0)
            .collect();
        PatchDaylight { h, b }
    }

    /// The sun's direct and interreflected light on every patch (at a normal illuminance
    /// of 1 lx) for the sun in unit scene direction `d`: shadow rays and one solve, kept
    /// for the last [`super::SUN_CACHE_ENTRIES`] directions.
    fn sun_on_patches(&self, d: DVec3) -> Arc<SunOnPatches> {
        self.gathers.sun(d, || self.trace_sun(d))
    }

    /// The sun's direct and interreflected light on every patch for the sun in unit scene
    /// direction `d`, at a normal illuminance of 1 lx.
    fn trace_sun(&self, d: DVec3) -> SunOnPatches {
        let direct = sky_view::patch_sun_direct(
            &self.baked.mesh,
            &self.baked.bvh,
            &self.baked.glazing,
            d,
            1.0,
            self.reach(),
        );
        let t = &self.baked.transfer;
        let interreflected = if t.factored.is_some() || t.hierarchy.is_some() {
            let first: Vec<f32> = direct
                .iter()
                .zip(&t.rho)
                .flat_map(|(&e, &r)| (e * r).0)
                .collect();
            t.solve(&first).map(|sol| sol.h)
        } else {
            None
        };
        let spread = match (&interreflected, self.site()) {
            (None, Ok(site)) => fit_sun_spread(t, site, d, &direct),
            _ => vec![],
        };
        SunOnPatches {
            direct,
            interreflected,
            spread,
        }
    }

    /// The sun's light on the patches for a sky: its direct illuminance, and its
    /// interreflection solved exactly (factored and hierarchical modes) or else carried by
    /// the sky patches around it ([`fit_sun_spread`]).
    fn sun_light(&self, sky: &SkyState, site: &Site) -> SunLight {
        let Some((d, e)) = sky.sun_direction(site) else {
            return SunLight::default();
        };
        let on = self.sun_on_patches(d);
        let scaled = |v: &[f32]| v.iter().map(|&x| (x as f64 * e) as f32).collect::<Vec<_>>();
        SunLight {
            direct: Some(scaled(&on.direct)),
            interreflected: on.interreflected.as_deref().map(scaled),
            spread: on.spread.iter().map(|&(k, c)| (k, c * e)).collect(),
        }
    }

    /// The solution of `lighting` (B and H per patch) with the daylight of `sky` added,
    /// when a sky is given.
    pub fn solve_daylit(
        &self,
        lighting: &crate::model::Lighting,
        sky: Option<&SkyState>,
    ) -> Result<crate::transport::transfer::Solution, QueryError> {
        let mut sol = self.solve(lighting)?;
        if let Some(sky) = sky {
            let day = self.patch_daylight(sky)?;
            sol.b.iter_mut().zip(&day.b).for_each(|(a, x)| *a += x);
            sol.h.iter_mut().zip(&day.h).for_each(|(a, x)| *a += x);
        }
        Ok(sol)
    }

    /// A sky's daylight on every patch.
    pub fn patch_daylight(&self, sky: &SkyState) -> Result<PatchDaylight, QueryError> {
        self.sky_on_patches(sky, true)
    }

    /// A sky's daylight on every patch without the sun's direct light (its interreflection
    /// stays): what an image shows on its patches while the sun is traced per pixel.
    pub fn patch_daylight_without_sun(&self, sky: &SkyState) -> Result<PatchDaylight, QueryError> {
        self.sky_on_patches(sky, false)
    }

    /// A sky's daylight on every patch, with the sun's direct light or without.
    fn sky_on_patches(
        &self,
        sky: &SkyState,
        with_direct_sun: bool,
    ) -> Result<PatchDaylight, QueryError> {
        let (_, l, sun) = self.sky_light(sky)?;
        Ok(self.sky_patches(&l, &sun, with_direct_sun))
    }

    /// A sky at the scene's site: the site, the mean luminances of the sky patches (cd/m²,
    /// 0 the ground) and the sun's light on the patches.
    pub(super) fn sky_light(
        &self,
        sky: &SkyState,
    ) -> Result<(&Site, Vec<f64>, SunLight), QueryError> {
        let site = self.site()?;
        let l = sky.patch_luminances(&sky_view::subdivision());
        Ok((site, l, self.sun_light(sky, site)))
    }

    /// The sun's reflected light, lm/m² per patch (n × 3), for gathering exactly at points:
    /// its first reflection, plus its interreflection where it is solved (else the
    /// daylight coefficients carry it with the sky's).
    pub(super) fn sun_reflected(&self, sun_light: &SunLight) -> Option<Vec<f32>> {
        let t = &self.baked.transfer;
        sun_light.direct.as_ref().map(|sd| {
            let ind = sun_light.interreflected.as_deref();
            sd.iter()
                .zip(&t.rho)
                .enumerate()
                .flat_map(|(i, (&e, r))| {
                    let h = |c: usize| e + ind.map_or(0.0, |v| v[3 * i + c]);
                    [h(0) * r[0], h(1) * r[1], h(2) * r[2]]
                })
                .collect()
        })
    }
}
