//! Daylight transport: what a surface or a point sees of the sky, the ground and the sun.
//!
//! Every ray that leaves the geometry upward sees the sky, downward the ground outside the
//! model (a uniform luminance), and the horizon is sharp. Openings are holes in the
//! geometry. Three products:
//!
//! - [`patch_sky_direct`]: per patch and per sky patch of the [`Subdivision`] (index 0 the
//!   ground), the direct illuminance at unit luminance, `D_k = ∫_{Ω_k, visible} cos θ dω`
//!   (lux per cd/m²), from stratified cosine-weighted rays over stratified points of the
//!   patch. The transfer carries `ρ D_k` through every bounce, one response per sky patch.
//! - [`SkyView`]: what one point sees of the sky, for integrating the continuous sky
//!   luminance rather than patch averages. The hemisphere is a 64 × 64 grid of cells of
//!   equal solid angle (the concentric disk mapping lifted by Lambert's equal-area map), so
//!   cells are about 2.5° wide everywhere, the receiver's horizon included; each ray
//!   carries its cell's cosine-weighted share. A cell whose centre ray differs from one of
//!   its eight neighbours' (blocked, sky or ground) is refined into 8 × 8 jittered rays,
//!   and a refined cell whose rays disagree passes the refinement on to its neighbours, so
//!   an edge, once found, is followed to its end. Edges are resolved to about 0.3°; an
//!   opening must span about a cell (2.5°) for a centre ray to find it.
//! - [`patch_sun_direct`] and [`point_sun_direct`]: the sun's direct illuminance with
//!   shadow rays (per patch 4 points, 64 where they disagree; per point one ray).

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use crate::daylight::tregenza::Subdivision;
use crate::daylight::Site;
use crate::geometry::bvh::Bvh;
use crate::geometry::glazing::Glazing;
use crate::geometry::mesh::{Facet, Mesh};
use crate::geometry::{frame, lifted};
use crate::sampling::{hashed_point, XorShift};

/// Rays per patch for [`patch_sky_direct`]: about this many in all, …
const PATCH_RAY_BUDGET: usize = 4 << 20;
/// … but at least and at most these per patch (rounded down to a square).
const PATCH_RAYS_MIN: usize = 256;
const PATCH_RAYS_MAX: usize = 1024;
/// The coarse grid of a [`SkyView`] and the refinement of a boundary cell.
const VIEW_GRID: usize = 64;
const VIEW_REFINE: usize = 8;

/// Sky patches of the daylight transfer: Tregenza's 145 and the ground.
pub fn subdivision() -> Subdivision {
    Subdivision::tregenza()
}

/// Far end of an escape ray: beyond anything in a scene of this size.
#[derive(Debug, Clone, Copy)]
pub struct Reach(f64);

impl Reach {
    /// The length, m.
    pub fn length(&self) -> f64 {
        self.0
    }

    /// For a scene within `lo..hi` (m).
    pub fn new(lo: DVec3, hi: DVec3) -> Reach {
        let d = (hi - lo).length();
        Reach(
            4.0 * (if d.is_finite() { d } else { 1.0 })
                + 1.0
                + 4.0 * lo.abs().max(hi.abs()).max_element(),
        )
    }
}

/// The concentric (Shirley–Chiu) map of the unit square onto the unit disk; equal areas
/// go to equal areas.
fn concentric(u: f64, v: f64) -> (f64, f64) {
    let (a, c) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    let (r, phi) = if a == 0.0 && c == 0.0 {
        (0.0, 0.0)
    } else if a.abs() > c.abs() {
        (a, std::f64::consts::FRAC_PI_4 * (c / a))
    } else {
        (
            c,
            std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (a / c),
        )
    };
    (r * phi.cos(), r * phi.sin())
}

