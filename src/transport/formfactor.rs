//! Form factors F_ij with occlusion.
//!
//! For a pair of patches (i, j):
//! 1. **Unoccluded factor.** The point-to-polygon factor from a point x on i to the whole
//!    triangle j is exact (Lambert's contour integral, after clipping j to the hemisphere
//!    above x). It is averaged over quadrature points on i: one point (the centroid) for
//!    distant pairs, 4, 16, 64 or 256 points (midpoint rule on a regular subdivision) as the
//!    pair gets closer relative to its size, so adjacent patches stay accurate.
//!    The same is done from j to i, and the pair's coupling `A_i F_ij = A_j F_ji` is the
//!    mean of the two estimates: reciprocity holds exactly by construction.
//! 2. **Visibility.** The fraction of unblocked segments between stratified random points
//!    on i and j, traced through the [`Bvh`]. Strongly coupled pairs get more rays
//!    (up to [`FormFactorOptions::max_rays`]); the random streams are seeded by the pair,
//!    so a bake is deterministic.
//!
//! One-sidedness: a patch only sends and receives on its front. A point x on i sees j
//! only if x is in front of j's plane; j is clipped to the half-space in front of i.
//!
//! The result is a dense row-major n×n `f32` matrix with `F[i*n + j] = F_ij`.

use std::f64::consts::PI;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{DVec3, Vec3A};
use rayon::prelude::*;
use serde::Serialize;

use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::{Facet, Mesh};
use crate::sampling::{sample_triangle, Rng};

/// Quality knobs of the form-factor pass. Part of the cache key.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct FormFactorOptions {
    /// Most visibility rays for one pair.
    pub max_rays: u32,
    /// Rays per unit of max(F_ij, F_ji), before clamping to [probe_rays, max_rays].
    pub rays_per_ff: f64,
    /// Rays every pair gets first; if they disagree, the pair gets `max_rays`.
    pub probe_rays: u32,
}

impl Default for FormFactorOptions {
    fn default() -> Self {
        FormFactorOptions {
            max_rays: 24,
            rays_per_ff: 400.0,
            probe_rays: 4,
        }
    }
}

/// Exact form factor from a differential area at `x` with unit normal `n` to the planar
/// convex polygon `poly` (unoccluded; the part of `poly` below x's tangent plane is cut
/// away). The polygon's orientation does not matter.
pub fn point_to_polygon(x: DVec3, n: DVec3, poly: &[DVec3]) -> f64 {
    // Clip to the half-space n·(p − x) ≥ 0 (Sutherland–Hodgman); a triangle gives ≤ 4
    // vertices, a quad ≤ 5.
    let mut buf = [DVec3::ZERO; 8];
    let mut m = 0usize;
    let k = poly.len();
    for a in 0..k {
        let pa = poly[a] - x;
        let pb = poly[(a + 1) % k] - x;
        let (ha, hb) = (n.dot(pa), n.dot(pb));
        if ha >= 0.0 && m < buf.len() {
            buf[m] = pa;
            m += 1;
        }
        if ((ha > 0.0 && hb < 0.0) || (ha < 0.0 && hb > 0.0)) && m < buf.len() {
            buf[m] = pa + (pb - pa) * (ha / (ha - hb));
            m += 1;
        }
    }
    if m < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for a in 0..m {
        let r0 = buf[a];
        let r1 = buf[(a + 1) % m];
        let c = r0.cross(r1);
        let cl = c.length();
        if cl <= 1e-300 {
            continue;
        }
        let theta = cl.atan2(r0.dot(r1));
        sum += theta * n.dot(c) / cl;
    }
    (sum / (2.0 * PI)).abs()
}

/// Barycentric midpoint-rule points for 4^level sub-triangles (levels 0..=4).
pub(crate) fn quadrature_tables() -> [Vec<DVec3>; 5] {
    fn rec(a: DVec3, b: DVec3, c: DVec3, level: u32, out: &mut Vec<DVec3>) {
        if level == 0 {
            out.push((a + b + c) / 3.0);
            return;
        }
        let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
        rec(a, ab, ca, level - 1, out);
        rec(ab, b, bc, level - 1, out);
        rec(ca, bc, c, level - 1, out);
        rec(ab, bc, ca, level - 1, out);
    }
    std::array::from_fn(|l| {
        let mut v = Vec::new();
        rec(DVec3::X, DVec3::Y, DVec3::Z, l as u32, &mut v);
        v
    })
}

