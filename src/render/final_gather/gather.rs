//! The final gather: the indirect light at a visible point, from cosine-weighted rays that
//! read the solved radiosity where they land.
//!
//! With cosine-weighted directions the irradiance is `E = π · mean(L)`, and a Lambertian
//! surface's radiance is `L = B/π`, so `E = mean(B)` over the rays. A ray reads, per
//! group, the radiosity *reflected* where it lands (`B − E` for groups whose emission the
//! direct part lights, `B` otherwise), Gouraud-interpolated over the shading vertices and
//! read bilinearly from the grid corners around the hit ([`Reflected`]), so nothing steps
//! at patch edges. A ray that meets the back of a
//! surface reads nothing (surfaces reflect on their front), and one that leaves the
//! scene reads nothing. Directions are stratified on a √n × √n grid with a random offset
//! per point, so neighbouring pixels' errors are independent and the filter removes them.

use glam::DVec3;
use rayon::prelude::*;

use super::lights::GroupLights;
use super::FinalScene;
use crate::color::Rgb;
use crate::transport::formfactor::Rng;

/// Reads the reflected radiosity at a point where a gather ray landed close by: `(point,
/// patch, generator, per group RGB out)`.
pub(super) type NearHit<'a> = dyn FnMut(DVec3, u32, &mut Rng, &mut [f32]) + 'a;

/// A gather ray that lands closer than this many times the mean patch size (√ of the mean
/// area) of the side it meets reads the light at the point it lands, not the patch's.
pub(super) const NEAR: f32 = 1.0;

/// The reflected radiosity at unit group weight (lm/m²) that gather rays read, per
/// corner of the patch lookup's grids ([`PatchLocator::grid_sides`]) and group,
/// `[corner][group][rgb]`: the Gouraud-interpolated radiosity of the patch under each
/// corner (of the nearest patch, for a corner beside the triangle), so a ray reads it
/// bilinearly from the four corners around its hit, with no search for the patch. The
/// corners are about a mean patch apart.
///
/// [`PatchLocator::grid_sides`]: crate::geometry::patch_locator::PatchLocator::grid_sides
pub(super) struct Reflected {
    groups: usize,
    values: Vec<f32>,
}

/// Bytes per group a [`Reflected`] holds at each grid corner, and while it is made at
/// each shading vertex.
pub(super) const REFLECTED_BYTES_PER_POINT_AND_GROUP: u64 = 12;

impl Reflected {
    pub(super) fn new(scene: &FinalScene<'_>, lights: &GroupLights<'_>) -> Reflected {
        // Per group, the reflected radiosity at the shading vertices.
        let per_group: Vec<Vec<Rgb>> = match &scene.sky {
            Some(sky) => vec![scene.shading.vertex_values(sky.reflected)],
            None => scene
                .groups
                .par_iter()
                .enumerate()
                .map(|(k, col)| {
                    let mut r = col.b.clone();
                    if lights.explicit(k) {
                        for (v, e) in r.iter_mut().zip(&col.e) {
                            *v = (*v - e).max(0.0);
                        }
                    }
                    scene.shading.vertex_values(&r)
                })
                .collect(),
        };
        let g = per_group.len();
        let loc = scene.patches;
        let mut values = vec![0f32; loc.corner_count() * 3 * g];
        // Each side's run of corners, filled in parallel.
        let mut runs = Vec::new();
        let mut rest = values.as_mut_slice();
        for (tri, back, n) in loc.grid_sides() {
            let (run, tail) = std::mem::take(&mut rest).split_at_mut(n * 3 * g);
            runs.push((tri, back, run));
            rest = tail;
        }
        runs.into_par_iter().for_each(|(tri, back, run)| {
            for (c, out) in run.chunks_mut((3 * g).max(1)).enumerate() {
                let x = loc.grid_corner(tri, back, c);
                let Some((q, w)) = loc.locate_beside(tri, back, x) else {
                    continue;
                };
                let sv = scene.shading.corner[q as usize];
                for (k, vals) in per_group.iter().enumerate() {
                    let v = vals[sv[0] as usize] * w[0]
                        + vals[sv[1] as usize] * w[1]
                        + vals[sv[2] as usize] * w[2];
                    out[3 * k..3 * k + 3].copy_from_slice(&v.0);
                }
            }
        });
        Reflected { groups: g, values }
    }

