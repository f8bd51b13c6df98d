//! Calculation grids: illuminance at work-plane points, per light group.
//!
//! The illuminance at a grid point is the direct light of the luminaires, exact per point
//! with shadow rays, plus the light gathered from the solved patches (see
//! [`crate::transport::probe::grid_columns`]). Both are linear in the group weights, so
//! the bake keeps one RGB column per grid and light group (lux at unit weight) in the
//! transfer and its cache entry. A lighting state's grid is then a weighted sum:
//! microseconds for a thousand points.

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::color::Rgb;
use crate::geometry::bvh::Bvh;
use crate::geometry::obstructed;
use crate::scene::{Grid, Scene};
use crate::transport::probe::GridGather;

/// A grid with its per-group responses.
pub struct GridResponse {
    pub grid: Grid,
    /// Per group: illuminance at each point, lux, points × 3 interleaved.
    pub per_group: Vec<Vec<f32>>,
    /// Per point: left out of the statistics, inside an object or under a surface at close
    /// range ([`crate::geometry::obstructed`]); all false when the grid keeps them.
    pub excluded: Vec<bool>,
    /// The gather's weights per point: the indirect illuminance of any radiosity.
    pub gather: GridGather,
}

/// Statistics of a grid for one lighting state (lux), over the points it measures.
#[derive(Debug, Clone, Serialize)]
pub struct GridStats {
    /// Luminous illuminance at each point, lx, in grid order; None for excluded points.
    pub values: Vec<Option<f32>>,
    /// Points left out of the statistics.
    pub excluded: usize,
    pub avg: f64,
    pub min: f64,
    pub max: f64,
    /// Uniformity U₀ = Emin / Eavg; None when the grid is unlit (see [`GridStats::note`]).
    pub u0: Option<f64>,
    /// Emin / Emax; None when the grid is unlit.
    pub min_max: Option<f64>,
    /// Why `u0` and `min_max` are None: every measured point is at 0 lx (or none is
    /// measured), and a ratio of zeros has no value.
    pub note: Option<&'static str>,
}

/// The note of a grid whose measured points are all at 0 lx.
pub const UNLIT_NOTE: &str =
    "every measured point is at 0 lx: U0 and Emin/Emax are undefined for an unlit grid";

/// The note of a grid with no measured point.
pub const UNMEASURED_NOTE: &str =
    "no point is measured (all are excluded): U0 and Emin/Emax are undefined";

impl GridResponse {
    /// Every grid of the scene with its per-group responses, as baked into the transfer
    /// (`Transfer::grids`, [`crate::transport::probe::grid_columns`]).
    /// Points inside objects are marked excluded with shadow rays over `bvh`.
    pub fn build_all(
        scene: &Scene,
        bvh: &Bvh,
        columns: Vec<Vec<Vec<f32>>>,
        gathers: Vec<GridGather>,
    ) -> Vec<GridResponse> {
        scene
            .grids
            .iter()
            .zip(columns)
            .zip(gathers)
            .map(|((grid, per_group), gather)| GridResponse {
                excluded: excluded_points(scene, bvh, grid),
                grid: grid.clone(),
                per_group,
                gather,
            })
            .collect()
    }

    /// Indices of the points the statistics use.
    pub fn measured(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.len()).filter(|&i| !self.excluded[i])
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
        Rgb::column(&rgb).iter().map(|c| c.luminance()).collect()
    }

    /// Luminous illuminance (lx) at every point for group g at unit weight and its default
    /// colour `color`.
    pub fn group_values(&self, g: usize, color: Rgb) -> Vec<f64> {
        Rgb::column(&self.per_group[g])
            .iter()
            .map(|&c| (c * color).luminance() as f64)
            .collect()
    }

    /// Statistics for per-group RGB weights.
    pub fn stats(&self, weights: &[Rgb]) -> GridStats {
        stats(self.values(weights), &self.excluded)
    }
}

