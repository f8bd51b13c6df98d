//! Calculation grids: the `[[grids]]` of `scene.toml` resolved to points in metres with
//! one receiver normal. A grid is one of
//! - explicit points;
//! - a work plane: a horizontal rectangle (`min`, `max`) or polygon (`area`) at a height
//!   above the floor, points at the centres of cells about `spacing` wide (default height
//!   0.75 m, spacing 0.25 m);
//! - an EN 12464-1 area: the same with a `kind` (`task`, `surrounding`, `background`),
//!   its cells sized by the standard ([`en12464_spacing`]). A task area brings its
//!   immediate surrounding, a band 0.5 m wide around it, as a grid of its own
//!   (`<id>-surrounding`); a background area leaves out a 0.5 m band along its edges (the
//!   walls).

use std::path::Path;

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::toml::GridToml;
use super::triangles::Triangle;
use super::{SceneError, SceneToml};
use crate::input_limits::MAX_GRID_POINTS;

/// The zones of EN 12464-1 a grid can stand for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum GridKind {
    /// The task area.
    Task,
    /// The immediate surrounding of a task area (a band at least 0.5 m wide).
    Surrounding,
    /// The background area (the room, less a 0.5 m band along the walls).
    Background,
}

/// Width of a task area's immediate surrounding band and of the band along the walls
/// that background areas leave out, m (EN 12464-1).
pub const EN12464_BAND_M: f64 = 0.5;

/// What an area must achieve, as EN 12464-1 Table 5 lists it per task. Each is optional.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct Requirements {
    /// Ēm: the least maintained average illuminance, lx.
    #[serde(default, deserialize_with = "present")]
    #[cfg_attr(
        feature = "server",
        schema(minimum = 0, maximum = 1e6, nullable = false)
    )]
    pub em: Option<f64>,
    /// U₀: the least uniformity Emin / Eavg, 0..1.
    #[serde(default, deserialize_with = "present")]
    #[cfg_attr(feature = "server", schema(minimum = 0, maximum = 1, nullable = false))]
    pub u0: Option<f64>,
    /// UGR_L: the highest UGR allowed at the area's observers, 5..40.
    #[serde(default, deserialize_with = "present")]
    #[cfg_attr(
        feature = "server",
        schema(minimum = 5, maximum = 40, nullable = false)
    )]
    pub ugr_l: Option<f64>,
    /// Ra: the least colour rendering index of the lamps that light it, 0..100.
    #[serde(default, deserialize_with = "present")]
    #[cfg_attr(
        feature = "server",
        schema(minimum = 0, maximum = 100, nullable = false)
    )]
    pub ra: Option<f64>,
}

/// A number that is there: `null` is not taken for absent.
fn present<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    f64::deserialize(d).map(Some)
}

/// The largest Ēm a requirement may ask for, lx.
pub const MAX_REQUIRED_LUX: f64 = 1e6;

impl Requirements {
    /// Checks every given number against its range; the message names the field.
    pub fn check(&self) -> Result<(), String> {
        for (what, v, lo, hi) in [
            ("em", self.em, 0.0, MAX_REQUIRED_LUX),
            ("u0", self.u0, 0.0, 1.0),
            ("ugr_l", self.ugr_l, 5.0, 40.0),
            ("ra", self.ra, 0.0, 100.0),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && (lo..=hi).contains(&v)) {
                    return Err(format!("{what} = {v}: must be in {lo}..={hi}"));
                }
            }
        }
        Ok(())
    }

    /// True when nothing is required.
    pub fn is_empty(&self) -> bool {
        self.em.is_none() && self.u0.is_none() && self.ugr_l.is_none() && self.ra.is_none()
    }
}

