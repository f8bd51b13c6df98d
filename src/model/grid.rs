//! Calculation grids: illuminance at work-plane points, per light group.
//!
//! The illuminance at a grid point is the direct light of the luminaires, exact per point
//! with shadow rays, plus the light gathered from the solved patches (see
//! [`crate::transport::probe::grid_columns`]). Both are linear in the group weights, so
//! the bake keeps one RGB column per grid and light group (lux at unit weight) in the
//! transfer and its cache entry. A lighting state's grid is then a weighted sum:
//! microseconds for a thousand points.

use serde::Serialize;

use crate::color::{luminance, Rgb};
use crate::scene::{Grid, Scene};

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
    /// Every grid of the scene with its per-group responses, as baked into the transfer
    /// (`Transfer::grids`, [`crate::transport::probe::grid_columns`]).
    pub fn build_all(scene: &Scene, columns: Vec<Vec<Vec<f32>>>) -> Vec<GridResponse> {
        scene
            .grids
            .iter()
            .zip(columns)
            .map(|(grid, per_group)| GridResponse {
                grid: grid.clone(),
                per_group,
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
