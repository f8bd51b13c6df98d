//! Illuminance at arbitrary points, gathered from a solved scene.
//!
//! `E(x, n) = Σ_j F(x → P_j) · V(x, P_j) · B_j`: the exact point-to-polygon factor of every
//! patch whose front faces x (clipped to the hemisphere above x), times the fraction of
//! visibility rays from x to stratified points on the patch that are unblocked. A point
//! lying on a surface sees the hemisphere above it: rays start a hair above the point.

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use crate::color::{Rgb, Rgb64};
use crate::geometry::bvh::Bvh;
use crate::geometry::lifted;
use crate::geometry::mesh::Mesh;
use crate::scene::Scene;
use crate::transport::formfactor::point_to_polygon;
use crate::transport::transfer::GroupColumns;

/// Rays every contributing patch gets first.
const PROBE_RAYS: u32 = 4;
/// Rays for a partly hidden patch, at least and at most.
const MIN_RAYS: u32 = 16;
const MAX_RAYS: u32 = 512;
/// Rays a partly hidden patch gets per unit share of the unoccluded illuminance.
const RAYS_PER_SHARE: f64 = 4096.0;

/// Illuminance (lux per channel) at `x` on a receiver facing `n`, for per-patch radiosity
/// `b` (n × 3 interleaved, lm/m²).
pub fn illuminance_at(mesh: &Mesh, bvh: &Bvh, b: &[f32], x: DVec3, n: DVec3) -> Rgb64 {
    let b_rgb = Rgb::column(b);
    let mut e = Rgb64::ZERO;
    for (j, w) in gather_weights(mesh, bvh, b, x, n) {
        e += w * b_rgb[j as usize].to_f64();
    }
    e
}