/// A calculation grid: points (metres) with one receiver normal.
#[derive(Debug, Clone, Serialize)]
pub struct Grid {
    pub id: String,
    pub name: String,
    pub points: Vec<[f64; 3]>,
    pub normal: [f64; 3],
    /// Work-plane layout (columns × rows), when the grid is a full rectangle.
    pub layout: Option<[usize; 2]>,
    /// The EN 12464-1 zone, when the grid is declared as one.
    pub kind: Option<GridKind>,
    /// Distance between neighbouring points, m (work planes and areas).
    pub spacing: Option<f64>,
    /// Points inside objects are kept in the statistics
    /// ([`crate::geometry::obstructed`]).
    pub keep_obstructed: bool,
    /// What the area must achieve (empty when `scene.toml` sets nothing).
    pub requirements: Requirements,
    /// The scene's floor height (its lowest point), m: observers' eyes stand above it.
    pub floor: f64,
}

/// The largest spacing of calculation points, m, for an area whose relevant dimension is
/// `d` m (EN 12464-1:2011 4.4, after EN 12193): `p = 0.2 · 5^log₁₀(d)`, at most 10 m and
/// at most `d`.
pub fn en12464_spacing(d: f64) -> f64 {
    (0.2 * 5f64.powf(d.log10())).min(10.0).min(d)
}

/// The cells of an area `w` × `l` m by EN 12464-1: the relevant dimension `d` is the
/// longer side, or the shorter one when the sides differ by a factor of 2 or more; along
/// it, `n = ⌈d / p⌉` cells of `d / n`; the other side takes cells of that size (rounded
/// up to whole cells, so the spacing never exceeds `p`). Returns (nw, nl).
pub fn en12464_cells(w: f64, l: f64) -> (usize, usize) {
    let (long, short) = (w.max(l), w.min(l));
    let d = if long >= 2.0 * short { short } else { long };
    let p = en12464_spacing(d);
    let n = (d / p - 1e-9).ceil().max(1.0);
    let cell = d / n;
    let count = |x: f64| (x / cell - 1e-9).ceil().max(1.0) as usize;
    (count(w), count(l))
}

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
        let n = DVec3::from_array(g.normal)
            .try_normalize()
            .ok_or_else(|| bad("normal must be a non-zero vector".into()))?;
        let main_id = g.id.clone();
        for (id, name, kind, placed) in grid_points(g, scale, floor).map_err(bad)? {
            if id.is_empty() || out.iter().any(|o| o.id == id) {
                return Err(bad(format!("id '{id}' is empty or used twice")));
            }
            if placed.points.is_empty() || placed.points.len() > MAX_GRID_POINTS {
                return Err(bad(format!(
                    "{} points: need 1..{MAX_GRID_POINTS}",
                    placed.points.len()
                )));
            }
            // The requirements are the area's own, not its surrounding band's.
            let requirements = match &g.requirements {
                Some(r) if id == main_id => *r,
                _ => Requirements::default(),
            };
            out.push(Grid {
                id,
                name,
                points: placed.points,
                normal: n.to_array(),
                layout: placed.layout,
                kind,
                spacing: placed.spacing,
                keep_obstructed: g.keep_obstructed,
                requirements,
                floor,
            });
        }
    }
    Ok(out)
}

/// Points (metres), their layout when they fill a rectangle, and their spacing (m).
struct Placed {
    points: Vec<[f64; 3]>,
    layout: Option<[usize; 2]>,
    spacing: Option<f64>,
}

/// A grid of the toml and the ones it brings (a task's surrounding).
type Grids = Vec<(String, String, Option<GridKind>, Placed)>;

/// The points of one `[[grids]]` entry; `floor` is the scene's lowest y, metres.
fn grid_points(g: &GridToml, scale: f64, floor: f64) -> Result<Grids, String> {
    let name = g.name.clone().unwrap_or_else(|| g.id.clone());
    let outline = match declared_outline(g)? {
        Declared::Points(p) => {
            let placed = explicit_points(g, p, scale)?;
            return Ok(vec![(g.id.clone(), name, g.kind, placed)]);
        }
        Declared::Outline(outline) => outline,
    };
    let area = Area::new(g, &outline, scale, floor)?;
    match g.kind {
        Some(GridKind::Background) => Ok(vec![(
            g.id.clone(),
            name,
            g.kind,
            area.background(g.wall_band, scale)?,
        )]),
        _ => area.plane_and_surrounding(g, name, scale),
    }
}

