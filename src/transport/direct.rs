//! Direct light from luminaires, with shadows.
//!
//! At a receiver point the illuminance is `Σ_k w_k I(ω_k) cos θ_k / d_k² · V_k` over the
//! points that stand for the luminaire ([`Luminaire::for_each_emitter`]): its photometric
//! centre, or, for a receiver within five times its luminous opening's size, a grid over
//! the opening, each with its own shadow ray (so near an area luminaire shadows have
//! penumbrae).
//!
//! Per patch, the direct illuminance is the average of that over points
//! spread evenly over the triangle: the centroids of its 4^k congruent sub-triangles.
//! Every patch starts at k = 1 (4 points). A patch whose points disagree on visibility
//! (a shadow edge crosses it) is refined to k = 3 (64 points), so penumbra-free point
//! shadows are resolved to 1/64 of a patch. The shadow ray runs from the point, lifted a
//! hair off its surface, to the luminaire; the patch's own input triangle is skipped.
//!
//! That direct illuminance `D` becomes the first reflection `ρ D` in the transfer, which
//! carries it through every further bounce (see [`crate::transport::transfer`]).

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use crate::color::{Rgb, Rgb64};
use crate::geometry::bvh::Bvh;
use crate::geometry::lifted;
use crate::geometry::mesh::{Facet, Mesh};
use crate::photometry::Luminaire;
use crate::scene::Scene;

/// Barycentric (u, v) of the centroids of the 4^level sub-triangles of a triangle.
pub(crate) fn sub_centroids(level: u32) -> Vec<(f64, f64)> {
    // Sub-triangles in barycentric space, starting from the whole triangle.
    let mut tris = vec![[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]];
    for _ in 0..level {
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let m = |p: (f64, f64), q: (f64, f64)| ((p.0 + q.0) / 2.0, (p.1 + q.1) / 2.0);
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        tris = next;
    }
    tris.iter()
        .map(|[a, b, c]| ((a.0 + b.0 + c.0) / 3.0, (a.1 + b.1 + c.1) / 3.0))
        .collect()
}

/// Whether the segment from `x` (on a surface with normal `n`) to `p` is free.
pub(crate) fn visible(bvh: &Bvh, x: DVec3, n: DVec3, p: DVec3, skip: u32) -> bool {
    let o = Vec3A::from(lifted(x, n).as_vec3());
    !bvh.occluded(o, Vec3A::from(p.as_vec3()), [skip, u32::MAX])
}

/// Shadowed illuminance (lux) of luminaire `l` at `x` (normal `n`), and whether any and
/// whether every lit emitter point was visible. `skip` is a triangle the rays ignore.
pub(crate) fn shadowed(
    bvh: &Bvh,
    l: &Luminaire,
    x: DVec3,
    n: DVec3,
    skip: u32,
) -> (f64, bool, bool) {
    let (mut e, mut any, mut all) = (0.0, false, true);
    l.for_each_emitter(x, |p, w| {
        let ek = w * l.illuminance_from(p, x, n);
        if ek > 0.0 {
            if visible(bvh, x, n, p, skip) {
                e += ek;
                any = true;
            } else {
                all = false;
            }
        }
    });
    (e, any, all && any)
}

/// Direct illuminance (lux, luminous) of one luminaire on patch `j`, averaged over the patch
/// (area-weighted over the elements of a cluster patch).
fn patch_illuminance(
    mesh: &Mesh,
    bvh: &Bvh,
    l: &Luminaire,
    j: usize,
    coarse: &[(f64, f64)],
    fine: &[(f64, f64)],
) -> f64 {
    let p = &mesh.patches[j];
    if p.elements.len() == 1 {
        let f = mesh.facets(j).next().expect("a patch has an element");
        return facet_illuminance(bvh, l, &f, coarse, fine);
    }
    let sum: f64 = mesh
        .facets(j)
        .map(|f| f.area * facet_illuminance(bvh, l, &f, coarse, fine))
        .sum();
    sum / p.area
}

/// Direct illuminance (lux, luminous) of one luminaire on one facet, averaged over it.
fn facet_illuminance(
    bvh: &Bvh,
    l: &Luminaire,
    p: &Facet,
    coarse: &[(f64, f64)],
    fine: &[(f64, f64)],
) -> f64 {
    let reach = 0.5 * l.opening.largest_dimension();
    if p.normal.dot(l.position - p.centroid) <= -reach {
        // The luminaire (all of its opening) is behind the patch plane.
        return 0.0;
    }
    let c = p.corners;
    let at = |&(u, v): &(f64, f64)| c[0] + (c[1] - c[0]) * u + (c[2] - c[0]) * v;
    let sample = |pts: &[(f64, f64)]| -> (f64, usize) {
        let mut sum = 0.0;
        // Points with every lit emitter visible, and points with some visible.
        let (mut free, mut some) = (0, 0);
        for q in pts {
            let (e, any, all) = shadowed(bvh, l, at(q), p.normal, p.source);
            sum += e;
            some += any as usize;
            free += all as usize;
        }
        (
            sum / pts.len() as f64,
            if free == some { free } else { usize::MAX },
        )
    };
    let (e, free) = sample(coarse);
    if free == 0 || free == coarse.len() {
        // All lit or all shadowed: refine only the irradiance gradient, cheaply, when the
        // luminaire is close compared with the patch (no rays needed beyond the coarse ones).
        if free == 0 {
            return 0.0;
        }
        let d = (l.position - p.centroid).length();
        let size = (c[1] - c[0]).length().max((c[2] - c[0]).length());
        if size < 0.25 * d {
            return e;
        }
    }
    sample(fine).0
}

