//! The emitting surfaces' direct light: each emitting triangle's exact form factor times
//! its visible share (a clear shaft, or stratified shadow rays). The light samples a
//! specular lobe takes of them are [`super::super::glossy`]'s.

use std::collections::BTreeMap;

use glam::DVec3;

use super::{GroupLights, Pass};
use crate::color::{Rgb, Rgb64};
use crate::geometry::ray_offset;
use crate::geometry::shaft::Shaft;
use crate::render::final_gather::point::ShadowOrigin;
use crate::render::final_gather::{EmitterLight, FinalScene};
use crate::sampling::{stratified_on_triangle, Rng};
use crate::transport::direct::visible;
use crate::transport::formfactor::point_to_polygon;

/// Shadow rays to an emitting triangle from which its shaft is tested first
/// ([`Shaft`]): a clear shaft takes the place of the rays. A test costs about as much as
/// four rays on the Cornell box, so a triangle given fewer traces them.
const SHAFT_MIN_RAYS: u32 = 4;
/// One emitting input triangle of a group.
pub(in crate::render::final_gather) struct Emitter {
    /// Its index among the scene's triangles.
    pub(in crate::render::final_gather) source: u32,
    /// Area, m².
    pub(in crate::render::final_gather) area: f64,
    pub(in crate::render::final_gather) corners: [DVec3; 3],
    pub(super) centroid: DVec3,
    pub(in crate::render::final_gather) normal: DVec3,
    /// Exitance at unit group weight, lm/m².
    pub(in crate::render::final_gather) exitance: Rgb,
    /// Its luminous value.
    pub(super) luminous: f64,
    /// Its set of coplanar neighbours in [`super::Sources::sets`].
    pub(super) set: u32,
}

/// An emitting triangle whose front a point sees ([`GroupLights::candidates`]).
#[derive(Debug, Clone, Copy)]
pub(in crate::render::final_gather) struct EmitterCandidate {
    /// Its light group.
    pub(in crate::render::final_gather) group: u32,
    /// Its index among the group's emitters ([`GroupLights::emitter`]).
    pub(in crate::render::final_gather) emitter: u32,
    /// The unoccluded form factor from the point to the triangle.
    pub(in crate::render::final_gather) form_factor: f64,
    /// Its unoccluded luminous light at the point: the form factor × its luminous value.
    pub(in crate::render::final_gather) light: f64,
}

/// Whether the shaft to one group's coplanar set was clear, kept for the current point.
#[derive(Debug, Clone, Copy)]
pub(super) struct ShaftMemo {
    group: u32,
    set: u32,
    clear: bool,
}