/// What a `[[grids]]` entry gives: explicit points, or an area's outline ([x, z], in the
/// scene's units).
enum Declared<'a> {
    Points(&'a [[f64; 3]]),
    Outline(Vec<[f64; 2]>),
}

/// The points or outline of a `[[grids]]` entry, once they are given one way only.
fn declared_outline(g: &GridToml) -> Result<Declared<'_>, String> {
    Ok(match (&g.points, g.min, g.max, &g.area) {
        (Some(p), None, None, None) => Declared::Points(p),
        (None, Some(lo), Some(hi), None) => {
            if !(lo.iter().chain(&hi).all(|x| x.is_finite()) && hi[0] > lo[0] && hi[1] > lo[1]) {
                return Err("max must exceed min in x and z".into());
            }
            Declared::Outline(vec![lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]])
        }
        (None, None, None, Some(a)) => {
            if a.len() < 3 || a.len() > 1000 || a.iter().flatten().any(|x| !x.is_finite()) {
                return Err("area must be 3 to 1000 finite [x, z] corners".into());
            }
            Declared::Outline(a.clone())
        }
        _ => {
            return Err(
                "give either points = [[x, y, z], ...], min = [x, z] and max = [x, z], \
                 or area = [[x, z], ...] (with height, spacing or kind)"
                    .into(),
            )
        }
    })
}

/// Explicit points, in metres.
fn explicit_points(g: &GridToml, p: &[[f64; 3]], scale: f64) -> Result<Placed, String> {
    if g.kind.is_some() {
        return Err("a kind needs an area (min and max, or area), not points".into());
    }
    if p.iter().flatten().any(|x| !x.is_finite()) {
        return Err("points must be finite".into());
    }
    Ok(Placed {
        points: p.iter().map(|q| q.map(|x| x * scale)).collect(),
        layout: None,
        spacing: None,
    })
}

/// A band width given in the scene's units (EN 12464-1's 0.5 m when None), in metres.
fn band_metres(v: Option<f64>, scale: f64, what: &str) -> Result<f64, String> {
    let m = v.map_or(EN12464_BAND_M, |x| x * scale);
    if m.is_finite() && m >= 0.0 {
        Ok(m)
    } else {
        Err(format!("{what} must be a length of 0 or more"))
    }
}

/// A work plane or EN 12464-1 area, in metres.
struct Area {
    /// [x, z] corners.
    outline: Vec<[f64; 2]>,
    /// Given as min and max (a full rectangle), not as a polygon.
    rect: bool,
    /// Height of the points.
    y: f64,
    /// Cell size; None: by EN 12464-1.
    spacing: Option<f64>,
}

impl Area {
    /// The area of entry `g` whose `outline` is in the scene's units, once its options
    /// are checked.
    fn new(g: &GridToml, outline: &[[f64; 2]], scale: f64, floor: f64) -> Result<Self, String> {
        let outline: Vec<[f64; 2]> = outline.iter().map(|p| p.map(|x| x * scale)).collect();
        let h = g.height.map_or(0.75, |h| h * scale);
        if !h.is_finite() {
            return Err("height must be finite".into());
        }
        if g.surrounding.is_some() && g.kind != Some(GridKind::Task) {
            return Err("surrounding is for kind = \"task\"".into());
        }
        if g.wall_band.is_some() && g.kind != Some(GridKind::Background) {
            return Err("wall_band is for kind = \"background\"".into());
        }
        let spacing = match g.spacing {
            Some(s) if !(s > 0.0 && s.is_finite()) => {
                return Err("spacing must be positive and finite".into())
            }
            Some(s) => Some(s * scale),
            None if g.kind.is_some() => None,
            None => Some(0.25),
        };
        Ok(Area {
            outline,
            rect: g.area.is_none(),
            y: floor + h,
            spacing,
        })
    }

