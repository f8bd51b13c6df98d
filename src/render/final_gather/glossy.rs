//! The glossy lobe's sampled light at a camera sample's point: its reflections of the
//! room and its share of the emitting surfaces, one estimator in two strategies combined
//! by the balance heuristic (Veach's multiple importance sampling).
//!
//! - **Light samples** ([`Tracer::light_samples`]): [`SPECULAR_LIGHT_SAMPLES`] shadow
//!   rays to points on each emitting triangle that gives at least [`SIGNIFICANT`] of the
//!   point's diffuse light, each weighted by `1 −` the reflection rays' weight for its
//!   direction. A lobe too narrow to be filtered takes none: its reflection rays alone
//!   find the emitters, all but without noise.
//! - **Reflection rays** ([`Tracer::reflections`]): a jittered square grid of directions
//!   drawn from the lobe ([`Lobe::sample`]). A ray reads the reflected radiosity where it
//!   lands over π (the gather's table, [`Reflected`](super::gather::Reflected)), plus the emitting surface's
//!   luminance `E/π` for the groups whose emission the direct part lights (the table
//!   holds `B` whole for the others), weighted by [`SampledEmitter::ray_weight`] where
//!   the triangle got light samples; or the sky's luminance where it leaves the scene.
//!
//! The lobe itself (its BRDF, density and draws) is [`super::specular`]'s; its highlights
//! of the point luminaires and the sun come with the direct light.

use glam::DVec3;

use super::gather::{square_count, SideHit};
use super::lights::{Scratch, SIGNIFICANT};
use super::point::ShadingPoint;
use super::specular::Lobe;
use super::{EmitterLight, LightParts, Tracer};
use crate::color::Rgb;
use crate::geometry::lifted;
use crate::geometry::patch_locator::PatchRay;
use crate::sampling::{stratified_on_triangle, Rng};
use crate::transport::direct::visible;

/// Light samples per emitting triangle for a specular lobe (a 2 × 2 jittered grid).
const SPECULAR_LIGHT_SAMPLES: u32 = 4;

/// An emitting triangle that a specular lobe's light samples went to: the reflection
/// rays that meet it weigh their share against these ([`SampledEmitter::ray_weight`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct SampledEmitter {
    /// Its index among the scene's triangles.
    source: u32,
    /// Light samples it got.
    samples: u32,
    /// Area, m².
    area: f64,
    /// Front normal.
    normal: DVec3,
}

impl SampledEmitter {
    /// The balance-heuristic weight of a reflection ray drawn with density `pdf`
    /// (1/sr) among `rays` that meets this triangle at distance `r` along `d`.
    fn ray_weight(&self, d: DVec3, r: f64, pdf: f64, rays: usize) -> f64 {
        let cos = -self.normal.dot(d);
        if cos <= 0.0 {
            return 1.0;
        }
        let light = self.samples as f64 * r * r / (self.area * cos);
        let brdf = rays as f64 * pdf;
        brdf / (brdf + light)
    }
}