/// The concentric map lifted to the hemisphere about `n` (frame `t`, `b`, `n`) by
/// projection: equal areas of the square are equal cosine-weighted solid angles.
fn cosine_dir(u: f64, v: f64, t: DVec3, b: DVec3, n: DVec3) -> DVec3 {
    let (x, y) = concentric(u, v);
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    (t * x + b * y + n * z).normalize()
}

/// The concentric map lifted to the hemisphere by Lambert's azimuthal equal-area map, in
/// the receiver's frame (z along the normal): equal areas of the square are equal solid
/// angles, and a disk radius ρ is at cos θ = 1 − ρ².
fn equal_area_local(u: f64, v: f64) -> DVec3 {
    let (x, y) = concentric(u, v);
    let r2 = (x * x + y * y).min(1.0);
    let s = (2.0 - r2).sqrt();
    DVec3::new(x * s, y * s, 1.0 - r2)
}

/// The cosine-weighted share of the fine cell of the [`SkyView`] grid centred at (u, v)
/// of the unit square, unnormalised: ∫ cos θ dω / π over the cell is 2 (1 − ρ²) × its
/// area in the square (dω = 2π dA over the unit disk's area π), by the midpoint rule.
fn fine_share_raw(u: f64, v: f64) -> f64 {
    let side = (VIEW_GRID * VIEW_REFINE) as f64;
    2.0 * equal_area_local(u, v).z / (side * side)
}

/// A fixed pseudo-random point in 0 … 1 × 0 … 1 for sub-cell (si, sj) of coarse cell
/// (i, j) of the [`SkyView`] grid.
fn jitter(i: usize, j: usize, si: usize, sj: usize) -> (f64, f64) {
    hashed_point((((j * VIEW_GRID + i) * VIEW_REFINE + sj) * VIEW_REFINE + si) as u64)
}

/// The cosine-weighted shares of the [`SkyView`] grid: per coarse cell (row-major) the sum
/// of its fine cells', and the factor that makes the whole hemisphere's shares sum to 1.
struct ViewShares {
    coarse: Vec<f64>,
    norm: f64,
}

fn view_shares() -> &'static ViewShares {
    static SHARES: std::sync::OnceLock<ViewShares> = std::sync::OnceLock::new();
    SHARES.get_or_init(|| {
        let (g, r) = (VIEW_GRID, VIEW_REFINE);
        let side = (g * r) as f64;
        let mut coarse = vec![0.0; g * g];
        for fj in 0..g * r {
            for fi in 0..g * r {
                let w = fine_share_raw((fi as f64 + 0.5) / side, (fj as f64 + 0.5) / side);
                coarse[(fj / r) * g + fi / r] += w;
            }
        }
        let norm = 1.0 / coarse.iter().sum::<f64>();
        coarse.iter_mut().for_each(|w| *w *= norm);
        ViewShares { coarse, norm }
    })
}

/// The share of light that reaches `o` from outside along unit `d`: 0 when the ray hits
/// an opaque triangle (other than `skip`), else the transmittance of the glazing it
/// crosses (1 through an opening).
pub fn transmitted(
    bvh: &Bvh,
    glazing: &Glazing,
    o: DVec3,
    d: DVec3,
    reach: Reach,
    skip: u32,
) -> f64 {
    let far = o + d * reach.0;
    if bvh.occluded(
        Vec3A::from(o.as_vec3()),
        Vec3A::from(far.as_vec3()),
        [skip, u32::MAX],
    ) {
        0.0
    } else {
        glazing.transmittance(o, far)
    }
}

/// Rays per patch for `n` patches (a square number).
fn patch_rays(n: usize) -> usize {
    let want = (PATCH_RAY_BUDGET / n.max(1)).clamp(PATCH_RAYS_MIN, PATCH_RAYS_MAX);
    let side = (want as f64).sqrt().floor() as usize;
    side * side
}