    /// A background area: the points at least `wall_band` from its edges.
    fn background(&self, wall_band: Option<f64>, scale: f64) -> Result<Placed, String> {
        let band = band_metres(wall_band, scale, "wall_band")?;
        let outline = &self.outline;
        let inside = |x: f64, z: f64| {
            point_in_polygon(outline, x, z) && edge_distance(outline, x, z) >= band
        };
        let (lo, hi) = bounds(outline);
        let (lo, hi) = ([lo[0] + band, lo[1] + band], [hi[0] - band, hi[1] - band]);
        if !(hi[0] > lo[0] && hi[1] > lo[1]) {
            return Err(format!(
                "the area is narrower than twice its {band} m wall band"
            ));
        }
        place(lo, hi, self.y, self.spacing, &inside, self.rect)
    }

    /// A work plane or task or surrounding area, and a task's immediate surrounding.
    fn plane_and_surrounding(
        &self,
        g: &GridToml,
        name: String,
        scale: f64,
    ) -> Result<Grids, String> {
        let outline = &self.outline;
        let inside = |x: f64, z: f64| point_in_polygon(outline, x, z);
        let (lo, hi) = bounds(outline);
        let mut out = vec![(
            g.id.clone(),
            name.clone(),
            g.kind,
            place(lo, hi, self.y, self.spacing, &inside, self.rect)?,
        )];
        if g.kind == Some(GridKind::Task) {
            let band = band_metres(g.surrounding, scale, "surrounding")?;
            if band > 0.0 {
                out.push((
                    format!("{}-surrounding", g.id),
                    format!("{name} (immediate surrounding)"),
                    Some(GridKind::Surrounding),
                    self.surrounding(lo, hi, band)?,
                ));
            }
        }
        Ok(out)
    }

    /// The band `band` m wide around the area (bounds `lo`..`hi`).
    fn surrounding(&self, lo: [f64; 2], hi: [f64; 2], band: f64) -> Result<Placed, String> {
        let outline = &self.outline;
        let (olo, ohi) = ([lo[0] - band, lo[1] - band], [hi[0] + band, hi[1] + band]);
        let ring = |x: f64, z: f64| {
            !point_in_polygon(outline, x, z)
                && (edge_distance(outline, x, z) <= band
                    || (self.rect && x >= olo[0] && x <= ohi[0] && z >= olo[1] && z <= ohi[1]))
        };
        place(olo, ohi, self.y, self.spacing, &ring, false)
    }
}

/// Points at the centres of the cells of the rectangle `lo`..`hi` (x, z, metres) at height
/// `y` whose centres pass `keep`; cells of `spacing`, or by EN 12464-1 when None.
fn place(
    lo: [f64; 2],
    hi: [f64; 2],
    y: f64,
    spacing: Option<f64>,
    keep: &dyn Fn(f64, f64) -> bool,
    full: bool,
) -> Result<Placed, String> {
    let (w, l) = (hi[0] - lo[0], hi[1] - lo[1]);
    let (nx, nz) = match spacing {
        Some(sp) => {
            let c = |x: f64| (x / sp).ceil().max(1.0);
            let (a, b) = (c(w), c(l));
            if a * b > MAX_GRID_POINTS as f64 {
                return Err(format!("{a} × {b} points; the limit is {MAX_GRID_POINTS}"));
            }
            (a as usize, b as usize)
        }
        None => en12464_cells(w, l),
    };
    if nx.saturating_mul(nz) > MAX_GRID_POINTS {
        return Err(format!(
            "{nx} × {nz} points; the limit is {MAX_GRID_POINTS}"
        ));
    }
    let (dx, dz) = (w / nx as f64, l / nz as f64);
    let mut points = Vec::with_capacity(if full { nx * nz } else { 0 });
    for k in 0..nz {
        for i in 0..nx {
            let (x, z) = (lo[0] + (i as f64 + 0.5) * dx, lo[1] + (k as f64 + 0.5) * dz);
            if full || keep(x, z) {
                points.push([x, y, z]);
            }
        }
    }
    Ok(Placed {
        layout: full.then_some([nx, nz]),
        spacing: Some(dx.max(dz)),
        points,
    })
}

