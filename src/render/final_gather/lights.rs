//! Direct light at a visible point, per light group, computed exactly.
//!
//! - **Point luminaires**: each luminaire's unoccluded illuminance is bounded first,
//!   without trigonometry: its peak intensity in the band of directions the point lies in
//!   ([`Luminaire::peak_intensities`]) times the receiver's cosine over the squared
//!   distance (a near luminaire, seen as an area, is computed over its opening,
//!   [`Luminaire::for_each_emitter`]). Every luminaire whose bound is at least
//!   [`SIGNIFICANT`] of the bounds' sum over all groups gets its shadow rays and its exact
//!   illuminance. The rest, the tail, is estimated without bias by a few luminaires drawn
//!   in proportion to their bounds, each one's exact shadowed illuminance weighted by the
//!   tail's sum over its bound.
//! - **Emissive surfaces**: each emitting input triangle that faces the point and gives at
//!   least [`SIGNIFICANT`] of its unoccluded light gives its exitance times the exact
//!   unoccluded point-to-triangle form factor, times the visible share of that factor,
//!   from stratified shadow rays weighted by the factor's kernel (more rays for brighter
//!   triangles). Where the shaft from the point to the triangle's coplanar set is clear
//!   of every other triangle ([`Shaft`]), the share is exactly 1 and no ray is traced. The rest, the tail, is estimated without bias by one triangle drawn in
//!   proportion to its light, with one ray.
//!   A group with more than [`MAX_EMITTER_TRIANGLES`] emitting triangles leaves its
//!   emission to the gather instead ([`GroupLights::explicit`]).

use std::collections::BTreeMap;

use glam::DVec3;

use super::specular::Lobe;
use super::FinalScene;
use crate::color::{Rgb, Rgb64};
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::geometry::shaft::{coplanar_sets, Shaft};
use crate::photometry::Luminaire;
use crate::transport::direct::{shadowed, visible};
use crate::transport::formfactor::{point_to_polygon, sample_triangle, Rng};

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

/// Shadow rays to an emitting triangle from which its shaft is tested first
/// ([`Shaft`]): a clear shaft takes the place of the rays. A test costs about as much as
/// four rays on the Cornell box, so a triangle given fewer traces them.
const SHAFT_MIN_RAYS: u32 = 4;

/// Emitting triangles per group handled exactly; a group with more is gathered.
pub(super) const MAX_EMITTER_TRIANGLES: usize = 1024;

/// One emitting input triangle of a group.
struct Emitter {
    /// Its index among the scene's triangles.
    source: u32,
    /// Area, m².
    area: f64,
    corners: [DVec3; 3],
    centroid: DVec3,
    normal: DVec3,
    /// Exitance at unit group weight, lm/m².
    exitance: Rgb,
    /// Its luminous value.
    luminous: f64,
    /// Its set of coplanar neighbours in [`Sources::sets`].
    set: u32,
}

/// Bands of the cosine to a luminaire's aim in its [`Bound`].
const BANDS: usize = 64;

/// What bounds the luminaires' unoccluded illuminance cheaply, every group's in one
/// list, field by field (f32), so the loop over them runs in vector lanes.
#[derive(Default)]
struct Bounds {
    /// (group, luminaire within it).
    who: Vec<(u32, u32)>,
    /// Positions, m.
    pos: [Vec<f32>; 3],
    /// Unit aims.
    aim: [Vec<f32>; 3],
    /// Receivers closer than this (squared, m²) see the luminaire as an area: their
    /// bound is the exact illuminance over the opening.
    near2: Vec<f32>,
    /// Peak intensity per band of the cosine to the aim, cd (rounded up).
    peak: Vec<[f32; BANDS]>,
}

impl Bounds {
    fn push(&mut self, who: (u32, u32), l: &Luminaire) {
        let mut peak = [0f32; BANDS];
        for (p, v) in peak.iter_mut().zip(l.peak_intensities(BANDS)) {
            *p = (v * (1.0 + 1e-6)) as f32;
        }
        let near = crate::photometry::AREA_DISTANCE_FACTOR * l.opening.largest_dimension();
        self.who.push(who);
        for a in 0..3 {
            self.pos[a].push(l.position[a] as f32);
            self.aim[a].push(l.aim[a] as f32);
        }
        self.near2.push((near * near) as f32);
        self.peak.push(peak);
    }