/// Per patch (rows) and sky patch of `sub` (columns, 0 = ground), the direct illuminance at
/// unit luminance, lux per cd/m² (n × K, row-major). Σ_k D_k ≤ π.
pub fn patch_sky_direct(
    mesh: &Mesh,
    bvh: &Bvh,
    glazing: &Glazing,
    site: &Site,
    sub: &Subdivision,
    reach: Reach,
) -> Vec<f32> {
    let k = sub.patches.len();
    let rays = patch_rays(mesh.len());
    let side = (rays as f64).sqrt() as usize;
    let rows: Vec<Vec<f32>> = (0..mesh.len())
        .into_par_iter()
        .with_min_len(16)
        .map(|i| {
            let single = mesh.patches[i].elements.len() == 1;
            let (t, b) = frame(mesh.patches[i].normal);
            let mut rng = XorShift::new(i as u64 + 1);
            let mut row = vec![0f64; k];
            for r in 0..rays {
                // Stratified direction cell, and a point of the patch from an independent
                // stratification (the cell index scrambled), so points and directions
                // decorrelate. A cluster patch's point picks its element, whose normal the
                // directions follow.
                let (cu, cv) = (r % side, r / side);
                let u = (cu as f64 + rng.next()) / side as f64;
                let v = (cv as f64 + rng.next()) / side as f64;
                let (p, mut a) = mesh.pick_facet(i, rng.next());
                let mut e = rng.next();
                let d = if single {
                    cosine_dir(u, v, t, b, p.normal)
                } else {
                    let (t, b) = frame(p.normal);
                    cosine_dir(u, v, t, b, p.normal)
                };
                if a + e > 1.0 {
                    a = 1.0 - a;
                    e = 1.0 - e;
                }
                let (c, g) = (p.corners, p.centroid);
                let x = g + (c[0] + (c[1] - c[0]) * a + (c[2] - c[0]) * e - g) * (1.0 - 1e-4);
                let tr = transmitted(bvh, glazing, lifted(x, p.normal), d, reach, p.source);
                if tr > 0.0 {
                    let (alt, az) = site.sky_position(d);
                    row[sub.patch_of(alt.to_radians(), az.to_radians())] += tr;
                }
            }
            let w = std::f64::consts::PI / rays as f64;
            row.into_iter().map(|x| (x * w) as f32).collect()
        })
        .collect();
    rows.concat()
}

/// What a ray sees: 0 blocked, 1 sky, 2 ground; and the transmittance on the way, bits.
type Class = (u8, u32);

/// The transmittance of a ray of class `k`.
#[inline]
fn share(k: Class) -> f32 {
    f32::from_bits(k.1)
}

/// Whether grid corner (i, j) of the coarse view grid lies on its rim.
#[inline]
fn rim(i: usize, j: usize) -> bool {
    let g = VIEW_GRID;
    i == 0 || j == 0 || i == g || j == g
}

/// Rays from one receiver point of a [`SkyView`].
struct Viewer<'a> {
    bvh: &'a Bvh,
    glazing: &'a Glazing,
    /// The point, off its surface.
    o: DVec3,
    /// The receiver's frame: tangent, bitangent, normal.
    t: DVec3,
    b: DVec3,
    n: DVec3,
    reach: Reach,
}