fn bounds(p: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    let (lo, hi) = p
        .iter()
        .map(|&q| DVec2::from(q))
        .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), q| {
            (lo.min(q), hi.max(q))
        });
    (lo.to_array(), hi.to_array())
}

/// Even–odd rule.
fn point_in_polygon(p: &[[f64; 2]], x: f64, z: f64) -> bool {
    let mut inside = false;
    let mut j = p.len() - 1;
    for i in 0..p.len() {
        let (a, b) = (p[i], p[j]);
        if (a[1] > z) != (b[1] > z) && x < (b[0] - a[0]) * (z - a[1]) / (b[1] - a[1]) + a[0] {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// Distance from (x, z) to the polygon's outline, m.
fn edge_distance(p: &[[f64; 2]], x: f64, z: f64) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..p.len() {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        let (ex, ez) = (b[0] - a[0], b[1] - a[1]);
        let len2 = ex * ex + ez * ez;
        let t = if len2 > 0.0 {
            (((x - a[0]) * ex + (z - a[1]) * ez) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (dx, dz) = (a[0] + t * ex - x, a[1] + t * ez - z);
        best = best.min((dx * dx + dz * dz).sqrt());
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// EN 12464-1's worked spacings: p = 0.2 · 5^log₁₀(d).
    #[test]
    fn the_standards_spacing_for_1_5_10_and_20_m() {
        for (d, p, n) in [
            (1.0, 0.2, 5),
            (5.0, 0.616, 9),
            (10.0, 1.0, 10),
            (20.0, 1.623, 13),
        ] {
            let got = en12464_spacing(d);
            assert!((got - p).abs() < 5e-4, "d = {d}: p = {got}, want {p}");
            // A square area of side d: n = ⌈d / p⌉ cells each way.
            assert_eq!(en12464_cells(d, d), (n, n), "d = {d}");
        }
        // Exactly the formula, not a table.
        assert_eq!(en12464_spacing(10.0), 1.0);
        assert!((en12464_spacing(5.0) - 0.2 * 5f64.powf(5f64.log10())).abs() < 1e-15);
        assert_eq!(en12464_spacing(1000.0), 10.0, "p is at most 10 m");
    }

    #[test]
    fn a_long_area_takes_its_short_side_as_d() {
        // 10 × 4 m: 10 ≥ 2·4, so d = 4 m, p = 0.2·5^log10(4) = 0.5260, n = 8 cells of 0.5 m;
        // the 10 m side takes 20 cells of 0.5 m.
        assert_eq!(en12464_cells(10.0, 4.0), (20, 8));
        // 6 × 4 m: d = 6 m, p = 0.7007, n = 9 cells of 0.667 m; the 4 m side 6 cells.
        assert_eq!(en12464_cells(6.0, 4.0), (9, 6));
    }

    #[test]
    fn polygons_bands_and_surroundings() {
        let square = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]];
        assert!(point_in_polygon(&square, 1.0, 1.0));
        assert!(!point_in_polygon(&square, 5.0, 1.0));
        assert!((edge_distance(&square, 1.0, 2.0) - 1.0).abs() < 1e-12);
        // An L-shaped room: the notch has no points.
        let l = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 2.0],
            [2.0, 2.0],
            [2.0, 4.0],
            [0.0, 4.0],
        ];
        let placed = place(
            [0.0, 0.0],
            [4.0, 4.0],
            0.0,
            Some(0.5),
            &|x, z| point_in_polygon(&l, x, z),
            false,
        )
        .unwrap();
        assert_eq!(placed.points.len(), 64 - 16);
        assert!(placed.points.iter().all(|p| !(p[0] > 2.0 && p[2] > 2.0)));
    }
}