/// The gather as weights: `E(x) = Σ_j w_j · B_j` for every radiosity that is zero where
/// `importance` (n × 3) is zero. `w_j` is the point-to-patch factor times the visible
/// fraction of patch j.
///
/// Pass 1 finds every patch that can contribute and its unoccluded share of
/// `importance`; pass 2 traces visibility, giving a partly hidden patch rays in proportion
/// to its share, so penumbrae of bright sources are resolved finely. A patch whose share
/// is worth more than [`MIN_RAYS`] gets them without probing first.
pub fn gather_weights(
    mesh: &Mesh,
    bvh: &Bvh,
    importance: &[f32],
    x: DVec3,
    n: DVec3,
) -> Vec<(u32, f64)> {
    let b = Rgb::column(importance);
    let n = n.normalize();
    let o = Vec3A::from(lifted(x, n).as_vec3());
    let candidates: Vec<(usize, f64, Rgb64)> = (0..mesh.len())
        .into_par_iter()
        .with_min_len(256)
        .filter_map(|j| {
            let bj = b[j].to_f64();
            if bj == Rgb64::ZERO {
                return None;
            }
            let ff: f64 = mesh
                .facets(j)
                .filter(|f| f.normal.dot(x - f.centroid) > 0.0)
                .map(|f| point_to_polygon(x, n, &f.corners))
                .sum();
            (ff > 0.0).then_some((j, ff, bj))
        })
        .collect();
    let total: f64 = candidates
        .iter()
        .map(|(_, ff, bj)| ff * bj.luminance())
        .sum();
    candidates
        .par_iter()
        .with_min_len(64)
        .filter_map(|&(j, ff, bj)| {
            let mut state = (j as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
            let mut next = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            let mut cast = |count: u32| {
                let mut free = 0;
                for r in 0..count {
                    let (p, mut u) = mesh.pick_facet(j, (r as f64 + next()) / count as f64);
                    let mut v = next();
                    if u + v > 1.0 {
                        u = 1.0 - u;
                        v = 1.0 - v;
                    }
                    let (c, g) = (p.corners, p.centroid);
                    let y = g + (c[0] + (c[1] - c[0]) * u + (c[2] - c[0]) * v - g) * (1.0 - 1e-4);
                    let blocked = bvh.occluded(o, Vec3A::from(y.as_vec3()), [p.source, u32::MAX]);
                    free += u32::from(!blocked);
                }
                free
            };
            let share = if total > 0.0 {
                ff * bj.luminance() / total
            } else {
                0.0
            };
            let want = ((share * RAYS_PER_SHARE).ceil() as u32).clamp(MIN_RAYS, MAX_RAYS);
            // A patch worth more than the minimum gets its full budget at once: probes
            // that all agree could hide a penumbra across a bright patch.
            let (mut free, mut rays) = if share * RAYS_PER_SHARE > MIN_RAYS as f64 {
                (cast(want), want)
            } else {
                (cast(PROBE_RAYS), PROBE_RAYS)
            };
            if rays == PROBE_RAYS && free != 0 && free != PROBE_RAYS {
                free += cast(want - PROBE_RAYS);
                rays = want;
            }
            (free > 0).then(|| (j as u32, ff * free as f64 / rays as f64))
        })
        .collect()
}

/// Most gather weights the bake keeps over all grids of a scene (8 bytes each: 512 MB).
/// A grid that would pass it keeps none, and its points gather per request instead.
pub const MAX_GRID_WEIGHTS: u64 = 64 << 20;

/// One point's gather: (patch, weight) pairs.
type Weights = Vec<(u32, f64)>;

/// A grid's gather as weights, per point (compressed rows): the indirect illuminance at
/// point p for any radiosity B is `Σ w · B_j` over its row (lux per lm/m²), as
/// [`gather_weights`] gives it. The bake keeps them, so that a lighting state that is not
/// a sum of the groups (an emission vector, luminaires placed per request) has its grid
/// answered by one sparse product instead of a gather per point.
#[derive(Clone, Default, Debug, PartialEq)]
pub struct GridGather {
    /// Row p is `offsets[p] .. offsets[p + 1]`; points + 1 entries.
    pub offsets: Vec<u32>,
    pub patch: Vec<u32>,
    pub weight: Vec<f32>,
}

impl GridGather {
    /// The rows, checked: offsets rising from 0 to the weights' count, one row per point,
    /// patches below `n`. None when they are not consistent.
    pub fn from_parts(
        offsets: Vec<u32>,
        patch: Vec<u32>,
        weight: Vec<f32>,
        points: usize,
        n: usize,
    ) -> Option<GridGather> {
        if offsets.is_empty() && patch.is_empty() && weight.is_empty() {
            return Some(GridGather::default());
        }
        let ok = offsets.len() == points + 1
            && offsets.first() == Some(&0)
            && offsets.last().map(|&l| l as usize) == Some(patch.len())
            && patch.len() == weight.len()
            && offsets.windows(2).all(|w| w[0] <= w[1])
            && patch.iter().all(|&j| (j as usize) < n)
            && weight.iter().all(|w| w.is_finite() && *w >= 0.0);
        ok.then_some(GridGather {
            offsets,
            patch,
            weight,
        })
    }

    /// Points (rows); 0 when the weights were not kept ([`MAX_GRID_WEIGHTS`]).
    pub fn points(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The indirect illuminance at point `p` of a grid (`x`, facing `n`) for radiosity `b`
    /// (lux per channel): through the weights, or, where they were not kept, by a gather at
    /// the point with `b`'s magnitude as the rays' importance.
    pub fn indirect(
        &self,
        p: usize,
        b: &[f32],
        mesh: &Mesh,
        bvh: &Bvh,
        x: DVec3,
        nrm: DVec3,
    ) -> Rgb64 {
        if p < self.points() {
            return self.illuminance(p, Rgb::column(b));
        }
        let importance: Vec<f32> = b.iter().map(|v| v.abs()).collect();
        let rgb = Rgb::column(b);
        let mut e = Rgb64::ZERO;
        for (j, w) in gather_weights(mesh, bvh, &importance, x, nrm) {
            e += w * rgb[j as usize].to_f64();
        }
        e
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        4 * (self.offsets.len() + self.patch.len() + self.weight.len()) as u64
    }

    /// The gathered illuminance at point `p` (lux per channel) from radiosity `b` (lm/m²).
    pub fn illuminance(&self, p: usize, b: &[Rgb]) -> Rgb64 {
        let r = self.offsets[p] as usize..self.offsets[p + 1] as usize;
        let mut e = Rgb64::ZERO;
        for (&j, &w) in self.patch[r.clone()].iter().zip(&self.weight[r]) {
            e += w as f64 * b[j as usize].to_f64();
        }
        e
    }
}

/// Per grid of the scene and per light group: the illuminance at each grid point (lux,
/// points × 3 interleaved) for the group at unit weight: its luminaires' direct light with
/// shadow rays plus the gather ([`gather_weights`]) from its radiosity column `b`; and per
/// grid, the gather's weights ([`GridGather`]).
pub fn grid_columns(
    scene: &Scene,
    mesh: &Mesh,
    bvh: &Bvh,
    groups: &[GroupColumns],
) -> (Vec<Vec<Vec<f32>>>, Vec<GridGather>) {
    if scene.grids.is_empty() {
        return (vec![], vec![]);
    }
    // Importance for the gather's ray budget: every group's radiosity at unit weight, and
    // a floor of 10⁻⁶ of its mean on every patch, so that the weights reach the patches no
    // group lights too (light placed later may).
    let mut importance = vec![0f32; 3 * mesh.len()];
    for g in groups {
        for (a, b) in importance.iter_mut().zip(&g.b) {
            *a += b;
        }
    }
    let mean = importance.iter().map(|&v| v as f64).sum::<f64>() / importance.len().max(1) as f64;
    let floor = if mean > 0.0 {
        (1e-6 * mean) as f32
    } else {
        1.0
    };
    importance.iter_mut().for_each(|v| *v = v.max(floor));
    let mut kept = 0u64;
    scene
        .grids
        .iter()
        .map(|grid| {
            let n = DVec3::from_array(grid.normal);
            let rows: Vec<(Vec<Rgb>, Weights)> = grid
                .points
                .par_iter()
                .map(|p| {
                    let x = DVec3::from_array(*p);
                    let w = gather_weights(mesh, bvh, &importance, x, n);
                    let values = scene
                        .lights
                        .iter()
                        .zip(groups)
                        .map(|(light, g)| {
                            let mut e = crate::transport::direct::point_illuminance(
                                bvh,
                                &light.luminaires,
                                x,
                                n,
                            );
                            let b = Rgb::column(&g.b);
                            for &(j, wj) in &w {
                                e += wj * b[j as usize].to_f64();
                            }
                            e.to_f32()
                        })
                        .collect();
                    (values, w)
                })
                .collect();
            let columns = (0..groups.len())
                .map(|g| rows.iter().flat_map(|r| r.0[g].0).collect())
                .collect();
            let entries: u64 = rows.iter().map(|r| r.1.len() as u64).sum();
            let mut gather = GridGather::default();
            if kept + entries <= MAX_GRID_WEIGHTS {
                kept += entries;
                gather.offsets.push(0);
                for (_, w) in &rows {
                    for &(j, wj) in w {
                        gather.patch.push(j);
                        gather.weight.push(wj as f32);
                    }
                    gather.offsets.push(gather.patch.len() as u32);
                }
            }
            (columns, gather)
        })
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::GridGather;

    #[test]
    fn gather_weights_are_checked_when_read() {
        let ok = GridGather::from_parts(vec![0, 1, 3], vec![4, 0, 2], vec![0.1, 0.2, 0.3], 2, 5);
        assert_eq!(ok.map(|g| g.points()), Some(2));
        // Not kept: no rows at all.
        assert_eq!(
            GridGather::from_parts(vec![], vec![], vec![], 2, 5).map(|g| g.points()),
            Some(0)
        );
        let bad = [
            (vec![0, 1], vec![4], vec![0.1], 2),             // a row short
            (vec![0, 2, 1], vec![4, 0], vec![0.1, 0.2], 2),  // offsets fall
            (vec![0, 1, 2], vec![4, 9], vec![0.1, 0.2], 2),  // a patch past n
            (vec![0, 1, 2], vec![4, 0], vec![0.1, -0.2], 2), // a negative weight
            (vec![0, 1, 2], vec![4, 0], vec![0.1, f32::NAN], 2),
            (vec![1, 1, 2], vec![4, 0], vec![0.1, 0.2], 2), // not from 0
        ];
        for (o, j, w, points) in bad {
            assert!(
                GridGather::from_parts(o.clone(), j, w, points, 5).is_none(),
                "{o:?}"
            );
        }
    }
}
