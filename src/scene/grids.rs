//! Calculation grids: the `[[grids]]` of `scene.toml` resolved to points in metres with
//! one receiver normal, either explicit point lists or work planes (a horizontal
//! rectangle at a height above the floor, points at the centres of cells about `spacing`
//! wide; default height 0.75 m, spacing 0.25 m).

use std::path::Path;

use glam::DVec3;
use serde::Serialize;

use super::toml::GridToml;
use super::triangles::Triangle;
use super::{SceneError, SceneToml};
use crate::limits::MAX_GRID_POINTS;

/// A calculation grid: points (metres) with one receiver normal.
#[derive(Debug, Clone, Serialize)]
pub struct Grid {
    pub id: String,
    pub name: String,
    pub points: Vec<[f64; 3]>,
    pub normal: [f64; 3],
    /// Work-plane layout (columns × rows), when the grid is a rectangle.
    pub layout: Option<[usize; 2]>,
}

/// Points (metres) and, for work planes, their layout (columns × rows).
type Points = (Vec<[f64; 3]>, Option<[usize; 2]>);

/// Resolves `[[grids]]` to points in metres.
pub(crate) fn build_grids(
    cfg: &SceneToml,
    toml_path: &Path,
    scale: f64,
    triangles: &[Triangle],
) -> Result<Vec<Grid>, SceneError> {
    let floor = triangles
        .iter()
        .flat_map(|t| t.p.iter().map(|p| p.y))
        .fold(f64::INFINITY, f64::min);
    let mut out: Vec<Grid> = Vec::new();
    for g in &cfg.grids {
        let bad = |m: String| SceneError::Invalid {
            path: toml_path.into(),
            message: format!("grid '{}': {m}", g.id),
        };
        if g.id.is_empty() || out.iter().any(|o| o.id == g.id) {
            return Err(bad("id is empty or used twice".into()));
        }
        let n = DVec3::from_array(g.normal)
            .try_normalize()
            .ok_or_else(|| bad("normal must be a non-zero vector".into()))?;
        let (points, layout) = grid_points(g, scale, floor).map_err(bad)?;
        if points.is_empty() || points.len() > MAX_GRID_POINTS {
            return Err(bad(format!(
                "{} points: need 1..{MAX_GRID_POINTS}",
                points.len()
            )));
        }
        out.push(Grid {
            id: g.id.clone(),
            name: g.name.clone().unwrap_or_else(|| g.id.clone()),
            points,
            normal: n.to_array(),
            layout,
        });
    }
    Ok(out)
}

/// The points of one grid, in metres; `floor` is the scene's lowest y, metres.
fn grid_points(g: &GridToml, scale: f64, floor: f64) -> Result<Points, String> {
    match (&g.points, g.min, g.max) {
        (Some(p), None, None) => {
            if p.iter().flatten().any(|x| !x.is_finite()) {
                return Err("points must be finite".into());
            }
            Ok((p.iter().map(|q| q.map(|x| x * scale)).collect::<Vec<_>>(), None))
        }
        (None, Some(lo), Some(hi)) => work_plane(g, lo, hi, scale, floor),
        _ => Err(
            "give either points = [[x, y, z], ...] or min = [x, z], max = [x, z] (with height, spacing)".into(),
        ),
    }
}

/// A work plane from `lo` = [x, z] to `hi` = [x, z] (scene units).
fn work_plane(
    g: &GridToml,
    lo: [f64; 2],
    hi: [f64; 2],
    scale: f64,
    floor: f64,
) -> Result<Points, String> {
    let h = g.height.unwrap_or(0.75 / scale);
    let sp = g.spacing.unwrap_or(0.25 / scale);
    if !(sp > 0.0 && sp.is_finite() && h.is_finite()) {
        return Err("spacing must be positive and height finite".into());
    }
    if !(hi[0] > lo[0] && hi[1] > lo[1]) {
        return Err("max must exceed min in x and z".into());
    }
    let nx = ((hi[0] - lo[0]) / sp).ceil().max(1.0) as usize;
    let nz = ((hi[1] - lo[1]) / sp).ceil().max(1.0) as usize;
    if nx.saturating_mul(nz) > MAX_GRID_POINTS {
        return Err(format!(
            "{nx} × {nz} points; the limit is {MAX_GRID_POINTS}"
        ));
    }
    let (dx, dz) = ((hi[0] - lo[0]) / nx as f64, (hi[1] - lo[1]) / nz as f64);
    let y = floor + h * scale;
    let mut pts = Vec::with_capacity(nx * nz);
    for k in 0..nz {
        for i in 0..nx {
            pts.push([
                (lo[0] + (i as f64 + 0.5) * dx) * scale,
                y,
                (lo[1] + (k as f64 + 0.5) * dz) * scale,
            ]);
        }
    }
    Ok((pts, Some([nx, nz])))
}