impl Viewer<'_> {
    /// The direction at (u, v) of the coarse grid, in cells.
    #[inline]
    fn dir(&self, u: f64, v: f64) -> DVec3 {
        let g = VIEW_GRID as f64;
        let l = equal_area_local(u / g, v / g);
        (self.t * l.x + self.b * l.y + self.n * l.z).normalize()
    }

    /// What the ray along unit `d` sees.
    #[inline]
    fn class(&self, d: DVec3) -> Class {
        let tr = transmitted(self.bvh, self.glazing, self.o, d, self.reach, u32::MAX) as f32;
        if tr <= 0.0 {
            (0, 0)
        } else if d.y >= 0.0 {
            (1, tr.to_bits())
        } else {
            (2, tr.to_bits())
        }
    }

    /// Whether the horizon crosses cell (i, j), whose centre ray is `d`.
    fn crosses_horizon(&self, i: usize, j: usize, d: DVec3) -> bool {
        let y = |a: usize, c: usize| self.dir((i + a) as f64, (j + c) as f64).y;
        let corners = [y(0, 0), y(1, 0), y(0, 1), y(1, 1)];
        corners.iter().any(|c| (*c >= 0.0) != (d.y >= 0.0))
    }

    /// The escaped rays of cell (i, j), refined into [`VIEW_REFINE`]² rays; whether they
    /// see otherwise than the cell's centre ray `centre` or than each other.
    fn refine(&self, i: usize, j: usize, centre: Class, rays: &mut Vec<([f32; 3], f32)>) -> bool {
        let (r, g) = (VIEW_REFINE, VIEW_GRID as f64);
        let norm = view_shares().norm;
        let mut mixed = false;
        for sj in 0..r {
            for si in 0..r {
                // The ray at a fixed random point of its sub-cell (the same for every
                // view): regular rows of rays alias with straight edges, such as a strip
                // two or three rows high.
                let (ju, jv) = jitter(i, j, si, sj);
                let u = i as f64 + (si as f64 + ju) / r as f64;
                let v = j as f64 + (sj as f64 + jv) / r as f64;
                let d = self.dir(u, v);
                let k = self.class(d);
                mixed |= k != centre;
                if k.0 != 0 {
                    let (cu, cv) = (
                        i as f64 + (si as f64 + 0.5) / r as f64,
                        j as f64 + (sj as f64 + 0.5) / r as f64,
                    );
                    let sub = norm * fine_share_raw(cu / g, cv / g);
                    rays.push((d.as_vec3().to_array(), sub as f32 * share(k)));
                }
            }
        }
        mixed
    }
}

/// The coarse grid of a [`SkyView`]: each cell's centre ray and what it sees, and what
/// the rays through the corners of the rim cells see.
struct Coarse {
    centres: Vec<(DVec3, Class)>,
    /// Rim corners (others `(u8::MAX, 0)`), (g + 1)² row-major.
    corners: Vec<Class>,
}

impl Coarse {
    fn trace(view: &Viewer) -> Coarse {
        let g = VIEW_GRID;
        let centres = (0..g * g)
            .map(|c| {
                let d = view.dir((c % g) as f64 + 0.5, (c / g) as f64 + 0.5);
                (d, view.class(d))
            })
            .collect();
        // The corners of the rim cells too: a cell on the rim (directions near the
        // receiver's plane) has no outer neighbour, and an edge (a window sill) that
        // crosses it between its centre and the plane shows only at its corners. Inner
        // cells have neighbours all round.
        let corners = (0..(g + 1) * (g + 1))
            .map(|c| {
                let (i, j) = (c % (g + 1), c / (g + 1));
                if rim(i, j) {
                    view.class(view.dir(i as f64, j as f64))
                } else {
                    (u8::MAX, 0)
                }
            })
            .collect();
        Coarse { centres, corners }
    }

    /// Whether cell (i, j), of class `k`, has a neighbour (of eight) or a rim corner that
    /// sees otherwise.
    fn differs(&self, i: usize, j: usize, k: Class) -> bool {
        let g = VIEW_GRID;
        let corner = |i: usize, j: usize| self.corners[j * (g + 1) + i];
        let at = |i: usize, j: usize| self.centres[j * g + i].1;
        let rim_differs = [(0, 0), (1, 0), (0, 1), (1, 1)]
            .iter()
            .any(|&(a, c)| rim(i + a, j + c) && corner(i + a, j + c) != k);
        // All eight neighbours: an edge that runs diagonally across the grid crosses a
        // cell whose four side neighbours all see as its centre does.
        let (i0, i1) = (i.saturating_sub(1), (i + 1).min(g - 1));
        let (j0, j1) = (j.saturating_sub(1), (j + 1).min(g - 1));
        rim_differs || (j0..=j1).any(|jj| (i0..=i1).any(|ii| at(ii, jj) != k))
    }
}

