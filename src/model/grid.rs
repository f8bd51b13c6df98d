//! Calculation grids: illuminance at work-plane points, per light group.
//!
//! The illuminance at a grid point is the direct light of the luminaires, exact per point
//! with shadow rays, plus the light gathered from the solved patches (see
//! [`crate::transport::probe`]). Both are linear in the group weights, so each grid keeps one RGB
//! column per light group (lux at unit weight). A lighting state's grid is then a
//! weighted sum: microseconds for a thousand points.

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::color::{luminance, Rgb};
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Mesh;
use crate::scene::{Grid, Scene};
use crate::transport::transfer::Transfer;

/// A grid with its per-group responses.
pub struct GridResponse {
    pub grid: Grid,
    /// Per group: illuminance at each point, lux, points × 3 interleaved.
    pub per_group: Vec<Vec<f32>>,
}

/// Statistics of a grid for one lighting state (lux).
#[derive(Debug, Clone, Serialize)]
pub struct GridStats {
    /// Luminous illuminance at each point, lx, in grid order.
    pub values: Vec<f32>,
    pub avg: f64,
    pub min: f64,
    pub max: f64,
    /// Uniformity U₀ = Emin / Eavg.
    pub u0: f64,
    /// Emin / Emax.
    pub min_max: f64,
}

impl GridResponse {
    /// Precomputes every grid of the scene for every light group.
    pub fn build_all(scene: &Scene, mesh: &Mesh, bvh: &Bvh, t: &Transfer) -> Vec<GridResponse> {
        if scene.grids.is_empty() {
            return vec![];
        }
        // Importance for the gather's ray budget: every group's radiosity at unit weight.
        let mut importance = vec![0f32; 3 * t.n];
        for g in &t.groups {
            for (a, b) in importance.iter_mut().zip(&g.b) {
                *a += b;
            }
        }
        scene
            .grids
            .iter()
            .map(|grid| {
                let n = DVec3::from_array(grid.normal);
                let rows: Vec<Vec<[f32; 3]>> = grid
                    .points
                    .par_iter()
                    .map(|p| {
                        let x = DVec3::from_array(*p);
                        let w =
                            crate::transport::probe::gather_weights(mesh, bvh, &importance, x, n);
                        scene
                            .lights
                            .iter()
                            .zip(&t.groups)
                            .map(|(light, g)| {
                                let mut e = crate::transport::direct::point_illuminance(
                                    bvh,
                                    &light.luminaires,
                                    x,
                                    n,
                                );
                                for &(j, wj) in &w {
                                    let bj = &g.b[3 * j as usize..3 * j as usize + 3];
                                    for (ec, &b) in e.iter_mut().zip(bj) {
                                        *ec += wj * b as f64;
                                    }
                                }
                                e.map(|v| v as f32)
                            })
                            .collect()
                    })
                    .collect();
                let per_group = (0..t.groups.len())
                    .map(|g| rows.iter().flat_map(|r| r[g]).collect())
                    .collect();
                GridResponse {
                    grid: grid.clone(),
                    per_group,
                }
            })
            .collect()
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.grid.points.len()
    }

    /// True for a grid without points (never built so).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Luminous illuminance (lx) at every point for per-group RGB weights.
    pub fn values(&self, weights: &[Rgb]) -> Vec<f32> {
        let mut rgb = vec![0f32; 3 * self.len()];
        crate::transport::transfer::weighted_sum(
            self.per_group.iter().map(|c| c.as_slice()),
            weights,
            &mut rgb,
        );
        rgb.chunks_exact(3)
            .map(|c| luminance([c[0], c[1], c[2]]))
            .collect()
    }

    /// Luminous illuminance (lx) at every point for group g at unit weight and its default
    /// colour `color`.
    pub fn group_values(&self, g: usize, color: Rgb) -> Vec<f64> {
        self.per_group[g]
            .chunks_exact(3)
            .map(|c| luminance([c[0] * color[0], c[1] * color[1], c[2] * color[2]]) as f64)
            .collect()
    }

    /// Statistics for per-group RGB weights.
    pub fn stats(&self, weights: &[Rgb]) -> GridStats {
        stats(self.values(weights))
    }
}

/// Average, extremes and uniformities of point values (lx).
pub fn stats(values: Vec<f32>) -> GridStats {
    let n = values.len().max(1) as f64;
    let avg = values.iter().map(|&v| v as f64).sum::<f64>() / n;
    let min = values.iter().fold(f64::INFINITY, |m, &v| m.min(v as f64));
    let max = values.iter().fold(0f64, |m, &v| m.max(v as f64));
    let min = if min.is_finite() { min } else { 0.0 };
    GridStats {
        avg,
        min,
        max,
        u0: if avg > 0.0 { min / avg } else { 0.0 },
        min_max: if max > 0.0 { min / max } else { 0.0 },
        values,
    }
}