/// Per light group, the direct illuminance of its luminaires on every patch at unit weight
/// (lux, n × 3 interleaved, coloured by each luminaire's colour); None for groups without
/// luminaires.
pub fn group_direct(scene: &Scene, mesh: &Mesh, bvh: &Bvh) -> Vec<Option<Vec<f32>>> {
    let coarse = sub_centroids(1);
    let fine = sub_centroids(3);
    scene
        .lights
        .iter()
        .map(|g| {
            if g.luminaires.is_empty() {
                return None;
            }
            Some(patches_direct(
                mesh,
                bvh,
                g.luminaires.iter().map(|l| (l, Rgb::ONE)),
                &coarse,
                &fine,
            ))
        })
        .collect()
}

/// The direct illuminance of `luminaires`, each at its RGB weight, on every patch (lux,
/// n × 3 interleaved, coloured by each luminaire's colour), as the bake computes a
/// group's: a request's placed luminaires get exactly the light they would get baked.
pub fn weighted_direct<'a>(
    mesh: &Mesh,
    bvh: &Bvh,
    luminaires: impl Iterator<Item = (&'a Luminaire, Rgb)> + Clone + Sync,
) -> Vec<f32> {
    patches_direct(mesh, bvh, luminaires, &sub_centroids(1), &sub_centroids(3))
}

fn patches_direct<'a>(
    mesh: &Mesh,
    bvh: &Bvh,
    luminaires: impl Iterator<Item = (&'a Luminaire, Rgb)> + Clone + Sync,
    coarse: &[(f64, f64)],
    fine: &[(f64, f64)],
) -> Vec<f32> {
    let per_patch: Vec<Rgb64> = (0..mesh.len())
        .into_par_iter()
        .with_min_len(64)
        .map(|j| {
            let mut acc = Rgb64::ZERO;
            for (l, w) in luminaires.clone() {
                let e = patch_illuminance(mesh, bvh, l, j, coarse, fine);
                acc += e * (l.color * w).to_f64();
            }
            acc
        })
        .collect();
    per_patch.iter().flat_map(|a| a.to_f32().0).collect()
}

/// Direct illuminance (lux per channel) of `luminaires` at point `x` on a receiver facing
/// `n`, per point, with shadows (sampled over near luminous openings).
pub fn point_illuminance(bvh: &Bvh, luminaires: &[Luminaire], x: DVec3, n: DVec3) -> Rgb64 {
    weighted_point_illuminance(bvh, luminaires.iter().map(|l| (l, Rgb::ONE)), x, n)
}

/// [`point_illuminance`] of luminaires each at an RGB weight.
pub fn weighted_point_illuminance<'a>(
    bvh: &Bvh,
    luminaires: impl Iterator<Item = (&'a Luminaire, Rgb)>,
    x: DVec3,
    n: DVec3,
) -> Rgb64 {
    let mut acc = Rgb64::ZERO;
    for (l, w) in luminaires {
        let (e, _, _) = shadowed(bvh, l, x, n, u32::MAX);
        acc += e * (l.color * w).to_f64();
    }
    acc
}

/// Σ over the group's luminaires of lumens × colour, and of A·D (the direct flux landing
/// on patches), per channel, at unit weight.
pub fn group_flux(
    g: &crate::scene::LightGroup,
    area: &[f32],
    direct: Option<&[f32]>,
) -> (Rgb64, Rgb64) {
    let emitted = g
        .luminaires
        .iter()
        .map(|l| l.lumens * l.color.to_f64())
        .sum();
    let mut landed = Rgb64::ZERO;
    if let Some(d) = direct {
        for (&a, d) in area.iter().zip(Rgb::column(d)) {
            landed += a as f64 * d.to_f64();
        }
    }
    (emitted, landed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sub_centroids_cover_the_triangle_evenly() {
        for level in 0..4 {
            let pts = sub_centroids(level);
            assert_eq!(pts.len(), 4usize.pow(level));
            // Their mean is the triangle's centroid.
            let (su, sv) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
            let n = pts.len() as f64;
            assert!((su / n - 1.0 / 3.0).abs() < 1e-12 && (sv / n - 1.0 / 3.0).abs() < 1e-12);
            assert!(pts.iter().all(|&(u, v)| u > 0.0 && v > 0.0 && u + v < 1.0));
        }
    }
}