/// Precomputed per-patch data for the pair loop.
pub(crate) struct PatchGeo {
    /// The corners of a single-triangle patch (of a cluster patch: its first element's).
    pub c: [DVec3; 3],
    pub centroid: DVec3,
    pub n: DVec3,
    pub area: f64,
    /// The longest edge of a triangle; the bounding box's diagonal of a cluster.
    pub size: f64,
    /// The largest distance from the centroid to a corner: a sphere around `centroid`
    /// that holds the patch.
    pub radius: f64,
    pub source: u32,
    /// The elements of a cluster patch; None for a single triangle.
    pub cluster: Option<Elements>,
}

/// The elements of a cluster patch. The cumulative area shares are kept apart from the
/// facets, so that picking an element by area reads one compact array.
pub(crate) struct Elements {
    pub facets: Box<[Facet]>,
    /// The share of the patch's area up to and including each element (the last is 1).
    pub cum: Box<[f64]>,
}

/// Distances beyond this many element sizes (√(2 × area)) take a cluster element as a
/// differential area in [`PatchGeo::seen_from`].
const FAR_ELEMENT: f64 = 8.0;

/// A point of a patch with the normal and scene triangle of the element it lies on.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PatchPoint {
    pub x: DVec3,
    pub n: DVec3,
    pub source: u32,
}

impl PatchGeo {
    /// The point of the patch at (u, v) ∈ [0, 1)²: `sample_triangle` on a triangle; on a
    /// cluster, `u` first picks the element by area and is rescaled within it.
    pub(crate) fn point(&self, u: f64, v: f64) -> PatchPoint {
        let Some(elems) = &self.cluster else {
            return PatchPoint {
                x: sample_triangle(&self.c, u, v),
                n: self.n,
                source: self.source,
            };
        };
        let cum = &elems.cum;
        let k = cum.partition_point(|&c| c <= u).min(cum.len() - 1);
        let lo = if k == 0 { 0.0 } else { cum[k - 1] };
        let (f, hi) = (&elems.facets[k], cum[k]);
        let u = ((u - lo) / (hi - lo).max(1e-300)).clamp(0.0, 1.0);
        PatchPoint {
            x: sample_triangle(&f.corners, u, v),
            n: f.normal,
            source: f.source,
        }
    }

    /// The patch's elements as facets: itself when it is a single triangle.
    pub(crate) fn facets(&self) -> impl Iterator<Item = Facet> + '_ {
        let single = self.cluster.is_none().then_some(Facet {
            corners: self.c,
            normal: self.n,
            centroid: self.centroid,
            area: self.area,
            source: self.source,
        });
        single
            .into_iter()
            .chain(self.cluster.iter().flat_map(|e| e.facets.iter().copied()))
    }

    /// The unoccluded factor from a point `x` with normal `n` to the whole patch: the
    /// exact point-to-polygon factor of each element whose front faces `x`.
    pub(crate) fn seen_from(&self, x: DVec3, n: DVec3) -> f64 {
        if self.cluster.is_none() {
            return if self.n.dot(x - self.centroid) > 0.0 {
                point_to_polygon(x, n, &self.c)
            } else {
                0.0
            };
        }
        let Some(elems) = &self.cluster else {
            return 0.0;
        };
        // An element far from x (beyond FAR_ELEMENT × its size) as a differential area:
        // the same factor to within (size / distance)², without the contour integral.
        elems
            .facets
            .iter()
            .filter(|f| f.normal.dot(x - f.centroid) > 0.0)
            .map(|f| {
                let d = f.centroid - x;
                let r2 = d.length_squared();
                if r2 > FAR_ELEMENT * FAR_ELEMENT * 2.0 * f.area {
                    n.dot(d).max(0.0) * (-f.normal.dot(d)).max(0.0) * f.area / (PI * r2 * r2)
                } else {
                    point_to_polygon(x, n, &f.corners)
                }
            })
            .sum()
    }
}