/// Per point of `grid`, whether it is left out ([`crate::geometry::obstructed`]).
fn excluded_points(scene: &Scene, bvh: &Bvh, grid: &Grid) -> Vec<bool> {
    if grid.keep_obstructed {
        return vec![false; grid.points.len()];
    }
    let n = DVec3::from_array(grid.normal);
    grid.points
        .par_iter()
        .map(|p| obstructed::is_obstructed(scene, bvh, DVec3::from_array(*p), n))
        .collect()
}

/// Average, extremes and uniformities of point values (lx) over the points not
/// `excluded` (same length; missing entries count as measured).
pub fn stats(values: Vec<f32>, excluded: &[bool]) -> GridStats {
    let out = |i: usize| excluded.get(i).copied().unwrap_or(false);
    let measured = || {
        values
            .iter()
            .enumerate()
            .filter(|(i, _)| !out(*i))
            .map(|(_, &v)| v as f64)
    };
    let count = measured().count();
    let avg = measured().sum::<f64>() / count.max(1) as f64;
    let min = measured().fold(f64::INFINITY, f64::min);
    let max = measured().fold(0f64, f64::max);
    let min = if min.is_finite() { min } else { 0.0 };
    let lit = avg > 0.0 && max > 0.0;
    GridStats {
        avg,
        min,
        max,
        u0: lit.then(|| min / avg),
        min_max: lit.then(|| min / max),
        note: match (count, lit) {
            (0, _) => Some(UNMEASURED_NOTE),
            (_, false) => Some(UNLIT_NOTE),
            _ => None,
        },
        excluded: values.len() - count,
        values: values
            .iter()
            .enumerate()
            .map(|(i, &v)| (!out(i)).then_some(v))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_are_over_the_measured_points_with_u0_emin_over_eavg() {
        let s = stats(
            vec![100.0, 200.0, 1000.0, 300.0],
            &[false, false, true, false],
        );
        assert_eq!((s.avg, s.min, s.max), (200.0, 100.0, 300.0));
        assert_eq!(s.u0, Some(0.5));
        assert_eq!(s.min_max, Some(100.0 / 300.0));
        assert_eq!(s.note, None);
        assert_eq!(s.excluded, 1);
        assert_eq!(s.values, vec![Some(100.0), Some(200.0), None, Some(300.0)]);
        // The excluded point, brightest or darkest, changes nothing.
        let t = stats(vec![100.0, 200.0, 0.0, 300.0], &[false, false, true, false]);
        assert_eq!((t.avg, t.min, t.u0), (200.0, 100.0, Some(0.5)));
    }

    #[test]
    fn points_without_an_exclusion_flag_are_measured() {
        let s = stats(vec![10.0, 30.0, 20.0], &[true]);
        assert_eq!((s.avg, s.min, s.max, s.excluded), (25.0, 20.0, 30.0, 1));
        assert_eq!(s.u0, Some(0.8));
    }

    #[test]
    fn an_unlit_grid_reported_zero_uniformity_instead_of_none() {
        let s = stats(vec![0.0, 0.0], &[]);
        assert_eq!((s.avg, s.min, s.max), (0.0, 0.0, 0.0));
        assert_eq!((s.u0, s.min_max, s.note), (None, None, Some(UNLIT_NOTE)));
        let s = stats(vec![5.0, 6.0], &[true, true]);
        assert_eq!((s.avg, s.min, s.max), (0.0, 0.0, 0.0));
        assert_eq!(
            (s.u0, s.min_max, s.note),
            (None, None, Some(UNMEASURED_NOTE))
        );
        assert_eq!(s.excluded, 2);
        assert_eq!(s.values, vec![None, None]);
        // A dark point on a lit grid is a real zero.
        let s = stats(vec![0.0, 10.0], &[]);
        assert_eq!((s.u0, s.min_max, s.note), (Some(0.0), Some(0.0), None));
    }
}
