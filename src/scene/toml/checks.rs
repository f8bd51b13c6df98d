//! The range checks of a parsed `scene.toml`: every number against
//! [`crate::input_limits`], in metres after scaling, before anything is sized by it.

use std::path::Path;

use super::{resolve_units, CameraToml, GridToml, LightToml, LuminaireToml, MeshToml, SceneToml};
use crate::color::Rgb;
use crate::input_limits::*;
use crate::scene::SceneError;

/// `lo ≤ v ≤ hi` and finite, else an error naming `what` and the range.
fn in_range(what: &str, v: f64, lo: f64, hi: f64) -> Result<(), String> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(format!("{what} = {}: must be in {lo}..={hi:e}", num(v)))
    }
}

/// A maintenance factor: in (0, 1].
fn maintenance_factor(mf: f64) -> Result<(), String> {
    if mf.is_finite() && mf > 0.0 && mf <= 1.0 {
        Ok(())
    } else {
        Err(format!(
            "maintenance_factor = {}: must be in (0, 1]",
            num(mf)
        ))
    }
}

/// A position in scene units: finite, within ±MAX_COORD_M metres after scaling.
fn position(what: &str, v: &[f64], scale: f64) -> Result<(), String> {
    for &x in v {
        let m = x * scale;
        if !(x.is_finite() && m.is_finite() && m.abs() <= MAX_COORD_M) {
            return Err(format!(
                "{what}: coordinate {} is outside ±{MAX_COORD_M:e} m (after scaling)",
                num(x)
            ));
        }
    }
    Ok(())
}

/// A direction: finite components.
fn direction(what: &str, v: &[f64; 3]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} must be finite"))
    }
}

/// A colour: finite components in 0..=MAX_COLOR.
fn color_ok(what: &str, c: &Rgb) -> Result<(), String> {
    if c.iter()
        .all(|&x| x.is_finite() && x >= 0.0 && x as f64 <= MAX_COLOR)
    {
        Ok(())
    } else {
        Err(format!(
            "{what} must be 3 numbers in 0..={MAX_COLOR} (got {:?})",
            c
        ))
    }
}

/// Checks the ranges of every number of a `scene.toml` (see [`crate::input_limits`]).
pub(super) fn validate_toml(cfg: &SceneToml, path: &Path) -> Result<(), SceneError> {
    let inv = |message: String| SceneError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    let (_, scale) = resolve_units(cfg, path)?;
    check_counts(cfg).map_err(inv)?;
    if let Some(mf) = cfg.maintenance_factor {
        maintenance_factor(mf).map_err(inv)?;
    }
    check_mesh(&cfg.mesh, scale).map_err(inv)?;
    for l in &cfg.lights {
        check_light(l).map_err(|m| inv(format!("light '{}': {m}", l.id)))?;
    }
    for l in &cfg.luminaires {
        check_luminaire(l, scale).map_err(|m| inv(format!("luminaire '{}': {m}", l.id)))?;
    }
    for c in &cfg.cameras {
        check_camera(c, scale).map_err(|m| inv(format!("camera '{}': {m}", c.id)))?;
    }
    if let Some(site) = &cfg.site {
        site.site().map_err(inv)?;
    }
    // Grid points, counted in f64 over all grids before anything is allocated.
    let mut grid_points = 0f64;
    for g in &cfg.grids {
        check_grid(g, scale, &mut grid_points).map_err(|m| inv(format!("grid '{}': {m}", g.id)))?;
    }
    Ok(())
}

/// The number of entries of each array of tables.
fn check_counts(cfg: &SceneToml) -> Result<(), String> {
    for (what, n, max) in [
        ("[[lights]]", cfg.lights.len(), MAX_TOML_ENTRIES),
        ("[[luminaires]]", cfg.luminaires.len(), MAX_LUMINAIRES),
        ("[[grids]]", cfg.grids.len(), MAX_TOML_ENTRIES),
        ("[[cameras]]", cfg.cameras.len(), MAX_TOML_ENTRIES),
    ] {
        if n > max {
            return Err(format!("{n} {what} entries; the limit is {max}"));
        }
    }
    Ok(())
}

/// `[mesh]`: `max_edge` (scene units, checked in metres) and `target_patches`.
fn check_mesh(mesh: &MeshToml, scale: f64) -> Result<(), String> {
    if let Some(e) = mesh.max_edge {
        let m = e * scale;
        if !(e.is_finite() && (MIN_MAX_EDGE_M..=MAX_MAX_EDGE_M).contains(&m)) {
            return Err(format!(
                "[mesh] max_edge = {}: must be a length between {MIN_MAX_EDGE_M} m and \
                 {MAX_MAX_EDGE_M:e} m (after scaling)",
                num(e)
            ));
        }
    }
    if let Some(t) = mesh.target_patches {
        if !(1..=MAX_TARGET_PATCHES).contains(&t) {
            return Err(format!(
                "[mesh] target_patches = {t}: must be in 1..={MAX_TARGET_PATCHES}"
            ));
        }
    }
    Ok(())
}

