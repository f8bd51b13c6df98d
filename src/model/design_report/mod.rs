//! The design report: what a lighting designer hands the client, assembled from the query
//! layer's answers for one lighting state, and written as one self-contained, printable
//! HTML document ([`DesignReport::html`]).
//!
//! - The title block: title, project, scene, date, author, relight's version and the
//!   lighting state (each group's level).
//! - The luminaire schedule, grouped by identical type (photometric file or distribution
//!   kind, lumens, watts): count, lumens, watts, lm/W.
//! - Per grid: a false-colour plan of the maintained illuminance ([`plan`]), Ēm, Emin, Emax,
//!   U₀, the initial average and the UGR where a UGR_L is required, each with pass or fail
//!   from [`super::compliance`]; the assumptions (maintenance factors, reflectances).
//! - The relit images the caller made (one per camera), as PNG data URLs.
//! - Installed power and power density. The floor area is that of the upward-facing
//!   patches at the scene's lowest level (within [`FLOOR_TOLERANCE_M`]); a scene without
//!   one takes the largest grid's area (points × spacing²).
//!
//! It knows nothing of HTTP: the server parses the request, renders the images and sends
//! the text.

use std::collections::{BTreeMap, HashMap};

use super::compliance::Compliance;
use super::placed::Placed;
use super::query::{GridAnswer, IlluminanceQuery, LuminairePower};
use super::{Cancel, Lighting, Model, QueryError};
use crate::color::Rgb;
use crate::photometry::{Distribution, Luminaire, PhotometricFormat};

mod html;
mod plan;

/// Longest title, project or author, characters.
pub const MAX_META_CHARS: usize = 200;

/// Patches this close above the scene's lowest point count as floor, m.
pub const FLOOR_TOLERANCE_M: f64 = 0.05;

/// Grids with more points than this get no plan (the table still lists them).
pub const MAX_PLAN_POINTS: usize = 40_000;

/// The words of the title block, as given (the writer escapes them).
#[derive(Debug, Clone, Default)]
pub struct ReportMeta {
    pub title: Option<String>,
    pub project: Option<String>,
    pub author: Option<String>,
}

/// A relit image of one camera, PNG.
#[derive(Debug, Clone)]
pub struct CameraImage {
    pub camera: String,
    pub width: u32,
    pub height: u32,
    pub png: Vec<u8>,
}

/// One light group's level in the reported state.
#[derive(Debug, Clone)]
pub struct GroupLevel {
    pub id: String,
    pub name: String,
    /// Luminous level of the weight (1 = as rated).
    pub level: f64,
    /// The RGB weight, when its channels differ.
    pub color: Option<Rgb>,
    pub maintenance_factor: f64,
    pub ra: Option<f64>,
}

/// Luminaires of one type.
#[derive(Debug, Clone)]
pub struct ScheduleRow {
    /// Distribution kind (e.g. "IES LM-63", "spot 30°/60°").
    pub kind: String,
    /// The photometric file's name, when it came from one.
    pub file: Option<String>,
    /// The groups they belong to.
    pub groups: Vec<String>,
    pub count: usize,
    /// Rated lumens of one luminaire.
    pub lumens: f64,
    /// Watts of one luminaire, when known.
    pub watts: Option<f64>,
}

/// One grid's answers.
#[derive(Debug, Clone)]
pub struct GridReport {
    pub id: String,
    pub name: String,
    pub kind: Option<crate::scene::grids::GridKind>,
    pub points: Vec<[f64; 3]>,
    pub spacing: Option<f64>,
    pub initial: GridAnswer,
    pub maintained: GridAnswer,
    pub compliance: Option<Compliance>,
}

/// A material's share of the scene and its reflectance.
#[derive(Debug, Clone)]
pub struct Reflectance {
    pub material: String,
    pub area: f64,
    /// Luminous reflectance ρ (Y of Kd).
    pub rho: f64,
    pub kd: Rgb,
}

/// Power and its density.
#[derive(Debug, Clone)]
pub struct PowerSummary {
    /// At every luminaire's rated output, W (None when a luminaire gives no wattage).
    pub installed_watts: Option<f64>,
    pub installed_lumens: f64,
    /// In the reported state.
    pub state: LuminairePower,
    /// m², and how it was found.
    pub floor_area: Option<f64>,
    pub floor_source: &'static str,
}

/// Everything the report shows.
#[derive(Debug, Clone)]
pub struct DesignReport {
    pub meta: ReportMeta,
    pub scene_id: String,
    pub scene_name: String,
    /// YYYY-MM-DD (UTC).
    pub date: String,
    pub version: &'static str,
    pub groups: Vec<GroupLevel>,
    pub schedule: Vec<ScheduleRow>,
    pub grids: Vec<GridReport>,
    pub reflectances: Vec<Reflectance>,
    pub power: PowerSummary,
    pub images: Vec<CameraImage>,
}

/// Bytes of report text per grid point (its plan cell and label).
const BYTES_PER_PLAN_POINT: u64 = 320;

