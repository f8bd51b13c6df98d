//! The electric light added to daylight: any lighting state, solved once, with what a
//! point adds to the light it gathers (the luminaires' direct light).

use glam::DVec3;

use super::super::{Lighting, Model, QueryError};
use crate::color::Rgb64;

/// A lighting state's electric light: its radiosity and illuminance on every patch, at
/// `scale` (a maintenance factor that every light of the state shares).
pub(super) struct ElectricLight<'a> {
    lighting: std::borrow::Cow<'a, Lighting>,
    /// Radiosity, lm/m² (n × 3), and illuminance, lux (n × 3), at scale 1.
    pub(super) b: Vec<f32>,
    pub(super) h: Vec<f32>,
    pub(super) scale: f64,
}

impl<'a> ElectricLight<'a> {
    /// The state solved: group weights relit, an emission or placed luminaires solved.
    pub(super) fn new(model: &Model, lighting: &'a Lighting) -> Result<Self, QueryError> {
        Self::of(model, std::borrow::Cow::Borrowed(lighting))
    }

    /// [`ElectricLight::new`] of a state it keeps.
    pub(super) fn owned(model: &Model, lighting: Lighting) -> Result<Self, QueryError> {
        Self::of(model, std::borrow::Cow::Owned(lighting))
    }

    fn of(model: &Model, lighting: std::borrow::Cow<'a, Lighting>) -> Result<Self, QueryError> {
        let sol = model.solve(&lighting)?;
        Ok(ElectricLight {
            lighting,
            b: sol.b,
            h: sol.h,
            scale: 1.0,
        })
    }

    /// The same light at `k` times its level.
    pub(super) fn scaled(&self, k: f64) -> ElectricLight<'a> {
        ElectricLight {
            lighting: self.lighting.clone(),
            b: self.b.clone(),
            h: self.h.clone(),
            scale: self.scale * k,
        }
    }

    /// The direct light (RGB lux) at `x` facing `n` of the state's luminaires (the groups'
    /// at their weights and the placed ones), shadowed, at scale 1. An emission has none:
    /// its emitting patches are gathered.
    pub(super) fn direct_at(&self, model: &Model, x: DVec3, n: DVec3) -> Rgb64 {
        let mut e = Rgb64::ZERO;
        match self.lighting.as_ref() {
            Lighting::Groups(w) => model.add_luminaires(w, x, n, &mut e),
            Lighting::Placed(p) => {
                model.add_luminaires(&p.weights, x, n, &mut e);
                e += crate::transport::direct::weighted_point_illuminance(
                    &model.baked.bvh,
                    p.luminaires(),
                    x,
                    n,
                );
            }
            Lighting::Emission(_) => {}
        }
        e
    }
}