    /// Into `out`, per luminaire, a bound on its unoccluded illuminance (lux) at `x`
    /// facing `n` (0 where it gives none), or −1 where `x` is near enough that it is an
    /// area (its exact value is wanted).
    fn lux(&self, x: DVec3, n: DVec3, out: &mut Vec<f32>) {
        let (x, n) = (x.as_vec3(), n.as_vec3());
        let count = self.who.len();
        out.clear();
        out.resize(count, 0.0);
        let [px, py, pz] = &self.pos;
        let [ax, ay, az] = &self.aim;
        for j in 0..count {
            let (vx, vy, vz) = (x.x - px[j], x.y - py[j], x.z - pz[j]);
            let d2 = vx * vx + vy * vy + vz * vz;
            let cos_receiver = -(n.x * vx + n.y * vy + n.z * vz);
            let inv = 1.0 / d2.sqrt();
            let cos_aim = (vx * ax[j] + vy * ay[j] + vz * az[j]) * inv;
            // NaN (x on the luminaire) casts to band 0; its bound is then NaN·0 below.
            let band = (((cos_aim + 1.0) * (0.5 * BANDS as f32)) as usize).min(BANDS - 1);
            let b = self.peak[j][band] * cos_receiver * inv / d2;
            out[j] = if d2 < self.near2[j] {
                -1.0
            } else if cos_receiver > 0.0 && b > 0.0 {
                b
            } else {
                0.0
            };
        }
    }
}

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

/// Reused buffers of one thread.
#[derive(Default)]
pub(super) struct Scratch {
    /// Per group RGB direct illuminance of the current sample, lux.
    pub(super) lux: Vec<f32>,
    /// The same at a point a gather ray landed on close by.
    pub(super) near: Vec<f32>,
    /// Luminaires that light the point: (group, luminaire, bound on its lux, the run of
    /// `points` that stands for it when near, else empty).
    candidates: Vec<(u32, u32, f64, (u32, u32))>,
    /// The opening points of the luminaires near the point, with each point's unoccluded
    /// illuminance (lux), computed once for both the choice and the shadowed light.
    points: Vec<(DVec3, f64)>,
    /// Per luminaire, its bound at the point ([`Bounds::lux`]).
    bound: Vec<f32>,
    /// Emitting triangles seen: (group, triangle, form factor, luminous light).
    emitters: Vec<(u32, u32, f64, f64)>,
    /// The coplanar sets whose shaft was tested at the current point: (group, set,
    /// whether it was clear).
    shafts: Vec<(u32, u32, bool)>,
    /// The emitting triangles a specular lobe's light samples went to at the current
    /// point ([`GroupLights::specular_emitters`]).
    pub(super) sampled: Vec<Sampled>,
}