/// Mean point-to-polygon factor from `level`-quadrature points on `a` to patch `b`
/// (`quad` the tables of [`quadrature_tables`]). A cluster patch shares the level's points
/// among its elements by area (at least one each), so its cost stays about a triangle's
/// times the elements of `b`.
pub(crate) fn directed(a: &PatchGeo, b: &PatchGeo, quad: &[Vec<DVec3>; 5], level: usize) -> f64 {
    if a.cluster.is_none() && b.cluster.is_none() {
        let pts = &quad[level];
        let mut s = 0.0;
        for w in pts {
            let x = a.c[0] * w.x + a.c[1] * w.y + a.c[2] * w.z;
            // x must see b's front.
            if b.n.dot(x - b.centroid) <= 0.0 {
                continue;
            }
            s += point_to_polygon(x, a.n, &b.c);
        }
        return s / pts.len() as f64;
    }
    // The area-weighted mean over a's elements of the factor to all of b's, with the
    // level's points shared among a's elements and fewer of them the more elements b has.
    let nb = b.cluster.as_ref().map_or(1, |e| e.facets.len()) as f64;
    let budget = quad[level].len() as f64 * (8.0 / nb).min(1.0);
    let mut s = 0.0;
    for fa in a.facets() {
        let share = budget * fa.area / a.area;
        let l = (0..=level)
            .rev()
            .find(|&l| quad[l].len() as f64 <= share.max(1.0))
            .unwrap_or(0);
        let pts = &quad[l];
        let mut sa = 0.0;
        for w in pts {
            let x = fa.corners[0] * w.x + fa.corners[1] * w.y + fa.corners[2] * w.z;
            sa += b.seen_from(x, fa.normal);
        }
        s += fa.area * sa / pts.len() as f64;
    }
    s / a.area
}

/// True when some corner of `b` lies more than `tol` above `a`'s plane (above the plane of
/// some element of `a`, for a cluster).
///
/// For a cluster, `b`'s bounding sphere decides each element of `a` whose plane it does
/// not cross, and only the rest compare `b`'s corners one by one: the answer is the exact
/// one, in time about the elements of `a` plus those of `b`, not their product.
pub(crate) fn above(a: &PatchGeo, b: &PatchGeo, tol: f64) -> bool {
    let corners_above = |n: DVec3, o: DVec3| -> bool {
        match &b.cluster {
            None => b.c.iter().any(|p| n.dot(*p - o) > tol),
            Some(e) => e
                .facets
                .iter()
                .any(|f| f.corners.iter().any(|p| n.dot(*p - o) > tol)),
        }
    };
    let Some(elems) = &a.cluster else {
        return corners_above(a.n, a.centroid);
    };
    elems.facets.iter().any(|fa| {
        let h = fa.normal.dot(b.centroid - fa.centroid);
        if h - b.radius > tol {
            true
        } else if h + b.radius <= tol {
            false
        } else {
            corners_above(fa.normal, fa.centroid)
        }
    })
}

/// True when each of `a` and `b` has a corner in front of the other (by more than a
/// rounding tolerance): the pair can exchange light.
pub(crate) fn face_each_other(a: &PatchGeo, b: &PatchGeo) -> bool {
    let tol = 1e-9 + 1e-7 * (a.size + b.size);
    above(a, b, tol) && above(b, a, tol)
}