/// What a point sees of the sky and the ground: escaped directions with their
/// cosine-weighted share (shares of the whole hemisphere sum to 1), merged per 3° cell
/// ([`SkyView::merged`]).
#[derive(Debug, Clone, Default)]
pub struct SkyView {
    /// Unit scene directions of escaped rays, and each one's share.
    pub rays: Vec<([f32; 3], f32)>,
}

impl SkyView {
    /// Traces the view from `x` on a receiver facing unit `n`.
    pub fn trace(bvh: &Bvh, glazing: &Glazing, x: DVec3, n: DVec3, reach: Reach) -> SkyView {
        let n = n.normalize();
        let (t, b) = frame(n);
        let view = Viewer {
            bvh,
            glazing,
            o: lifted(x, n),
            t,
            b,
            n,
            reach,
        };
        let coarse = Coarse::trace(&view);
        let g = VIEW_GRID;
        let shares = &view_shares().coarse;
        let mut rays = Vec::new();
        // Cells to refine: those whose centre ray sees otherwise than a neighbour's, and
        // those the horizon crosses (it is sharp). A refined cell whose rays disagree
        // holds an edge, which goes on into its neighbours: they are refined too, so an
        // opening narrower than a cell, found by one centre ray, is followed along its
        // whole length. At most every cell is refined once.
        let mut todo: Vec<usize> = (0..g * g)
            .filter(|&c| {
                let (i, j) = (c % g, c / g);
                let (d, k) = coarse.centres[c];
                coarse.differs(i, j, k) || (k.0 != 0 && view.crosses_horizon(i, j, d))
            })
            .collect();
        let mut refined = vec![false; g * g];
        while let Some(c) = todo.pop() {
            if std::mem::replace(&mut refined[c], true) {
                continue;
            }
            let (i, j) = (c % g, c / g);
            if view.refine(i, j, coarse.centres[c].1, &mut rays) {
                for jj in j.saturating_sub(1)..=(j + 1).min(g - 1) {
                    for ii in i.saturating_sub(1)..=(i + 1).min(g - 1) {
                        if !refined[jj * g + ii] {
                            todo.push(jj * g + ii);
                        }
                    }
                }
            }
        }
        for (c, &(d, k)) in coarse.centres.iter().enumerate() {
            if !refined[c] && k.0 != 0 {
                rays.push((d.as_vec3().to_array(), shares[c] as f32 * share(k)));
            }
        }
        SkyView::merged(rays)
    }

    /// The rays merged per cell of Reinhart's MF:4 subdivision (2,305 sky patches of about
    /// 3°, and the ground): each cell keeps its share-weighted mean direction and the sum
    /// of its shares, so a view is a few hundred entries. The shares sum as before; a
    /// luminance is then read once per cell.
    fn merged(rays: Vec<([f32; 3], f32)>) -> SkyView {
        static CELLS: std::sync::OnceLock<Subdivision> = std::sync::OnceLock::new();
        let cells = CELLS.get_or_init(|| Subdivision::reinhart(4));
        let mut acc: std::collections::BTreeMap<usize, ([f64; 3], f64)> = Default::default();
        for (d, w) in rays {
            let alt = (d[1] as f64).clamp(-1.0, 1.0).asin();
            let az = (d[0] as f64).atan2(-(d[2] as f64));
            let e = acc.entry(cells.patch_of(alt, az)).or_default();
            for (a, &dc) in e.0.iter_mut().zip(&d) {
                *a += dc as f64 * w as f64;
            }
            e.1 += w as f64;
        }
        SkyView {
            rays: acc
                .into_values()
                .map(|(d, w)| {
                    let v = DVec3::from_array(d).normalize_or_zero();
                    (v.as_vec3().to_array(), w as f32)
                })
                .collect(),
        }
    }

