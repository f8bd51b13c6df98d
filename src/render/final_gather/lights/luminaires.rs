//! The point luminaires' direct light: a cheap bound on each one's unoccluded
//! illuminance chooses which get their own shadow rays, and the rest are drawn in
//! proportion to their bounds.

use glam::DVec3;

use super::{GroupLights, Pass, Scratch};
use crate::color::Rgb;
use crate::photometry::Luminaire;
use crate::render::final_gather::point::ShadowOrigin;
use crate::render::final_gather::specular::Lobe;
use crate::transport::direct::{shadowed, visible};

/// Bands of the cosine to a luminaire's aim in its [`Bounds`].
const BANDS: usize = 64;

/// What bounds the luminaires' unoccluded illuminance cheaply, every group's in one
/// list, field by field (f32), so the loop over them runs in vector lanes.
#[derive(Default)]
pub(super) struct Bounds {
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
    pub(super) fn push(&mut self, who: (u32, u32), l: &Luminaire) {
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
/// A luminaire that lights a point ([`GroupLights::luminaires`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct LuminaireCandidate {
    group: u32,
    /// Its index among the group's luminaires.
    luminaire: u32,
    /// A bound on its unoccluded illuminance at the point, lux (the exact value when near).
    bound: f64,
    /// The run of the scratch's opening points that stands for it when near, else empty.
    points: (u32, u32),
}

impl GroupLights<'_> {
    /// Point luminaires of every group: those whose bound is at least
    /// [`super::Rays::significant`] of all groups' bounds together get their shadow rays and
    /// exact light; the rest, the tail, [`super::Rays::tail_draws`] luminaires drawn in
    /// proportion to their bounds, each weighted by the tail's sum over its bound and the
    /// number of draws (an unbiased estimate of the tail's light per group). The bounds
    /// are of the unit-weight light, so the rays depend on the geometry alone and each
    /// group's image stays linear; a room's luminaires spend no rays on those of the
    /// rooms beyond its walls one by one.
    pub(super) fn luminaires(
        &self,
        pass: &mut Pass,
        out: &mut [Rgb],
        mut specular: Option<(&Lobe, &mut [Rgb])>,
    ) {
        let (at, rays) = (pass.at, pass.rays);
        let total = self.luminaire_candidates(at, pass.scratch);
        let (cand, points) = (&pass.scratch.candidates, &pass.scratch.points[..]);
        let cut = rays.significant() * total;
        let mut tail = 0.0;
        for c in cand.iter() {
            if c.bound >= cut {
                self.add_shadowed(c, 1.0, at, points, out, &mut specular);
            } else {
                tail += c.bound;
            }
        }
        if tail <= 0.0 {
            return;
        }
        let draws = rays.tail_draws();
        for _ in 0..draws {
            // The drawn one: where the running sum passes r (the last of the tail should
            // rounding leave r unspent).
            let r = pass.rng.next_f64() * tail;
            let mut sum = 0.0;
            let mut drawn = None;
            for c in cand.iter().filter(|c| c.bound < cut) {
                drawn = Some(c);
                sum += c.bound;
                if r < sum {
                    break;
                }
            }
            if let Some(c) = drawn {
                let weight = tail / (c.bound * draws as f64);
                self.add_shadowed(c, weight, at, points, out, &mut specular);
            }
        }
    }

    /// Into `scratch.candidates`, every luminaire that lights `at`, with a bound on its
    /// light ([`Bounds::lux`]), or where `at` is near, its exact light over the opening,
    /// point by point into `scratch.points`; returns the sum of their bounds.
    fn luminaire_candidates(&self, at: ShadowOrigin, scratch: &mut Scratch) -> f64 {
        let (x, n) = (at.position, at.normal);
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
                cand.push(LuminaireCandidate {
                    group: k,
                    luminaire: i,
                    bound: c,
                    points: run,
                });
                total += c;
            }
        }
        total
    }

    /// Adds to `out` `weight` × luminaire `c`'s shadowed illuminance at `at` (over its
    /// opening's `points` when near), and with a specular lobe, to its highlights the
    /// light the lobe reflects of it.
    fn add_shadowed(
        &self,
        c: &LuminaireCandidate,
        weight: f64,
        at: ShadowOrigin,
        points: &[(DVec3, f64)],
        out: &mut [Rgb],
        specular: &mut Option<(&Lobe, &mut [Rgb])>,
    ) {
        let (x, n, skip) = (at.position, at.normal, at.skip_triangle);
        let (k, run) = (c.group, c.points);
        let l = &self.groups[k as usize].luminaires[c.luminaire as usize];
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
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

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
