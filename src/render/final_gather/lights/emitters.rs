//! The emitting surfaces' direct light: each emitting triangle's exact form factor times
//! its visible share (a clear shaft, or stratified shadow rays), and the light samples a
//! specular lobe takes of them.

use std::collections::BTreeMap;

use glam::DVec3;

use super::{GroupLights, Rays, Scratch, SIGNIFICANT};
use crate::color::{Rgb, Rgb64};
use crate::geometry::ray_offset;
use crate::geometry::shaft::Shaft;
use crate::render::final_gather::specular::Lobe;
use crate::render::final_gather::FinalScene;
use crate::sampling::{stratified_on_triangle, Rng};
use crate::transport::direct::visible;
use crate::transport::formfactor::point_to_polygon;

/// Shadow rays to an emitting triangle from which its shaft is tested first
/// ([`Shaft`]): a clear shaft takes the place of the rays. A test costs about as much as
/// four rays on the Cornell box, so a triangle given fewer traces them.
const SHAFT_MIN_RAYS: u32 = 4;
/// One emitting input triangle of a group.
pub(super) struct Emitter {
    /// Its index among the scene's triangles.
    pub(super) source: u32,
    /// Area, m².
    pub(super) area: f64,
    pub(super) corners: [DVec3; 3],
    pub(super) centroid: DVec3,
    pub(super) normal: DVec3,
    /// Exitance at unit group weight, lm/m².
    pub(super) exitance: Rgb,
    /// Its luminous value.
    pub(super) luminous: f64,
    /// Its set of coplanar neighbours in [`super::Sources::sets`].
    pub(super) set: u32,
}
/// An emitting triangle that a specular lobe's light samples went to: the reflection
/// rays that meet it weigh their share against these ([`Sampled::ray_weight`]).
#[derive(Debug, Clone, Copy)]
pub(in crate::render::final_gather) struct Sampled {
    /// Its index among the scene's triangles.
    pub(in crate::render::final_gather) source: u32,
    /// Light samples it got.
    samples: u32,
    /// Area, m².
    area: f64,
    /// Front normal.
    normal: DVec3,
}

impl Sampled {
    /// The balance-heuristic weight of a reflection ray drawn with density `pdf`
    /// (1/sr) among `rays` that meets this triangle at distance `r` along `d`.
    pub(in crate::render::final_gather) fn ray_weight(
        &self,
        d: DVec3,
        r: f64,
        pdf: f64,
        rays: usize,
    ) -> f64 {
        let cos = -self.normal.dot(d);
        if cos <= 0.0 {
            return 1.0;
        }
        let light = self.samples as f64 * r * r / (self.area * cos);
        let brdf = rays as f64 * pdf;
        brdf / (brdf + light)
    }
}

/// Light samples per emitting triangle for a specular lobe (a 2 × 2 jittered grid).
const SPECULAR_LIGHT_SAMPLES: u32 = 4;