    /// Illuminance, lux, from sky luminance `sky(d)` (cd/m², d upward) and a uniform ground
    /// of luminance `ground` (cd/m²): E = π Σ share · L.
    pub fn illuminance(&self, sky: impl Fn(DVec3) -> f64, ground: f64) -> f64 {
        let mut e = 0.0;
        for (d, w) in &self.rays {
            let l = if d[1] >= 0.0 {
                sky(DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64))
            } else {
                ground
            };
            e += *w as f64 * l;
        }
        std::f64::consts::PI * e
    }

    /// The sums that give the illuminance under the skies of fixed shape: the sky's
    /// share, the share weighted by the CIE overcast gradation (1 + 2 sin γ) / 3, and the
    /// ground's share. A uniform sky of luminance L gives π (L s₀ + L_g s₂), the overcast
    /// sky of zenith luminance L_z gives π (L_z s₁ + L_g s₂).
    pub fn shape_sums(&self) -> [f64; 3] {
        let mut s = [0.0; 3];
        for (d, w) in &self.rays {
            let w = *w as f64;
            if d[1] >= 0.0 {
                s[0] += w;
                s[1] += w * (1.0 + 2.0 * (d[1] as f64).min(1.0)) / 3.0;
            } else {
                s[2] += w;
            }
        }
        s
    }

    /// The view binned into the sky patches of `sub` (0 = ground): per patch, the direct
    /// illuminance at unit luminance, lux per cd/m².
    pub fn binned(&self, site: &Site, sub: &Subdivision) -> Vec<f32> {
        let mut out = vec![0f64; sub.patches.len()];
        for (d, w) in &self.rays {
            let d = DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64);
            let (alt, az) = site.sky_position(d);
            out[sub.patch_of(alt.to_radians(), az.to_radians())] +=
                std::f64::consts::PI * *w as f64;
        }
        out.into_iter().map(|x| x as f32).collect()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        16 * self.rays.capacity() + 24
    }
}

/// The sun's direct illuminance at point `x` on a receiver facing unit `n`, for the sun in
/// unit direction `s` with normal illuminance `e_n` (lux).
pub fn point_sun_direct(
    bvh: &Bvh,
    glazing: &Glazing,
    x: DVec3,
    n: DVec3,
    s: DVec3,
    e_n: f64,
    reach: Reach,
) -> f64 {
    let cos = n.dot(s);
    if cos <= 0.0 || e_n <= 0.0 {
        return 0.0;
    }
    e_n * cos * transmitted(bvh, glazing, lifted(x, n), s, reach, u32::MAX)
}