impl GroupLights<'_> {
    /// Emitting triangles of every group: exact form factor × visible share. The triangles
    /// that give at least [`super::Rays::significant`] of the light of all groups together get
    /// up to `rays` shadow rays each (by their share); the rest, the tail, one triangle
    /// drawn in proportion to its light, weighted by the tail's total over its own (an
    /// unbiased estimate of their sum). Shares are of the unit-weight light, so the rays
    /// depend on the geometry alone and each group's image stays linear; a room's panels
    /// spend no rays on the panels of the rooms beyond its walls one by one.
    pub(super) fn emitters(&self, pass: &mut Pass, out: &mut [Rgb]) {
        let (at, rays, rng) = (pass.at, pass.rays, &mut *pass.rng);
        let cand = &mut pass.scratch.emitters;
        let shafts = &mut pass.scratch.shafts;
        shafts.clear();
        self.candidates(at.position, at.normal, cand);
        let total: f64 = cand.iter().map(|c| c.light).sum();
        if total <= 0.0 {
            return;
        }
        let cut = rays.significant() * total;
        let draws = rays.tail_draws();
        let rays = rays.per_triangle();
        let budget = rays as f64;
        let mut tail = 0.0;
        for c in cand.iter() {
            let (k, ff, part) = (c.group, c.form_factor, c.light);
            if part < cut {
                tail += part;
                continue;
            }
            let e = self.emitter(c);
            let m = ((part / total * budget).ceil() as u32).clamp(1, rays);
            let seen = if m >= SHAFT_MIN_RAYS && self.shaft_clear(k, e.set, at, shafts) {
                1.0
            } else {
                self.visible_share(e, at, m, rng)
            };
            out[k as usize] += (ff * seen) as f32 * e.exitance;
        }
        if tail <= 0.0 {
            return;
        }
        // Stratified draws over the tail's cumulative light, one ray each.
        for j in 0..draws {
            let mut r = rng.stratum(j as usize, draws as usize) * tail;
            let mut drawn = None;
            for c in cand.iter() {
                if c.light >= cut {
                    continue;
                }
                drawn = Some(c);
                if r < c.light {
                    break;
                }
                r -= c.light;
            }
            if let Some(c) = drawn {
                let e = self.emitter(c);
                let f = c.form_factor * self.visible_share(e, at, 1, rng) * tail
                    / c.light
                    / draws as f64;
                out[c.group as usize] += f as f32 * e.exitance;
            }
        }
    }

    /// Into `cand`, the emitting triangles whose front `x` (normal `n`) sees.
    pub(in crate::render::final_gather) fn candidates(
        &self,
        x: DVec3,
        n: DVec3,
        cand: &mut Vec<EmitterCandidate>,
    ) {
        cand.clear();
        for (k, g) in self.groups.iter().enumerate() {
            for (i, e) in g.emitters.iter().enumerate() {
                if e.normal.dot(x - e.centroid) <= 0.0 {
                    continue;
                }
                let ff = point_to_polygon(x, n, &e.corners);
                if ff > 0.0 {
                    cand.push(EmitterCandidate {
                        group: k as u32,
                        emitter: i as u32,
                        form_factor: ff,
                        light: ff * e.luminous,
                    });
                }
            }
        }
    }

    /// The emitting triangle `c` stands for.
    pub(in crate::render::final_gather) fn emitter(&self, c: &EmitterCandidate) -> &Emitter {
        &self.groups[c.group as usize].emitters[c.emitter as usize]
    }

    /// Whether the shaft from `at` to group `k`'s coplanar set `set` is clear
    /// ([`crate::geometry::bvh::Bvh::clear_of`]): every shadow ray to its triangles is then free. Each set's
    /// answer is kept in `memo` for the point.
    fn shaft_clear(&self, k: u32, set: u32, at: ShadowOrigin, memo: &mut Vec<ShaftMemo>) -> bool {
        if let Some(m) = memo.iter().find(|m| m.group == k && m.set == set) {
            return m.clear;
        }
        let (x, n) = (at.position, at.normal);
        let (hull, normal) = &self.groups[k as usize].sets[set as usize];
        // The lift `visible` gives its rays.
        let lift = ray_offset(x);
        let clear = Shaft::new(x + n * lift, n, lift, hull, *normal)
            .is_some_and(|shaft| self.bvh.clear_of(&shaft, [at.skip_triangle, u32::MAX]));
        memo.push(ShaftMemo {
            group: k,
            set,
            clear,
        });
        clear
    }

    /// The visible share of emitter `e`'s form factor at `at`: about `k` stratified points
    /// on the triangle (a `⌈√k⌉²` grid, jittered), each weighted by the form factor's
    /// kernel `cos θ cos θ' / r²`, so a hidden near corner of a large emitter counts for
    /// more than a hidden far one. The count never depends on what the rays find: an
    /// estimate refined only where its first rays disagree is biased (a small hidden part
    /// that the first rays miss reads as wholly visible).
    fn visible_share(&self, e: &Emitter, at: ShadowOrigin, k: u32, rng: &mut Rng) -> f64 {
        let side = (k as f64).sqrt().ceil() as u32;
        let mut sums = KernelWeights::default();
        self.sample_emitter(e, at, side, rng, &mut sums);
        let all = sums.free + sums.hidden;
        if all > 0.0 {
            sums.free / all
        } else {
            // Every point fell below x's horizon: a sliver the form factor barely counts.
            1.0
        }
    }

    /// Adds `side`² jittered points of emitter `e` to `sums`, by their kernel weight.
    fn sample_emitter(
        &self,
        e: &Emitter,
        at: ShadowOrigin,
        side: u32,
        rng: &mut Rng,
        sums: &mut KernelWeights,
    ) {
        let (x, n, skip) = (at.position, at.normal, at.skip_triangle);
        stratified_on_triangle(&e.corners, side as usize, rng, |y| {
            let d = y - x;
            let r2 = d.length_squared();
            let w = n.dot(d) * -e.normal.dot(d) / (r2 * r2);
            if w.is_nan() || w <= 0.0 {
                return;
            }
            if visible(self.bvh, x, n, y, skip) {
                sums.free += w;
            } else {
                sums.hidden += w;
            }
        });
    }
}