/// One `[[lights]]` entry: lumens, intensity, colour.
fn check_light(l: &LightToml) -> Result<(), String> {
    if let Some(lm) = l.lumens {
        in_range("lumens", lm, 0.0, MAX_LUMENS)?;
    }
    if let Some(mf) = l.maintenance_factor {
        maintenance_factor(mf)?;
    }
    if let Some(ra) = l.ra {
        in_range("ra", ra, 0.0, 100.0)?;
    }
    if let Some(i) = l.intensity {
        in_range("intensity", i as f64, 0.0, MAX_DEFAULT_INTENSITY)?;
    }
    if let Some(c) = &l.color {
        color_ok("color", c)?;
    }
    Ok(())
}

/// One `[[luminaires]]` entry: placement, flux, spot angles (degrees), colour, power.
fn check_luminaire(l: &LuminaireToml, scale: f64) -> Result<(), String> {
    position("position", &l.position, scale)?;
    if let Some(ra) = l.ra {
        in_range("ra", ra, 0.0, 100.0)?;
    }
    direction("aim", &l.aim)?;
    if let Some(c) = &l.c0 {
        direction("c0", c)?;
    }
    if let Some(lm) = l.lumens {
        in_range("lumens", lm, 0.0, MAX_LUMENS)?;
    }
    for (what, v) in [("beam_deg", l.beam_deg), ("field_deg", l.field_deg)] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0 && v <= 180.0) {
                return Err(format!("{what} = {}: must be in (0, 180]", num(v)));
            }
        }
    }
    if let Some(k) = l.cct {
        if !(k.is_finite() && (MIN_CCT..=MAX_CCT).contains(&k)) {
            return Err(format!("cct = {}: must be {MIN_CCT}..{MAX_CCT} K", num(k)));
        }
    }
    if let Some(c) = &l.color {
        color_ok("color", c)?;
    }
    if let Some(w) = l.watts {
        in_range("watts", w, 0.0, MAX_WATTS)?;
    }
    if let Some(e) = l.efficacy {
        if !(e.is_finite() && e > 0.0 && e <= MAX_EFFICACY) {
            return Err(format!(
                "efficacy = {}: must be in (0, {MAX_EFFICACY}] lm/W",
                num(e)
            ));
        }
    }
    Ok(())
}

/// One `[[cameras]]` entry: placement and vertical field of view (degrees).
fn check_camera(c: &CameraToml, scale: f64) -> Result<(), String> {
    position("position", &c.position, scale)?;
    position("target", &c.target, scale)?;
    direction("up", &c.up)?;
    if !(c.fov_deg > 0.0 && c.fov_deg < 180.0) {
        return Err(format!("fov_deg = {}: must be in (0, 180)", num(c.fov_deg)));
    }
    Ok(())
}

/// One `[[grids]]` entry; adds its points to `grid_points`, the running total of all
/// grids, which must stay within [`MAX_GRID_POINTS_TOTAL`].
fn check_grid(g: &GridToml, scale: f64, grid_points: &mut f64) -> Result<(), String> {
    direction("normal", &g.normal)?;
    if let Some(r) = &g.requirements {
        r.check().map_err(|m| format!("requirements.{m}"))?;
    }
    if let Some(p) = &g.points {
        if p.len() > MAX_GRID_POINTS {
            return Err(format!(
                "{} points; the limit is {MAX_GRID_POINTS}",
                p.len()
            ));
        }
        for q in p {
            position("points", q, scale)?;
        }
        *grid_points += p.len() as f64;
    }
    for (what, v) in [("min", g.min), ("max", g.max)] {
        if let Some(v) = v {
            position(what, &v, scale)?;
        }
    }
    if let Some(h) = g.height {
        position("height", &[h], scale)?;
    }
    if let Some(sp) = g.spacing {
        let m = sp * scale;
        if !(sp.is_finite() && m.is_finite() && m >= MIN_GRID_SPACING_M) {
            return Err(format!(
                "spacing = {}: must be at least {MIN_GRID_SPACING_M} m (after scaling)",
                num(sp)
            ));
        }
    }
    if let (Some(lo), Some(hi)) = (g.min, g.max) {
        let sp = g.spacing.unwrap_or(0.25 / scale);
        // Counted in f64 before anything is allocated.
        let nx = ((hi[0] - lo[0]) / sp).ceil().max(1.0);
        let nz = ((hi[1] - lo[1]) / sp).ceil().max(1.0);
        if nx * nz > MAX_GRID_POINTS as f64 {
            return Err(format!(
                "{} × {} points; the limit is {MAX_GRID_POINTS}",
                num(nx),
                num(nz)
            ));
        }
        *grid_points += nx * nz;
    }
    if *grid_points > MAX_GRID_POINTS_TOTAL as f64 {
        return Err(format!(
            "the grids have {} points in all; the limit is {MAX_GRID_POINTS_TOTAL}",
            num(*grid_points)
        ));
    }
    Ok(())
}