impl Tracer<'_> {
    /// Adds the sampled light of the specular `lobe` at `at` (per group RGB, cd/m²) from
    /// `specular_rays` (a whole square grid of them, which the light samples' weights
    /// count): to the indirect light when the lobe is filtered ([`Lobe::filtered`]), else
    /// to the direct light.
    pub(super) fn glossy_light(
        &self,
        at: ShadingPoint,
        lobe: &Lobe,
        specular_rays: usize,
        rng: &mut Rng,
        scratch: &mut Scratch,
        light: &mut LightParts<'_>,
    ) {
        let rays = square_count(specular_rays);
        let out = if lobe.filtered() {
            &mut *light.indirect
        } else {
            &mut *light.direct
        };
        self.light_samples(at, lobe, rays, rng, scratch, out);
        self.reflections(at, lobe, rays, &scratch.sampled, rng, out);
    }

    /// Adds to `out` (per group RGB, cd/m²) the light of the emitting triangles that
    /// the specular `lobe` at `at` reflects, from light samples weighted by the balance
    /// heuristic against the `rays` reflection rays drawn from the lobe (see the module's
    /// documentation). The triangles sampled are left in `scratch.sampled`; the
    /// reflection rays that meet them take the complementary weight, the others' light
    /// in full.
    fn light_samples(
        &self,
        at: ShadingPoint,
        lobe: &Lobe,
        rays: usize,
        rng: &mut Rng,
        scratch: &mut Scratch,
        out: &mut [f32],
    ) {
        let (x, n) = (at.position, at.normal);
        let skip = at.shadow_origin(self.scene.mesh).skip_triangle;
        scratch.sampled.clear();
        if !lobe.filtered() {
            // A near mirror: its reflection rays alone find the emitters, all but
            // without noise; a light sample landing in its narrow peak would add one.
            return;
        }
        let cand = &mut scratch.emitters;
        self.lights.candidates(x, n, cand);
        let total: f64 = cand.iter().map(|c| c.light).sum();
        if total <= 0.0 {
            return;
        }
        let out = Rgb::column_mut(out);
        let side = (SPECULAR_LIGHT_SAMPLES as f64).sqrt().ceil() as u32;
        let m = side * side;
        for c in cand.iter() {
            if c.light < SIGNIFICANT * total {
                continue;
            }
            let e = self.lights.emitter(c);
            let sampled = SampledEmitter {
                source: e.source,
                samples: m,
                area: e.area,
                normal: e.normal,
            };
            scratch.sampled.push(sampled);
            let mut sum = Rgb::ZERO;
            stratified_on_triangle(&e.corners, side as usize, rng, |y| {
                let to = y - x;
                let r = to.length();
                let d = to / r;
                let (cos_x, cos_y) = (n.dot(d), -e.normal.dot(d));
                if !(cos_x > 0.0 && cos_y > 0.0) {
                    return;
                }
                let f = lobe.brdf(d, 0.0);
                if f.luminance() <= 0.0 || !visible(self.scene.bvh, x, n, y, skip) {
                    return;
                }
                // Density per solid angle of a uniform point on the triangle.
                let light = r * r / (e.area * cos_y);
                let w = 1.0 - sampled.ray_weight(d, r, lobe.pdf(d), rays);
                sum += f * (cos_x / light * w / m as f64) as f32;
            });
            out[c.group as usize] += sum * e.exitance * std::f32::consts::FRAC_1_PI;
        }
    }

    /// Adds to `out` (per group RGB, cd/m²) the light the specular `lobe` at `at`
    /// reflects towards the viewer, from `rays` rays drawn from the lobe on a jittered
    /// √rays × √rays grid; an emitting triangle among `sampled` is weighed against its
    /// light samples (see the module's documentation).
    fn reflections(
        &self,
        at: ShadingPoint,
        lobe: &Lobe,
        rays: usize,
        sampled: &[SampledEmitter],
        rng: &mut Rng,
        out: &mut [f32],
    ) {
        let scene = self.scene;
        let count = square_count(rays);
        let side = count.isqrt();
        let o = lifted(at.position, at.normal);
        let own = at.triangle(scene.mesh);
        let patches = scene.patches;
        let inv_pi = std::f32::consts::FRAC_1_PI;
        let mut read = vec![0f32; out.len()];
        for i in 0..count {
            let u = (rng.stratum(i / side, side), rng.stratum(i % side, side));
            let Some((d, weight)) = lobe.sample(u) else {
                continue;
            };
            let weight = weight * (1.0 / count as f32);
            let hit = patches.nearest_side(scene.bvh, PatchRay::leaving(own, o, d));
            read.iter_mut().for_each(|v| *v = 0.0);
            match hit {
                None => {
                    if let Some(sky) = &scene.sky {
                        read[..3]
                            .iter_mut()
                            .for_each(|v| *v = sky.outside(o, d, false));
                    }
                }
                Some((th, tri, back)) => {
                    if !patches.faces(tri, back, d) {
                        continue;
                    }
                    let hit = SideHit {
                        triangle: tri,
                        back,
                        point: o + d * th as f64,
                    };
                    self.reflected.add_at(patches, hit, inv_pi, &mut read);
                    let mis = |q_triangle: u32| {
                        sampled
                            .iter()
                            .find(|s| s.source == q_triangle)
                            .map_or(1.0, |s| s.ray_weight(d, th as f64, lobe.pdf(d), count))
                    };
                    self.emitter_seen(hit, mis, &mut read);
                }
            }
            for (o, r) in Rgb::column_mut(out).iter_mut().zip(Rgb::column(&read)) {
                *o += weight * *r;
            }
        }
    }

    /// Adds to `read` (per group RGB, cd/m²) the luminance `E/π` of the emitter a
    /// reflection ray met at `hit`, for the groups whose gather table leaves it out,
    /// weighted by `mis` of the triangle (against the light samples it got).
    fn emitter_seen(&self, hit: SideHit, mis: impl Fn(u32) -> f64, read: &mut [f32]) {
        let scene = self.scene;
        let inv_pi = std::f32::consts::FRAC_1_PI;
        let (tri, back) = (hit.triangle, hit.back);
        // One lighting state's image has one group, whatever the triangle's.
        let group = match scene.emitters {
            EmitterLight::PerGroup => scene.triangles.get(tri as usize).and_then(|t| t.group),
            EmitterLight::AnyPatch | EmitterLight::Patches => Some(0),
        };
        if let (Some(k), false, None) = (group, back, &scene.sky) {
            let k = k as usize;
            if k < self.reflected.groups() && self.lights.explicit(k) {
                if let Some(q) = scene.patches.locate(tri, back, hit.point) {
                    // Weighed against the light samples the triangle got.
                    let mis = mis(tri);
                    let e = Rgb::column(&scene.groups[k].e)[q as usize];
                    Rgb::column_mut(read)[k] += e * (inv_pi * mis as f32);
                }
            }
        }
    }
}