impl DesignReport {
    /// Peak bytes a report of `model` with images of `pixels` pixels each takes, the
    /// images made one at a time with at most `render_bytes` each: every encoded image
    /// kept (PNG at most 4 bytes a pixel, and its base64 text), the grids' answers and
    /// the text.
    pub fn estimate_bytes(model: &Model, pixels: &[u64], render_bytes: u64) -> u64 {
        let points: u64 = model.grids.iter().map(|g| g.len() as u64).sum();
        let kept: u64 = pixels.iter().map(|px| 10 * px).sum();
        let q = IlluminanceQuery {
            grids: (0..model.grids.len()).collect(),
            ..Default::default()
        };
        render_bytes + kept + 2 * model.illuminance_bytes(&q) + BYTES_PER_PLAN_POINT * points
    }

    /// Assembles the report of `lighting` (group weights, or luminaires placed for the
    /// request) on `model`, with the caller's `images`. A per-patch emission has no
    /// luminaires or groups to report (an error).
    pub fn assemble(
        model: &Model,
        lighting: &Lighting,
        meta: ReportMeta,
        images: Vec<CameraImage>,
        cancel: &Cancel,
    ) -> Result<DesignReport, QueryError> {
        let scene = &model.baked.scene;
        let none = Placed::default();
        let (w, installed) = match lighting {
            Lighting::Groups(w) => (w.as_slice(), none.installed(scene)),
            Lighting::Placed(p) => (p.weights.as_slice(), p.installed(scene)),
            Lighting::Emission(_) => {
                return Err(QueryError::Invalid(
                    "a design report reports light groups (lights) and luminaires, not a \
                     per-patch emission"
                        .into(),
                ))
            }
        };
        let q = IlluminanceQuery {
            grids: (0..model.grids.len()).collect(),
            ..Default::default()
        };
        let mut answer = model.illuminance(lighting, &q, cancel)?;
        let grids = model
            .grids
            .iter()
            .filter_map(|g| {
                let id = &g.grid.id;
                Some(GridReport {
                    id: id.clone(),
                    name: g.grid.name.clone(),
                    kind: g.grid.kind,
                    points: g.grid.points.clone(),
                    spacing: g.grid.spacing,
                    initial: answer.grids.remove(id)?,
                    maintained: answer.maintained.grids.remove(id)?,
                    compliance: answer.compliance.remove(id),
                })
            })
            .collect();
        let groups = scene
            .lights
            .iter()
            .zip(w)
            .map(|(g, wg)| GroupLevel {
                id: g.id.clone(),
                name: g.name.clone(),
                level: wg.luminance() as f64,
                color: (wg[0] != wg[1] || wg[1] != wg[2]).then_some(*wg),
                maintenance_factor: answer
                    .maintenance_factors
                    .get(&g.id)
                    .copied()
                    .unwrap_or(1.0),
                ra: g.ra,
            })
            .collect();
        let schedule = schedule(model, &installed);
        let power = power(
            model,
            &schedule,
            answer.power.unwrap_or(LuminairePower {
                luminaire_lumens: 0.0,
                luminaire_watts: None,
            }),
        );
        Ok(DesignReport {
            meta,
            scene_id: scene.id.clone(),
            scene_name: scene.name.clone(),
            date: today_utc(),
            version: env!("CARGO_PKG_VERSION"),
            groups,
            schedule,
            grids,
            reflectances: reflectances(model),
            power,
            images,
        })
    }
}

/// The luminaire schedule of the `installed` luminaires (with their groups and the
/// photometry a request gave them): grouped by kind, file, lumens and watts, in order of
/// their first member.
fn schedule(
    model: &Model,
    installed: &[(&Luminaire, Option<usize>, Option<&str>)],
) -> Vec<ScheduleRow> {
    let scene = &model.baked.scene;
    let files = photometric_files(scene);
    let mut rows: Vec<ScheduleRow> = Vec::new();
    for &(l, group, given) in installed {
        let g = &group.map_or("(no group)".to_string(), |k| scene.lights[k].id.clone());
        {
            let kind = kind_label(&l.distribution);
            let file = given
                .map(str::to_string)
                .or_else(|| files.get(&l.id).cloned());
            let same = |r: &ScheduleRow| {
                r.kind == kind
                    && r.file == file
                    && (r.lumens - l.lumens).abs() <= 1e-6 * l.lumens.abs().max(1.0)
                    && r.watts.map(|x| (x * 1e3).round()) == l.watts.map(|x| (x * 1e3).round())
            };
            match rows.iter_mut().find(|r| same(r)) {
                Some(r) => {
                    r.count += 1;
                    if !r.groups.contains(g) {
                        r.groups.push(g.clone());
                    }
                }
                None => rows.push(ScheduleRow {
                    kind,
                    file,
                    groups: vec![g.clone()],
                    count: 1,
                    lumens: l.lumens,
                    watts: l.watts,
                }),
            }
        }
    }
    rows
}