impl GroupLights<'_> {
    /// Emitting triangles of every group: exact form factor × visible share. The triangles
    /// that give at least [`Rays::significant`] of the light of all groups together get
    /// up to `rays` shadow rays each (by their share); the rest, the tail, one triangle
    /// drawn in proportion to its light, weighted by the tail's total over its own (an
    /// unbiased estimate of their sum). Shares are of the unit-weight light, so the rays
    /// depend on the geometry alone and each group's image stays linear; a room's panels
    /// spend no rays on the panels of the rooms beyond its walls one by one.
    pub(super) fn emitters(
        &self,
        at: (DVec3, DVec3, u32),
        rays: Rays,
        rng: &mut Rng,
        scratch: &mut Scratch,
        out: &mut [Rgb],
    ) {
        let (x, n, _) = at;
        let cand = &mut scratch.emitters;
        let shafts = &mut scratch.shafts;
        shafts.clear();
        self.candidates(x, n, cand);
        let total: f64 = cand.iter().map(|c| c.3).sum();
        if total <= 0.0 {
            return;
        }
        let cut = rays.significant() * total;
        let draws = rays.tail_draws();
        let rays = rays.per_triangle();
        let budget = rays as f64;
        let mut tail = 0.0;
        for &(k, i, ff, part) in cand.iter() {
            if part < cut {
                tail += part;
                continue;
            }
            let e = &self.groups[k as usize].emitters[i as usize];
            let m = ((part / total * budget).ceil() as u32).clamp(1, rays);
            let seen = if m >= SHAFT_MIN_RAYS && self.shaft_clear(k, e.set, at, shafts) {
                1.0
            } else {
                self.seen(e, at, m, rng)
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
            for &(k, i, ff, part) in cand.iter() {
                if part >= cut {
                    continue;
                }
                drawn = Some((k, i, ff, part));
                if r < part {
                    break;
                }
                r -= part;
            }
            if let Some((k, i, ff, part)) = drawn {
                let e = &self.groups[k as usize].emitters[i as usize];
                let f = ff * self.seen(e, at, 1, rng) * tail / part / draws as f64;
                out[k as usize] += f as f32 * e.exitance;
            }
        }
    }

    /// Into `cand`, the emitting triangles whose front `x` (normal `n`) sees: (group,
    /// triangle, form factor, luminous light).
    fn candidates(&self, x: DVec3, n: DVec3, cand: &mut Vec<(u32, u32, f64, f64)>) {
        cand.clear();
        for (k, g) in self.groups.iter().enumerate() {
            for (i, e) in g.emitters.iter().enumerate() {
                if e.normal.dot(x - e.centroid) <= 0.0 {
                    continue;
                }
                let ff = point_to_polygon(x, n, &e.corners);
                if ff > 0.0 {
                    cand.push((k as u32, i as u32, ff, ff * e.luminous));
                }
            }
        }
    }

    /// Adds to `out` (per group RGB, cd/m²) the light of the emitting triangles that
    /// the specular `lobe` at `x` on patch `p` (normal `n`) reflects, from
    /// [`SPECULAR_LIGHT_SAMPLES`] shadow rays to points on each triangle that gives at
    /// least [`SIGNIFICANT`] of the point's diffuse light, weighted by the balance
    /// heuristic against the `rays` reflection rays drawn from the lobe (a lobe too
    /// narrow to be filtered takes no light samples). The triangles
    /// sampled are left in `scratch.sampled`; the reflection rays that meet them take
    /// the complementary weight ([`Sampled::ray_weight`]), the others' light in full.
    pub(in crate::render::final_gather) fn specular_emitters(
        &self,
        (x, n, p): (DVec3, DVec3, u32),
        (lobe, rays): (&Lobe, usize),
        rng: &mut Rng,
        scratch: &mut Scratch,
        out: &mut [f32],
    ) {
        let skip = self.mesh.patches[p as usize].source;
        scratch.sampled.clear();
        if !lobe.filtered() {
            // A near mirror: its reflection rays alone find the emitters, all but
            // without noise; a light sample landing in its narrow peak would add one.
            return;
        }
        let cand = &mut scratch.emitters;
        self.candidates(x, n, cand);
        let total: f64 = cand.iter().map(|c| c.3).sum();
        if total <= 0.0 {
            return;
        }
        let out = Rgb::column_mut(out);
        let side = (SPECULAR_LIGHT_SAMPLES as f64).sqrt().ceil() as u32;
        let m = side * side;
        for &(k, i, _, part) in cand.iter() {
            if part < SIGNIFICANT * total {
                continue;
            }
            let e = &self.groups[k as usize].emitters[i as usize];
            let sampled = Sampled {
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
                if f.luminance() <= 0.0 || !visible(self.bvh, x, n, y, skip) {
                    return;
                }
                // Density per solid angle of a uniform point on the triangle.
                let light = r * r / (e.area * cos_y);
                let w = 1.0 - sampled.ray_weight(d, r, lobe.pdf(d), rays);
                sum += f * (cos_x / light * w / m as f64) as f32;
            });
            out[k as usize] += sum * e.exitance * std::f32::consts::FRAC_1_PI;
        }
    }

    /// Whether the shaft from `x` to group `k`'s coplanar set `set` is clear
    /// ([`crate::geometry::bvh::Bvh::clear_of`]): every shadow ray to its triangles is then free. Each set's
    /// answer is kept in `memo` for the point.
    fn shaft_clear(
        &self,
        k: u32,
        set: u32,
        (x, n, skip): (DVec3, DVec3, u32),
        memo: &mut Vec<(u32, u32, bool)>,
    ) -> bool {
        if let Some(&(_, _, clear)) = memo.iter().find(|m| m.0 == k && m.1 == set) {
            return clear;
        }
        let (hull, normal) = &self.groups[k as usize].sets[set as usize];
        // The lift `visible` gives its rays.
        let lift = ray_offset(x);
        let clear = Shaft::new(x + n * lift, n, lift, hull, *normal)
            .is_some_and(|shaft| self.bvh.clear_of(&shaft, [skip, u32::MAX]));
        memo.push((k, set, clear));
        clear
    }

    /// The visible share of emitter `e`'s form factor at `x`: about `k` stratified points
    /// on the triangle (a `⌈√k⌉²` grid, jittered), each weighted by the form factor's
    /// kernel `cos θ cos θ' / r²`, so a hidden near corner of a large emitter counts for
    /// more than a hidden far one. The count never depends on what the rays find: an
    /// estimate refined only where its first rays disagree is biased (a small hidden part
    /// that the first rays miss reads as wholly visible).
    fn seen(&self, e: &Emitter, at: (DVec3, DVec3, u32), k: u32, rng: &mut Rng) -> f64 {
        let side = (k as f64).sqrt().ceil() as u32;
        let mut sums = Seen::default();
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
        (x, n, skip): (DVec3, DVec3, u32),
        side: u32,
        rng: &mut Rng,
        sums: &mut Seen,
    ) {
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

/// Kernel-weighted sums of an emitter's sample points.
#[derive(Default)]
struct Seen {
    free: f64,
    hidden: f64,
}

/// The emitting input triangles of group `k`, with their exitance at unit weight (the
/// area-weighted mean of their patches' emission `e`, lm/m²).
pub(super) fn emitters_of(scene: &FinalScene<'_>, k: usize, e: &[f32]) -> Vec<Emitter> {
    let mut by_source: BTreeMap<u32, (f64, Rgb64)> = BTreeMap::new();
    for (patch, ej) in scene.mesh.patches.iter().zip(Rgb::column(e)) {
        if patch.group != Some(k as u32) {
            continue;
        }
        if ej.iter().all(|&v| v <= 0.0) {
            continue;
        }
        let s = by_source.entry(patch.source).or_insert((0.0, Rgb64::ZERO));
        s.0 += patch.area;
        s.1 += patch.area * ej.to_f64();
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
