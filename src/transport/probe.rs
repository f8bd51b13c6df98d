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

/// Per grid of the scene and per light group: the illuminance at each grid point (lux,
/// points × 3 interleaved) for the group at unit weight: its luminaires' direct light with
/// shadow rays plus the gather ([`gather_weights`]) from its radiosity column `b`.
pub fn grid_columns(
    scene: &Scene,
    mesh: &Mesh,
    bvh: &Bvh,
    groups: &[GroupColumns],
) -> Vec<Vec<Vec<f32>>> {
    if scene.grids.is_empty() {
        return vec![];
    }
    // Importance for the gather's ray budget: every group's radiosity at unit weight.
    let mut importance = vec![0f32; 3 * mesh.len()];
    for g in groups {
        for (a, b) in importance.iter_mut().zip(&g.b) {
            *a += b;
        }
    }
    scene
        .grids
        .iter()
        .map(|grid| {
            let n = DVec3::from_array(grid.normal);
            let rows: Vec<Vec<Rgb>> = grid
                .points
                .par_iter()
                .map(|p| {
                    let x = DVec3::from_array(*p);
                    let w = gather_weights(mesh, bvh, &importance, x, n);
                    scene
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
                        .collect()
                })
                .collect();
            (0..groups.len())
                .map(|g| rows.iter().flat_map(|r| r[g].0).collect())
                .collect()
        })
        .collect()
}
