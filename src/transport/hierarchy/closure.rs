//! Closure: each patch's links, summed over the patch and its ancestors, are its form
//! factors to the rest of the scene, `S_i = Σ_j F_ij`, and must equal the part of its
//! hemisphere that sees a front face, `1 − escape_i` (1 in a closed scene).
//!
//! The links estimate `S_i` with an error of about ε per link. An independent estimate of
//! `1 − escape_i` comes from [`super::HierarchyOptions::closure_rays`] stratified,
//! cosine-distributed rays from stratified points of the patch: the fraction that hits a
//! side of some triangle that is a patch (its front, or either side of a two-sided
//! surface): a ray that leaves the scene or hits a one-sided surface's back carries light
//! that no patch receives. The two are combined by their variances (the rays' binomial
//! variance, and 1 % of `S_i` for the links), and the patch's gathered irradiance is scaled
//! by `σ_i = combined / S_i`. Where no ray escapes, the scene is closed around the patch:
//! the combined value is exactly 1, so in a closed scene every patch's form factors sum to
//! 1 up to float rounding.
//!
//! σ stays within `[1 / MAX_CLOSURE_SCALE, MAX_CLOSURE_SCALE]`. The links' error is about
//! ε per link, far below a factor of two; a larger disagreement is geometry the links
//! cannot resolve, not an error to scale away. Typically a face pressed against another
//! (a rug on a floor, the back of a two-sided panel against a wall): the rays, lifted off
//! the face, all hit the other, while its links see almost nothing. Scaling such a patch's
//! irradiance by 1/S_i (10⁶ and more on a real model) amplified stray light between the
//! two faces until the solve diverged.

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use crate::geometry::bvh::Bvh;
use crate::geometry::ray_offset;
use crate::sampling::Rng;
use crate::transport::formfactor::PatchGeo;

/// Relative standard deviation assumed for a patch's link sum.
const LINK_SUM_REL_SD: f64 = 0.01;

/// The largest factor by which closure scales a patch's gathered irradiance, up or down.
pub const MAX_CLOSURE_SCALE: f64 = 2.0;

/// The sides of a scene triangle that are patches: what a closure ray counts as a hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sides {
    /// The front only, facing along this unit normal (counter-clockwise).
    Front(DVec3),
    /// Both sides (a two-sided surface: a patch per side).
    Both,
}

impl Sides {
    /// True when a ray travelling along `d` that hits the triangle lands on a patch.
    fn receives(self, d: DVec3) -> bool {
        match self {
            Sides::Front(n) => n.dot(d) < 0.0,
            Sides::Both => true,
        }
    }
}

/// For each patch of `patches`: the fraction of cosine-weighted rays that hit a patch
/// side of a triangle. `sides[t]` says which sides of scene triangle t are patches. Each
/// patch's rays depend on its index only, so any subset gives the same values.
pub(crate) fn hit_fraction(
    geo: &[PatchGeo],
    bvh: &Bvh,
    sides: &[Sides],
    rays: u32,
    patches: &[u32],
) -> Vec<f64> {
    let side = (rays.max(1) as f64).sqrt().ceil() as u32;
    let total = side * side;
    patches
        .par_iter()
        .with_min_len(64)
        .map(|&i| {
            let (i, g) = (i as usize, &geo[i as usize]);
            let mut rng = Rng::new(i, usize::MAX);
            let (t1, t2) = tangents(g.n);
            let lift = ray_offset(g.centroid) + 1e-6 * g.size;
            let mut hits = 0u32;
            for a in 0..side {
                for b in 0..side {
                    let u1 = rng.stratum(a as usize, side as usize);
                    let u2 = rng.stratum(b as usize, side as usize);
                    let r = u1.sqrt();
                    let phi = 2.0 * std::f64::consts::PI * u2;
                    // A cluster patch's ray leaves the element its point lies on.
                    let p = g.point(rng.next_f64(), rng.next_f64());
                    let (t1, t2, n) = if g.cluster.is_some() {
                        let (t1, t2) = tangents(p.n);
                        (t1, t2, p.n)
                    } else {
                        (t1, t2, g.n)
                    };
                    let d = t1 * (r * phi.cos()) + t2 * (r * phi.sin()) + n * (1.0 - u1).sqrt();
                    let x = p.x + n * lift;
                    let hit = bvh.nearest(
                        Vec3A::from(x.as_vec3()),
                        Vec3A::from(d.as_vec3()),
                        0.0,
                        f32::INFINITY,
                    );
                    if let Some((_, t)) = hit {
                        if t != p.source && sides.get(t as usize).is_some_and(|s| s.receives(d)) {
                            hits += 1;
                        }
                    }
                }
            }
            hits as f64 / total as f64
        })
        .collect()
}

/// Two unit vectors completing `n` to an orthonormal basis.
fn tangents(n: DVec3) -> (DVec3, DVec3) {
    let a = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let t1 = n.cross(a).normalize();
    (t1, n.cross(t1))
}

/// The closure scale σ_i and the escape fraction of each patch from its link sum `s` and
/// the rays' hit fraction `h` (`rays` per patch).
pub fn combine(s: &[f64], h: &[f64], rays: u32) -> (Vec<f32>, Vec<f32>) {
    s.iter()
        .zip(h)
        .map(|(&s, &h)| {
            let vh = h * (1.0 - h) / rays.max(1) as f64;
            let vs = (LINK_SUM_REL_SD * s).powi(2);
            // Every ray hit a front face: closed. No ray hit: small targets may hide
            // between the rays, so the links decide.
            let closed = if h >= 1.0 {
                1.0
            } else if h <= 0.0 || vs == 0.0 {
                s
            } else {
                (s / vs + h / vh) / (1.0 / vs + 1.0 / vh)
            };
            let sigma = if s > 0.0 {
                // And never more than the whole hemisphere: σ·S ≤ 1.
                (closed / s)
                    .clamp(1.0 / MAX_CLOSURE_SCALE, MAX_CLOSURE_SCALE)
                    .min(1.0 / s)
            } else {
                1.0
            };
            (sigma as f32, (1.0 - closed).max(0.0) as f32)
        })
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_closed_patch_sums_to_one() {
        let (sigma, escape) = combine(&[0.97], &[1.0], 256);
        assert!((sigma[0] as f64 * 0.97 - 1.0).abs() < 1e-6);
        assert_eq!(escape[0], 0.0);
    }

    #[test]
    fn a_face_pressed_against_another_is_not_scaled_past_the_bound() {
        // Links that see almost nothing while every ray hits: 1/S would be 10⁷.
        let (sigma, _) = combine(&[1e-7], &[1.0], 256);
        assert_eq!(sigma[0] as f64, MAX_CLOSURE_SCALE);
        // Links that overshoot: scaled down, at most to the bound, and σ·S ≤ 1.
        let (sigma, _) = combine(&[3.0], &[0.5], 256);
        assert!((sigma[0] as f64 - 1.0 / 3.0).abs() < 1e-6, "{}", sigma[0]);
    }

    #[test]
    fn the_back_of_a_two_sided_triangle_receives() {
        let d = DVec3::new(0.0, 0.0, 1.0);
        assert!(Sides::Front(DVec3::new(0.0, 0.0, -1.0)).receives(d));
        assert!(!Sides::Front(DVec3::new(0.0, 0.0, 1.0)).receives(d));
        assert!(Sides::Both.receives(d));
    }
}