    /// Adds to `out` (per group RGB) the gathered irradiance (lux) at `x` on patch `p`
    /// (normal `n`), from `rays` cosine-weighted rays; rays that leave the scene read the
    /// sky, weighted against the aimed sky rays of `aim` when given. A ray that lands closer than
    /// [`NEAR`] × the mean patch size of the side it meets asks `near(point, patch, values)` for the
    /// reflected radiosity there instead (per group RGB into `values`), when given: near
    /// a corner the patch's mean is not the light at the point. Returns the harmonic mean
    /// distance of the rays' hits (metres; infinite when every ray left the scene): the
    /// scale over which the gathered light can change (Ward's irradiance caching).
    pub(super) fn gather(
        &self,
        scene: &FinalScene<'_>,
        (x, n, p): (DVec3, DVec3, u32),
        rays: usize,
        rng: &mut Rng,
        (mut near, aim): (Option<&mut NearHit<'_>>, Option<&super::sky::SkyAim>),
        out: &mut [f32],
    ) -> f32 {
        let g = self.groups;
        let count = ray_count(rays);
        let side = count.isqrt();
        let (t, b) = crate::geometry::frame(n);
        let lift = 1e-6 * (1.0 + x.abs().max_element());
        let o = x + n * lift;
        let own = scene.mesh.patches[p as usize].source;
        let (du, dv) = (rng.next_f64(), rng.next_f64());
        let patches = scene.patches;
        let w = 1.0 / count as f32;
        // The reflected radiosity at close hits, reused from ray to ray.
        let mut near_values: Vec<f32> = Vec::new();
        let mut inverse_distances = 0f64;
        // The azimuth of column j is 2π (j + dv) / side: a rotation by a fixed step from
        // the first, so no ray computes a sine or cosine.
        let step = std::f64::consts::TAU / side as f64;
        let (step_sin, step_cos) = step.sin_cos();
        let (mut sin_phi, mut cos_phi) = (step * dv).sin_cos();
        for i in 0..count {
            if i > 0 && i % side == 0 {
                (cos_phi, sin_phi) = (
                    cos_phi * step_cos - sin_phi * step_sin,
                    sin_phi * step_cos + cos_phi * step_sin,
                );
            }
            let u1 = ((i % side) as f64 + du) / side as f64;
            let r = u1.sqrt();
            let d = t * (r * cos_phi) + b * (r * sin_phi) + n * (1.0 - u1).max(0.0).sqrt();
            let hit = scene
                .patches
                .nearest_side(scene.bvh, o, d, Some(own), false);
            if let Some((th, _, _)) = hit {
                inverse_distances += 1.0 / (th as f64).max(1e-9);
            }
            let Some((th, tri, back)) = hit else {
                // Out of the scene: the sky (through any glazing), as radiosity π L, or
                // weighted against the aimed sky rays.
                if let Some(sky) = &scene.sky {
                    let l = sky.outside(o, d, false) as f64;
                    let v = match aim {
                        Some(a) => {
                            let pc = count as f64 * n.dot(d) / std::f64::consts::PI;
                            l * n.dot(d) / (pc + sky.aimed_density(a, d))
                        }
                        None => std::f64::consts::PI * l / count as f64,
                    };
                    Rgb::column_mut(out)[0] += Rgb::splat(v as f32);
                }
                continue;
            };
            if !patches.faces(tri, back, d) {
                // The back of a one-sided surface: it reflects nothing this way.
                continue;
            }
            let at = o + d * th as f64;
            if let Some(f) = near.as_mut() {
                if th < NEAR * patches.patch_size(tri, back) {
                    if let Some(q) = patches.locate(tri, back, at) {
                        near_values.clear();
                        near_values.resize(out.len(), 0.0);
                        f(at, q, rng, &mut near_values);
                        for (o, v) in out.iter_mut().zip(&near_values) {
                            *o += w * v;
                        }
                    }
                    continue;
                }
            }
            let Some((c, [wa, wb, wc, wd])) = patches.grid_weights(tri, back, at) else {
                continue;
            };
            let rows = c.map(|c| &self.values[3 * g * c as usize..3 * g * (c as usize + 1)]);
            for (k, o) in out.iter_mut().enumerate() {
                *o += w * (wa * rows[0][k] + wb * rows[1][k] + wc * rows[2][k] + wd * rows[3][k]);
            }
        }
        (count as f64 / inverse_distances) as f32
    }
}

/// The rays [`Reflected::gather`] traces when asked for `rays`: a whole square grid.
pub(super) fn ray_count(rays: usize) -> usize {
    let side = (rays as f64).sqrt().ceil().max(1.0) as usize;
    side * side
}