/// Per patch, the sun's direct illuminance (lux), averaged over 4 points of the patch, or 64
/// where they disagree on visibility.
pub fn patch_sun_direct(
    mesh: &Mesh,
    bvh: &Bvh,
    glazing: &Glazing,
    s: DVec3,
    e_n: f64,
    reach: Reach,
) -> Vec<f32> {
    if e_n <= 0.0 || s.y <= 0.0 {
        return vec![0.0; mesh.len()];
    }
    let coarse = super::direct::sub_centroids(1);
    let fine = super::direct::sub_centroids(3);
    (0..mesh.len())
        .into_par_iter()
        .with_min_len(64)
        .map(|i| {
            let lit = |p: &Facet| -> f64 {
                let cos = p.normal.dot(s);
                if cos <= 0.0 {
                    return 0.0;
                }
                let c = p.corners;
                // Per point, the share of the beam that reaches it.
                let lit = |pts: &[(f64, f64)]| -> Vec<f64> {
                    pts.iter()
                        .map(|&(u, v)| {
                            let x = c[0] + (c[1] - c[0]) * u + (c[2] - c[0]) * v;
                            transmitted(bvh, glazing, lifted(x, p.normal), s, reach, p.source)
                        })
                        .collect()
                };
                let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
                let free = lit(&coarse);
                let frac = if free.iter().all(|&f| f == free[0]) {
                    free[0]
                } else {
                    mean(&lit(&fine))
                };
                e_n * cos * frac
            };
            let p = &mesh.patches[i];
            if p.elements.len() == 1 {
                let f = mesh.facets(i).next().expect("a patch has an element");
                return lit(&f) as f32;
            }
            let sum: f64 = mesh.facets(i).map(|f| f.area * lit(&f)).sum();
            (sum / p.area) as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_concentric_map_is_cosine_weighted() {
        // The mean of cos θ over equal cells is ∫cos² / ∫cos = 2/3.
        let (t, b) = frame(DVec3::Y);
        let m = 200;
        let mut sum = 0.0;
        for j in 0..m {
            for i in 0..m {
                let d = cosine_dir(
                    (i as f64 + 0.5) / m as f64,
                    (j as f64 + 0.5) / m as f64,
                    t,
                    b,
                    DVec3::Y,
                );
                assert!((d.length() - 1.0).abs() < 1e-12 && d.y >= 0.0);
                sum += d.y;
            }
        }
        let mean = sum / (m * m) as f64;
        assert!((mean - 2.0 / 3.0).abs() < 1e-3, "{mean}");
    }

    #[test]
    fn the_equal_area_map_gives_equal_solid_angles() {
        // The mean of cos θ over cells of equal solid angle is ∫cos dω / 2π = 1/2, and a
        // cap θ < 60° holds 1 − cos 60° of the hemisphere's solid angle.
        let m = 400;
        let (mut sum, mut cap) = (0.0, 0usize);
        for j in 0..m {
            for i in 0..m {
                let d = equal_area_local((i as f64 + 0.5) / m as f64, (j as f64 + 0.5) / m as f64);
                assert!((d.length() - 1.0).abs() < 1e-12 && d.z >= 0.0);
                sum += d.z;
                cap += usize::from(d.z > 0.5);
            }
        }
        let n = (m * m) as f64;
        assert!((sum / n - 0.5).abs() < 1e-4, "{}", sum / n);
        // (The cap is a square of the unit square, 282 of 400 cells a side: 0.497.)
        assert!((cap as f64 / n - 0.5).abs() < 5e-3, "{}", cap as f64 / n);
        // The shares: the whole hemisphere sums to 1, and the cap θ < 60° to sin² 60°.
        let s = view_shares();
        assert!((s.coarse.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let g = VIEW_GRID;
        let in_cap: f64 = (0..g * g)
            .filter(|c| {
                let (i, j) = ((c % g) as f64 + 0.5, (c / g) as f64 + 0.5);
                equal_area_local(i / g as f64, j / g as f64).z > 0.5
            })
            .map(|c| s.coarse[c])
            .sum();
        // The cells whose centres lie in the cap fill a square of the unit square, of
        // half-side h (in units of the disk's radius); their share is ∫₀ʰ 2(1 − ρ²) 2ρ dρ.
        let half = g as f64 / 2.0;
        let h = ((0.5f64.sqrt() * half - 0.5).floor() + 1.0) / half;
        let want = 2.0 * h * h - h.powi(4);
        assert!((in_cap - want).abs() < 1e-4, "{in_cap} vs {want}");
    }

    #[test]
    fn an_open_point_sees_the_whole_sky_and_ground() {
        let bvh = Bvh::new(&[]);
        let reach = Reach::new(DVec3::ZERO, DVec3::ONE);
        let up = SkyView::trace(&bvh, &Glazing::none(), DVec3::ZERO, DVec3::Y, reach);
        assert!((up.illuminance(|_| 1.0, 0.0) - std::f64::consts::PI).abs() < 1e-5);
        // A vertical receiver sees half sky, half ground.
        let side = SkyView::trace(&bvh, &Glazing::none(), DVec3::ZERO, DVec3::X, reach);
        let sky = side.illuminance(|_| 1.0, 0.0);
        assert!((sky - std::f64::consts::PI / 2.0).abs() < 2e-3, "{sky}");
    }
}