/// Kernel-weighted sums of an emitter's sample points, visible and hidden.
#[derive(Default)]
struct KernelWeights {
    free: f64,
    hidden: f64,
}

/// The emitting facets of every patch that `e` gives emission, each at its patch's
/// exitance (lm/m²), up to one more than [`super::MAX_EMITTER_TRIANGLES`] (which leaves
/// them to the gather).
fn facet_emitters(scene: &FinalScene<'_>, e: &[f32]) -> Vec<Emitter> {
    let mut out = Vec::new();
    for (i, ej) in Rgb::column(e).iter().enumerate() {
        if ej.iter().all(|&v| v <= 0.0) {
            continue;
        }
        for f in scene.mesh.facets(i) {
            if out.len() > super::MAX_EMITTER_TRIANGLES {
                return out;
            }
            out.push(Emitter {
                source: f.source,
                area: f.area,
                corners: f.corners,
                centroid: f.centroid,
                normal: f.normal,
                exitance: *ej,
                luminous: ej.luminance().max(1e-12) as f64,
                set: 0,
            });
        }
    }
    out
}

/// The emitting input triangles of group `k` (of any group under
/// [`EmitterLight::AnyPatch`]), with their exitance at unit weight (the area-weighted mean
/// of their patches' emission `e`, lm/m²).
pub(super) fn emitters_of(scene: &FinalScene<'_>, k: usize, e: &[f32]) -> Vec<Emitter> {
    if scene.emitters == EmitterLight::Patches {
        return facet_emitters(scene, e);
    }
    let mut by_source: BTreeMap<u32, (f64, Rgb64)> = BTreeMap::new();
    for (i, (patch, ej)) in scene.mesh.patches.iter().zip(Rgb::column(e)).enumerate() {
        if scene.emitters == EmitterLight::PerGroup && patch.group != Some(k as u32) {
            continue;
        }
        if ej.iter().all(|&v| v <= 0.0) {
            continue;
        }
        // A cluster patch's elements come from several input triangles.
        for f in scene.mesh.facets(i) {
            let s = by_source.entry(f.source).or_insert((0.0, Rgb64::ZERO));
            s.0 += f.area;
            s.1 += f.area * ej.to_f64();
        }
    }
    by_source
        .into_iter()
        .filter_map(|(source, (area, sum))| {
            let t = scene.triangles.get(source as usize)?;
            let normal = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).normalize_or_zero();
            if area <= 0.0 || normal == DVec3::ZERO {
                return None;
            }
            let exitance = (sum / area).to_f32();
            Some(Emitter {
                source,
                area: t.area(),
                corners: t.p,
                centroid: (t.p[0] + t.p[1] + t.p[2]) / 3.0,
                normal,
                exitance,
                luminous: exitance.luminance().max(1e-12) as f64,
                set: 0,
            })
        })
        .collect()
}