/// A distribution's kind in words.
fn kind_label(d: &Distribution) -> String {
    match d {
        Distribution::Isotropic => "isotropic".into(),
        Distribution::Spot {
            beam_deg,
            field_deg,
        } => format!("spot {beam_deg:.0}°/{field_deg:.0}°"),
        Distribution::Cone {
            inner_deg,
            outer_deg,
        } => format!("cone {inner_deg:.0}°/{outer_deg:.0}°"),
        Distribution::Table(t) => match t.format {
            PhotometricFormat::Ies => "IES LM-63".into(),
            PhotometricFormat::Eulumdat => "EULUMDAT".into(),
        },
    }
}

/// The photometric file of each luminaire id, from the scene folder's `scene.toml` (the
/// loaded scene keeps the table, not its name); empty when it cannot be read.
pub(crate) fn photometric_files(scene: &crate::scene::Scene) -> HashMap<String, String> {
    let path = scene.dir.join("scene.toml");
    let Ok(text) = std::fs::read_to_string(&path) else {
        return HashMap::new();
    };
    let Ok(cfg) = crate::scene::parse_scene_toml("scene.toml", &text) else {
        return HashMap::new();
    };
    cfg.luminaires
        .iter()
        .filter_map(|l| {
            let f = l.photometry.as_ref().or(l.ies.as_ref())?;
            Some((l.id.clone(), f.get_ref().clone()))
        })
        .collect()
}

/// The installed power and the floor area.
fn power(model: &Model, schedule: &[ScheduleRow], state: LuminairePower) -> PowerSummary {
    let installed_watts = schedule
        .iter()
        .map(|r| r.watts.map(|x| x * r.count as f64))
        .sum();
    let installed_lumens = schedule.iter().map(|r| r.lumens * r.count as f64).sum();
    let (floor_area, floor_source) = match floor_area(model) {
        a if a > 0.0 => (Some(a), "upward-facing surfaces at the lowest level"),
        _ => match largest_grid_area(model) {
            a if a > 0.0 => (Some(a), "the largest calculation grid"),
            _ => (None, "no floor or grid to measure"),
        },
    };
    PowerSummary {
        installed_watts,
        installed_lumens,
        state,
        floor_area,
        floor_source,
    }
}

/// Area of the patches facing up at the scene's lowest level, m².
fn floor_area(model: &Model) -> f64 {
    let patches = &model.baked.mesh.patches;
    let lowest = patches
        .iter()
        .map(|p| p.centroid.y)
        .fold(f64::INFINITY, f64::min);
    patches
        .iter()
        .filter(|p| p.normal.y > 0.99 && p.centroid.y <= lowest + FLOOR_TOLERANCE_M)
        .map(|p| p.area)
        .sum()
}

/// The largest grid's area (points × spacing²), m²; 0 without spaced grids.
fn largest_grid_area(model: &Model) -> f64 {
    let area = |g: &crate::scene::Grid| g.spacing.map_or(0.0, |s| g.points.len() as f64 * s * s);
    model
        .grids
        .iter()
        .map(|g| area(&g.grid))
        .fold(0.0, f64::max)
}

/// The materials that reflect (not the emitters), by the area they cover, largest first:
/// those covering at least 1 % of the scene, at most ten.
fn reflectances(model: &Model) -> Vec<Reflectance> {
    let scene = &model.baked.scene;
    let mut area: BTreeMap<u32, f64> = BTreeMap::new();
    for p in &model.baked.mesh.patches {
        *area.entry(p.material).or_default() += p.area;
    }
    let total: f64 = area.values().sum();
    let mut out: Vec<Reflectance> = area
        .into_iter()
        .filter_map(|(m, a)| {
            let mat = scene.materials.get(m as usize)?;
            let emits = mat.ke.iter().any(|&c| c > 0.0);
            (!emits && a >= 0.01 * total).then(|| Reflectance {
                material: mat.name.clone(),
                area: a,
                rho: mat.kd.to_f64().luminance(),
                kd: mat.kd,
            })
        })
        .collect();
    out.sort_by(|a, b| b.area.total_cmp(&a.area));
    out.truncate(10);
    out
}

/// Today's date, UTC, as YYYY-MM-DD.
fn today_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (y, m, d) = civil_from_days((secs / 86_400) as i64);
    format!("{y:04}-{m:02}-{d:02}")
}

/// The proleptic Gregorian date of a day count since 1970-01-01 (H. Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

/// Illuminance as the report prints it: whole lux from 10 lx, else one decimal.
pub fn fmt_lux(v: f64) -> String {
    if !v.is_finite() {
        "–".into()
    } else if v.abs() >= 10.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn days_become_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(19_723), (2024, 1, 1));
        assert_eq!(civil_from_days(19_782), (2024, 2, 29));
    }

    #[test]
    fn lux_prints_whole_from_ten() {
        assert_eq!(fmt_lux(523.46), "523");
        assert_eq!(fmt_lux(9.96), "10.0");
        assert_eq!(fmt_lux(f64::NAN), "–");
    }
}