/// An emitting triangle that a specular lobe's light samples went to: the reflection
/// rays that meet it weigh their share against these ([`Sampled::ray_weight`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Sampled {
    /// Its index among the scene's triangles.
    pub(super) source: u32,
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
    pub(super) fn ray_weight(&self, d: DVec3, r: f64, pdf: f64, rays: usize) -> f64 {
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

    /// Adds to `out` (per group RGB, lux) the direct illuminance at `x` on patch `p`
    /// (normal `n`), with shadow rays as `rays` says; and with a specular `lobe`, to
    /// `highlights` (per group RGB, cd/m²) the point luminaires' light it reflects
    /// ([`super::specular`]).
    pub(super) fn direct(
        &self,
        (x, n, p): (DVec3, DVec3, u32),
        rays: Rays,
        rng: &mut Rng,
        scratch: &mut Scratch,
        out: &mut [f32],
        specular: Option<(&Lobe, &mut [f32])>,
    ) {
        // Below, the third member is the scene triangle the shadow rays skip.
        let at = (x, n, self.mesh.patches[p as usize].source);
        let out = Rgb::column_mut(out);
        let specular = specular.map(|(lobe, h)| (lobe, Rgb::column_mut(h)));
        self.luminaires(at, rays, rng, scratch, out, specular);
        self.emitters(at, rays, rng, scratch, out);
    }

    /// Point luminaires of every group: those whose bound is at least
    /// [`Rays::significant`] of all groups' bounds together get their shadow rays and
    /// exact light; the rest, the tail, [`Rays::tail_draws`] luminaires drawn in
    /// proportion to their bounds, each weighted by the tail's sum over its bound and the
    /// number of draws (an unbiased estimate of the tail's light per group). The bounds
    /// are of the unit-weight light, so the rays depend on the geometry alone and each
    /// group's image stays linear; a room's luminaires spend no rays on those of the
    /// rooms beyond its walls one by one.
    fn luminaires(
        &self,
        (x, n, skip): (DVec3, DVec3, u32),
        rays: Rays,
        rng: &mut Rng,
        scratch: &mut Scratch,
        out: &mut [Rgb],
        mut specular: Option<(&Lobe, &mut [Rgb])>,
    ) {
        let (cand, points) = (&mut scratch.candidates, &mut scratch.points);
        cand.clear();
        points.clear();
        self.bounds.lux(x, n, &mut scratch.bound);
        let mut total = 0.0;
        for (&(k, i), &b) in self.bounds.who.iter().zip(&scratch.bound) {
            let (c, run) = if b < 0.0 {
                // Near: its exact light over the opening, point by point.
                let l = &self.groups[k as usize].luminaires[i as usize];
                let start = points.len() as u32;
                let mut sum = 0.0;
                l.for_each_emitter(x, |p, w| {
                    let e = w * l.illuminance_from(p, x, n);
                    if e > 0.0 {
                        points.push((p, e));
                        sum += e;
                    }
                });
                (sum, (start, points.len() as u32))
            } else {
                (b as f64, (0, 0))
            };
            if c > 0.0 {
                cand.push((k, i, c, run));
                total += c;
            }
        }
        let cut = rays.significant() * total;
        let mut tail = 0.0;
        let mut add = |k: u32, i: u32, run: (u32, u32), weight: f64| {
            let l = &self.groups[k as usize].luminaires[i as usize];
            let e = if run.0 == run.1 {
                shadowed(self.bvh, l, x, n, skip).0
            } else {
                points[run.0 as usize..run.1 as usize]
                    .iter()
                    .filter(|(p, _)| visible(self.bvh, x, n, *p, skip))
                    .map(|(_, e)| e)
                    .sum()
            };
            let lux = (e * weight * l.color.to_f64()).to_f32();
            out[k as usize] += lux;
            if let Some((lobe, highlights)) = specular.as_mut() {
                // The opening's half angle, halved again for the half vector.
                let to = l.position - x;
                let spread = 0.25 * l.opening.largest_dimension() / to.length().max(1e-9);
                highlights[k as usize] += lux * lobe.brdf(to, spread);
            }
        };
        for &(k, i, c, run) in cand.iter() {
            if c >= cut {
                add(k, i, run, 1.0);
            } else {
                tail += c;
            }
        }
        if tail <= 0.0 {
            return;
        }
        let draws = rays.tail_draws();
        for _ in 0..draws {
            // The drawn one: where the running sum passes r (the last of the tail should
            // rounding leave r unspent).
            let r = rng.next_f64() * tail;
            let mut sum = 0.0;
            let mut drawn = None;
            for &(k, i, c, run) in cand.iter().filter(|&&(_, _, c, _)| c < cut) {
                drawn = Some((k, i, c, run));
                sum += c;
                if r < sum {
                    break;
                }
            }
            if let Some((k, i, c, run)) = drawn {
                add(k, i, run, tail / (c * draws as f64));
            }
        }
    }

    /// Emitting triangles of every group: exact form factor × visible share. The triangles
    /// that give at least [`Rays::significant`] of the light of all groups together get
    /// up to `rays` shadow rays each (by their share); the rest, the tail, one triangle
    /// drawn in proportion to its light, weighted by the tail's total over its own (an
    /// unbiased estimate of their sum). Shares are of the unit-weight light, so the rays
    /// depend on the geometry alone and each group's image stays linear; a room's panels
    /// spend no rays on the panels of the rooms beyond its walls one by one.
    fn emitters(
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
            let mut r = (j as f64 + rng.next_f64()) / draws as f64 * tail;
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
    pub(super) fn specular_emitters(
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
            for a in 0..side {
                for b in 0..side {
                    let u = (a as f64 + rng.next_f64()) / side as f64;
                    let v = (b as f64 + rng.next_f64()) / side as f64;
                    let y = sample_triangle(&e.corners, u, v);
                    let to = y - x;
                    let r = to.length();
                    let d = to / r;
                    let (cos_x, cos_y) = (n.dot(d), -e.normal.dot(d));
                    if !(cos_x > 0.0 && cos_y > 0.0) {
                        continue;
                    }
                    let f = lobe.brdf(d, 0.0);
                    if f.luminance() <= 0.0 || !visible(self.bvh, x, n, y, skip) {
                        continue;
                    }
                    // Density per solid angle of a uniform point on the triangle.
                    let light = r * r / (e.area * cos_y);
                    let w = 1.0 - sampled.ray_weight(d, r, lobe.pdf(d), rays);
                    sum += f * (cos_x / light * w / m as f64) as f32;
                }
            }
            out[k as usize] += sum * e.exitance * std::f32::consts::FRAC_1_PI;
        }
    }

    /// Whether the shaft from `x` to group `k`'s coplanar set `set` is clear
    /// ([`Bvh::clear_of`]): every shadow ray to its triangles is then free. Each set's
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
        let lift = 1e-6 * (1.0 + x.abs().max_element());
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
        let m = side as f64;
        for a in 0..side {
            for b in 0..side {
                let u = (a as f64 + rng.next_f64()) / m;
                let v = (b as f64 + rng.next_f64()) / m;
                let y = sample_triangle(&e.corners, u, v);
                let d = y - x;
                let r2 = d.length_squared();
                let w = n.dot(d) * -e.normal.dot(d) / (r2 * r2);
                if w.is_nan() || w <= 0.0 {
                    continue;
                }
                if visible(self.bvh, x, n, y, skip) {
                    sums.free += w;
                } else {
                    sums.hidden += w;
                }
            }
        }
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
fn emitters_of(scene: &FinalScene<'_>, k: usize, e: &[f32]) -> Vec<Emitter> {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The bounds that choose the shadow rays bound the exact unoccluded illuminance of
    /// each of office-floor's 91 luminaires (two IES files, rectangular openings), at
    /// random points and normals: a luminaire drawn in proportion to its bound must
    /// never have a bound of 0 where it gives light, or the estimate would be biased.
    #[test]
    fn luminaire_bounds_hold_the_exact_illuminance() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office-floor");
        let scene = crate::scene::Scene::load(&dir).unwrap();
        let mut bounds = Bounds::default();
        let ls: Vec<&Luminaire> = scene.lights.iter().flat_map(|g| &g.luminaires).collect();
        for (i, l) in ls.iter().enumerate() {
            bounds.push((0, i as u32), l);
        }
        assert!(ls.len() > 50, "{} luminaires", ls.len());
        let (lo, hi) = scene.bounds();
        let mut rng = Rng::new(8, 9);
        let (mut lit, mut near, mut out) = (0, 0, Vec::new());
        for _ in 0..3000 {
            let x = lo + (hi - lo) * DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            let n = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - 1.0;
            let n = n.normalize();
            bounds.lux(x, n, &mut out);
            for (l, &b) in ls.iter().zip(&out) {
                let exact = l.illuminance(x, n);
                if b < 0.0 {
                    near += 1;
                    continue;
                }
                let grazing = 1e-4 * l.lumens / (x - l.position).length_squared();
                assert!(
                    b as f64 >= exact * (1.0 - 1e-4) || exact < grazing,
                    "bound {b} below the exact {exact} lux"
                );
                lit += usize::from(exact > 0.0);
            }
        }
        assert!(lit > 10_000 && near > 0, "{lit} lit, {near} near");
    }
}