/// Computes the dense form-factor matrix. `progress` receives the finished fraction
/// (0..1) now and then, from any thread.
pub fn compute(
    mesh: &Mesh,
    bvh: &Bvh,
    opts: &FormFactorOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Vec<f32> {
    let n = mesh.len();
    let geo = patch_geometry(mesh);
    let quad = quadrature_tables();
    let mut f = vec![0f32; n * n];
    let total_pairs = (n * n.saturating_sub(1) / 2).max(1);
    let done = AtomicUsize::new(0);
    let last_report = AtomicUsize::new(0);

    // Pass 1: the symmetric coupling G_ij = A_i F_ij into the upper triangle.
    f.par_chunks_mut(n)
        .enumerate()
        .with_min_len(1)
        .for_each(|(i, row)| {
            for (j, g) in row.iter_mut().enumerate().skip(i + 1) {
                *g = coupling(&geo, i, j, bvh, opts, &quad);
            }
            let pairs = n - i - 1;
            let now = done.fetch_add(pairs, Ordering::Relaxed) + pairs;
            let step = total_pairs / 200 + 1;
            let prev = last_report.load(Ordering::Relaxed);
            if now >= prev + step
                && last_report
                    .compare_exchange(prev, now, Ordering::Relaxed, Ordering::Relaxed)
                    .is_ok()
            {
                progress(now as f64 / total_pairs as f64);
            }
        });
    divide_by_areas(&mut f, &geo);
    progress(1.0);
    f
}

/// Corners, centroid, normal, area, size and source triangle of every patch (and the
/// elements of cluster patches).
pub(crate) fn patch_geometry(mesh: &Mesh) -> Vec<PatchGeo> {
    (0..mesh.len())
        .map(|i| {
            let p = &mesh.patches[i];
            if let Some(c) = mesh.single_corners(i) {
                let size = (0..3)
                    .map(|k| c[k].distance(c[(k + 1) % 3]))
                    .fold(0.0, f64::max);
                let radius = c.iter().map(|q| q.distance(p.centroid)).fold(0.0, f64::max);
                return PatchGeo {
                    c,
                    centroid: p.centroid,
                    n: p.normal,
                    area: p.area,
                    size,
                    radius,
                    source: p.source,
                    cluster: None,
                };
            }
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            let mut radius = 0f64;
            let mut share = 0.0;
            let (facets, cum): (Vec<Facet>, Vec<f64>) = mesh
                .facets(i)
                .map(|f| {
                    for q in f.corners {
                        lo = lo.min(q);
                        hi = hi.max(q);
                        radius = radius.max(q.distance(p.centroid));
                    }
                    share += f.area / p.area;
                    (f, share)
                })
                .unzip();
            PatchGeo {
                c: facets[0].corners,
                centroid: p.centroid,
                n: p.normal,
                area: p.area,
                size: (hi - lo).length(),
                radius,
                source: p.source,
                cluster: Some(Elements {
                    facets: facets.into(),
                    cum: cum.into(),
                }),
            }
        })
        .collect()
}

/// The symmetric coupling `G_ij = ½ (A_i F_ij + A_j F_ji)` of patches i < j, m², with
/// visibility from rays: probes first, the full ray budget for partly hidden pairs.
fn coupling(
    geo: &[PatchGeo],
    i: usize,
    j: usize,
    bvh: &Bvh,
    opts: &FormFactorOptions,
    quad: &[Vec<DVec3>; 5],
) -> f32 {
    let (a, b) = (&geo[i], &geo[j]);
    if !face_each_other(a, b) {
        return 0.0;
    }
    let fij = directed(a, b, quad, quadrature_level(a, b));
    let fji = directed(b, a, quad, quadrature_level(b, a));
    let g = 0.5 * (a.area * fij + b.area * fji);
    if g <= 0.0 {
        return 0.0;
    }
    let fmax = (g / a.area).max(g / b.area);
    (g * visible_fraction(a, b, Rng::new(i, j), fmax, bvh, opts)) as f32
}

/// Quadrature level (0..=4) for points on `own` seeing `other`: finer as the pair gets
/// closer relative to its size.
pub(crate) fn quadrature_level(own: &PatchGeo, other: &PatchGeo) -> usize {
    let d = own.centroid.distance(other.centroid);
    let r = d / own.size.max(other.size * 0.5);
    match r {
        r if r > 8.0 => 0,
        r if r > 4.0 => 1,
        r if r > 2.0 => 2,
        r if r > 1.0 => 3,
        _ => 4,
    }
}

/// The unblocked fraction of segments between stratified random points of `a` and `b`.
/// A pair with factor `fmax` gets `fmax · rays_per_ff` rays within the options' bounds;
/// probes first, and a pair the probes see as partly hidden gets the full budget, so
/// shadow boundaries are resolved where they are.
pub(crate) fn visible_fraction(
    a: &PatchGeo,
    b: &PatchGeo,
    mut rng: Rng,
    fmax: f64,
    bvh: &Bvh,
    opts: &FormFactorOptions,
) -> f64 {
    let rays = ((fmax * opts.rays_per_ff).ceil() as u32)
        .clamp(opts.probe_rays, opts.max_rays.max(opts.probe_rays));
    let cast = |count: u32, rng: &mut Rng| -> u32 {
        let mut free = 0u32;
        // Stratify the first sample coordinate of both ends over the rays.
        for r in 0..count {
            let s = rng.stratum(r as usize, count as usize);
            let t = ((r * 7 + 3) % count) as f64 / count as f64;
            let x = a.point(s, rng.next_f64());
            let y = b.point(t + rng.next_f64() / count as f64, rng.next_f64());
            let blocked = bvh.occluded(
                Vec3A::from(x.x.as_vec3()),
                Vec3A::from(y.x.as_vec3()),
                [x.source, y.source],
            );
            free += u32::from(!blocked);
        }
        free
    };
    let probes = opts.probe_rays.min(rays);
    let mut free = cast(probes, &mut rng);
    let mut total = probes;
    let partial = free != 0 && free != probes;
    let budget = if partial {
        opts.max_rays.max(rays)
    } else {
        rays
    };
    if budget > total {
        free += cast(budget - total, &mut rng);
        total = budget;
    }
    free as f64 / total.max(1) as f64
}

/// Passes 2 and 3: `F_ji = G_ij / A_j` into the lower triangle, then `F_ij = G_ij / A_i`
/// in place.
fn divide_by_areas(f: &mut [f32], geo: &[PatchGeo]) {
    let n = geo.len();
    let ptr = SyncPtr(f.as_mut_ptr());
    (0..n).into_par_iter().for_each(|j| {
        let p = ptr;
        let inv = 1.0 / geo[j].area;
        for i in 0..j {
            // SAFETY: row j's lower part (j, i<j) is written only by this task; the
            // upper entries (i, j) it reads are not written in this pass.
            unsafe {
                let g = *p.0.add(i * n + j);
                *p.0.add(j * n + i) = (g as f64 * inv) as f32;
            }
        }
    });
    f.par_chunks_mut(n).enumerate().for_each(|(i, row)| {
        let inv = 1.0 / geo[i].area;
        for x in &mut row[i + 1..] {
            *x = (*x as f64 * inv) as f32;
        }
    });
}

#[derive(Clone, Copy)]
struct SyncPtr(*mut f32);
// SAFETY: used only for the disjoint writes documented at its use.
unsafe impl Send for SyncPtr {}
unsafe impl Sync for SyncPtr {}

/// Row sums of a row-major n×n matrix, in f64.
pub fn row_sums(f: &[f32], n: usize) -> Vec<f64> {
    f.par_chunks(n)
        .map(|r| r.iter().map(|&x| x as f64).sum())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_to_coaxial_square_matches_closed_form() {
        // Differential area to a parallel coaxial square of half-side a at distance c:
        // F = (2/π)·[ A/√(1+A²)·atan(B/√(1+A²)) + B/√(1+B²)·atan(A/√(1+B²)) ] with the
        // quarter-plate formula A = B = a/c summed over the four quarters.
        let (a, c) = (0.7f64, 1.3f64);
        let (x, y) = (a / c, a / c);
        let quarter = (1.0 / (2.0 * PI))
            * (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
                + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan());
        let poly = [
            DVec3::new(-a, -a, c),
            DVec3::new(a, -a, c),
            DVec3::new(a, a, c),
            DVec3::new(-a, a, c),
        ];
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &poly);
        assert!(
            (f - 4.0 * quarter).abs() < 1e-12,
            "{f} vs {}",
            4.0 * quarter
        );
    }

    #[test]
    fn polygon_behind_the_tangent_plane_is_clipped() {
        // An infinite-ish vertical wall centred on x: half of it is above the plane.
        let w = 1e4;
        let poly = [
            DVec3::new(-w, -w, 1.0),
            DVec3::new(w, -w, 1.0),
            DVec3::new(w, w, 1.0),
            DVec3::new(-w, w, 1.0),
        ];
        // Normal along +y: the wall at z = 1 fills a quarter... of the hemisphere view:
        // the projected area of a half-plane seen edge-on from its edge direction is 1/2.
        let f = point_to_polygon(DVec3::ZERO, DVec3::Y, &poly);
        assert!((f - 0.5).abs() < 1e-3, "{f}");
    }
}
