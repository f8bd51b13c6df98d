//! Closure: each patch's links, summed over the patch and its ancestors, are its form
//! factors to the rest of the scene, `S_i = Σ_j F_ij`, and must equal the part of its
//! hemisphere that sees a front face, `1 − escape_i` (1 in a closed scene).
//!
//! The links estimate `S_i` with an error of about ε per link. An independent estimate of
//! `1 − escape_i` comes from [`super::HierarchyOptions::closure_rays`] stratified,
//! cosine-distributed rays from stratified points of the patch: the fraction that hits the
//! front of some triangle (a ray that leaves the scene or hits a back face carries light
//! that no patch receives). The two are combined by their variances (the rays' binomial
//! variance, and 1 % of `S_i` for the links), and the patch's gathered irradiance is scaled
//! by `σ_i = combined / S_i`. Where no ray escapes, the scene is closed around the patch:
//! the combined value is exactly 1, so in a closed scene every patch's form factors sum to
//! 1 up to float rounding.

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use crate::geometry::bvh::Bvh;
use crate::geometry::ray_offset;
use crate::sampling::Rng;
use crate::transport::formfactor::PatchGeo;

/// Relative standard deviation assumed for a patch's link sum.
const LINK_SUM_REL_SD: f64 = 0.01;

/// For each patch of `patches`: the fraction of cosine-weighted rays that hit the front of
/// a triangle. `front[t]` is the unit front normal of scene triangle t. Each patch's rays
/// depend on its index only, so any subset gives the same values.
pub(crate) fn hit_fraction(
    geo: &[PatchGeo],
    bvh: &Bvh,
    front: &[DVec3],
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
                        if t != p.source && front.get(t as usize).is_some_and(|n| n.dot(d) < 0.0) {
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
            let sigma = if s > 0.0 { closed / s } else { 1.0 };
            (sigma as f32, (1.0 - closed).max(0.0) as f32)
        })
        .unzip()
}
