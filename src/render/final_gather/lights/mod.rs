//! Direct light at a visible point, per light group, computed exactly.
//!
//! - **Point luminaires** ([`luminaires`]): each luminaire's unoccluded illuminance is
//!   bounded first, without trigonometry: its peak intensity in the band of directions
//!   the point lies in ([`Luminaire::peak_intensities`]) times the receiver's cosine over
//!   the squared distance (a near luminaire, seen as an area, is computed over its
//!   opening, [`Luminaire::for_each_emitter`]). Every luminaire whose bound is at least
//!   [`SIGNIFICANT`] of the bounds' sum over all groups gets its shadow rays and its exact
//!   illuminance. The rest, the tail, is estimated without bias by a few luminaires drawn
//!   in proportion to their bounds, each one's exact shadowed illuminance weighted by the
//!   tail's sum over its bound.
//! - **Emissive surfaces** ([`emitters`]): each emitting input triangle that faces the
//!   point and gives at least [`SIGNIFICANT`] of its unoccluded light gives its exitance
//!   times the exact unoccluded point-to-triangle form factor, times the visible share of
//!   that factor, from stratified shadow rays weighted by the factor's kernel (more rays
//!   for brighter triangles). Where the shaft from the point to the triangle's coplanar
//!   set is clear of every other triangle ([`Shaft`](crate::geometry::shaft::Shaft)), the
//!   share is exactly 1 and no ray is traced. The rest, the tail, is estimated without
//!   bias by one triangle drawn in proportion to its light, with one ray. A group with
//!   more than [`MAX_EMITTER_TRIANGLES`] emitting triangles leaves its emission to the
//!   gather instead ([`GroupLights::explicit`]). A per-patch emission vector's emitters
//!   are its emitting patches' facets ([`super::EmitterLight::Patches`]).

mod emitters;
mod luminaires;

use glam::DVec3;

use super::glossy::SampledEmitter;
use super::point::{ShadingPoint, ShadowOrigin};
use super::specular::Lobe;
use super::FinalScene;
use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::geometry::shaft::coplanar_sets;
use crate::photometry::Luminaire;
use crate::sampling::Rng;

use emitters::{emitters_of, ShaftMemo};
pub(super) use emitters::{Emitter, EmitterCandidate};
use luminaires::{Bounds, LuminaireCandidate};

/// A luminaire whose unoccluded illuminance is at least this share of the point's total
/// gets its own shadow rays; the others are sampled.
pub(super) const SIGNIFICANT: f64 = 0.01;

/// Luminaires, and emitting triangles, drawn from the tail per camera sample.
const TAIL_DRAWS: u32 = 4;

/// How many shadow rays the direct light takes.
#[derive(Debug, Clone, Copy)]
pub(super) enum Rays {
    /// Every source that gives at least [`SIGNIFICANT`] of the light gets its rays (an
    /// emitting triangle up to this many, by its share), the rest one drawn ray.
    Stratified(u32),
    /// One source drawn in proportion to its unoccluded light, with one ray: for values
    /// that many others are averaged with (the gather's close hits).
    OneDrawn,
}

impl Rays {
    /// The share of the light above which a source gets its own rays.
    fn significant(self) -> f64 {
        match self {
            Rays::Stratified(_) => SIGNIFICANT,
            Rays::OneDrawn => f64::INFINITY,
        }
    }

    /// Triangles drawn from the tail, one ray each.
    fn tail_draws(self) -> u32 {
        match self {
            Rays::Stratified(k) => TAIL_DRAWS.min(k.max(1)),
            Rays::OneDrawn => 1,
        }
    }

    /// Most rays per emitting triangle.
    fn per_triangle(self) -> u32 {
        match self {
            Rays::Stratified(k) => k.max(1),
            Rays::OneDrawn => 1,
        }
    }
}

/// Emitting triangles per group handled exactly; a group with more is gathered.
pub(super) const MAX_EMITTER_TRIANGLES: usize = 1024;
/// One light group's sources.
struct Sources<'a> {
    luminaires: &'a [Luminaire],
    emitters: Vec<Emitter>,
    /// The convex hulls of its emitting triangles' coplanar sets ([`coplanar_sets`]),
    /// each with its front normal: one shaft per set.
    sets: Vec<(Vec<DVec3>, DVec3)>,
    /// Whether its emitting surfaces are handled here (else by the gather).
    explicit: bool,
}

/// Every group's direct-light sources.
pub(super) struct GroupLights<'a> {
    /// The scene BVH (ids: scene triangles): shadow rays skip the triangle a patch was cut
    /// from, and this tree is far smaller than the patches'.
    bvh: &'a Bvh,
    mesh: &'a Mesh,
    groups: Vec<Sources<'a>>,
    /// Every group's luminaires' bounds.
    bounds: Bounds,
}

/// One point's direct light, as each kind of source takes it: where its shadow rays leave
/// from, how many it takes, and the thread's random numbers and buffers.
struct Pass<'p> {
    at: ShadowOrigin,
    rays: Rays,
    rng: &'p mut Rng,
    scratch: &'p mut Scratch,
}

/// Reused buffers of one thread.
#[derive(Default)]
pub(super) struct Scratch {
    /// Per group RGB direct illuminance of the current sample, lux.
    pub(super) lux: Vec<f32>,
    /// The same at a point a gather ray landed on close by.
    pub(super) near: Vec<f32>,
    /// Luminaires that light the point.
    candidates: Vec<LuminaireCandidate>,
    /// The opening points of the luminaires near the point, with each point's unoccluded
    /// illuminance (lux), computed once for both the choice and the shadowed light.
    points: Vec<(DVec3, f64)>,
    /// Per luminaire, its bound at the point ([`Bounds::lux`]).
    bound: Vec<f32>,
    /// Emitting triangles seen.
    pub(super) emitters: Vec<EmitterCandidate>,
    /// The coplanar sets whose shaft was tested at the current point.
    shafts: Vec<ShaftMemo>,
    /// The emitting triangles a specular lobe's light samples went to at the current
    /// point ([`super::glossy`]).
    pub(super) sampled: Vec<SampledEmitter>,
}

impl<'a> GroupLights<'a> {
    pub(super) fn new(scene: &'a FinalScene<'a>) -> GroupLights<'a> {
        // Under a sky the image is the daylight's alone: no group's lights.
        let groups = if scene.sky.is_some() {
            &[][..]
        } else {
            scene.lights
        };
        let groups: Vec<Sources<'a>> = groups
            .iter()
            .zip(scene.groups)
            .enumerate()
            .map(|(k, (light, col))| {
                let mut emitters = emitters_of(scene, k, &col.e);
                let explicit = emitters.len() <= MAX_EMITTER_TRIANGLES;
                if !explicit {
                    emitters.clear();
                }
                let tris: Vec<[DVec3; 3]> = emitters.iter().map(|e| e.corners).collect();
                let normals: Vec<DVec3> = emitters.iter().map(|e| e.normal).collect();
                let (set, hulls) = coplanar_sets(&tris, &normals);
                for (e, s) in emitters.iter_mut().zip(set) {
                    e.set = s;
                }
                let mut sets: Vec<(Vec<DVec3>, DVec3)> =
                    hulls.into_iter().map(|h| (h, DVec3::ZERO)).collect();
                for e in &emitters {
                    sets[e.set as usize].1 = e.normal;
                }
                Sources {
                    luminaires: &light.luminaires,
                    emitters,
                    sets,
                    explicit,
                }
            })
            .collect();
        let mut bounds = Bounds::default();
        for (k, g) in groups.iter().enumerate() {
            for (i, l) in g.luminaires.iter().enumerate() {
                bounds.push((k as u32, i as u32), l);
            }
        }
        GroupLights {
            bvh: scene.bvh,
            mesh: scene.mesh,
            groups,
            bounds,
        }
    }

    /// Whether group `k`'s emitting surfaces are lit here (so the gather must leave their
    /// emission out).
    pub(super) fn explicit(&self, k: usize) -> bool {
        self.groups[k].explicit
    }

    /// Adds to `out` (per group RGB, lux) the direct illuminance at `at`, with shadow
    /// rays as `rays` says; and with a specular `lobe`, to `highlights` (per group RGB,
    /// cd/m²) the point luminaires' light it reflects ([`super::specular`]).
    pub(super) fn direct(
        &self,
        at: ShadingPoint,
        rays: Rays,
        rng: &mut Rng,
        scratch: &mut Scratch,
        out: &mut [f32],
        specular: Option<(&Lobe, &mut [f32])>,
    ) {
        let mut pass = Pass {
            at: at.shadow_origin(self.mesh),
            rays,
            rng,
            scratch,
        };
        let out = Rgb::column_mut(out);
        let specular = specular.map(|(lobe, h)| (lobe, Rgb::column_mut(h)));
        self.luminaires(&mut pass, out, specular);
        self.emitters(&mut pass, out);
    }
}
