//! Scenes: a folder under `scenes/` holding one OBJ file, its MTL, and an optional
//! `scene.toml`. Loading validates everything a later stage relies on and reports broken
//! input as a [`SceneError`] that names the file and line (or the object).
//!
//! Units: positions are converted to metres on load (`units`/`scale` in `scene.toml`).
//! `Kd` is diffuse reflectance in [0, 1) per channel; `Ke` is luminous exitance in lm/m²
//! per channel (see [`crate::color`]).
//!
//! Safety of input: every referenced file must resolve inside the scene folder and be a
//! regular file within a size limit ([`files`]); every number is range-checked in the type
//! it is computed in, against the bounds of [`crate::limits`]. Error messages name files
//! as `<scene id>/<path in the folder>`, never by their absolute path.

mod files;
pub(crate) use files::read_regular_file;
pub mod mtl;
pub mod obj;

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::color::{luminance, Rgb};
pub use crate::limits::MAX_GRID_POINTS;
use crate::limits::*;
pub use mtl::{parse_mtl_str, MtlLibrary, MtlMaterial};
pub use obj::{parse_obj_str, ObjPart, ObjScan};

/// Everything that can be wrong with a scene on disk. Every `path` is shown relative to the
/// scene folder, prefixed by the scene id (`office/office.mtl`).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}: not a scene folder (no .obj file in it)")]
    NoObj(PathBuf),
    #[error("{dir}: more than one .obj file ({files}); a scene folder holds exactly one")]
    ManyObj { dir: PathBuf, files: String },
    #[error("{path}: {message}")]
    Toml { path: PathBuf, message: String },
    #[error("{path}:{line}: {message}")]
    Syntax {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// A file reference (`mtllib`, `ies`) that is missing, outside the folder, or not
    /// readable as a regular file.
    #[error("{path}:{line}: {what} '{name}' {problem}")]
    Reference {
        path: PathBuf,
        line: usize,
        what: String,
        name: String,
        problem: String,
    },
    #[error("{path}:{line}: unknown material '{name}' (not defined in any mtllib)")]
    UnknownMaterial {
        path: PathBuf,
        line: usize,
        name: String,
    },
    #[error("{path}:{line}: material '{material}': {message}")]
    BadMaterial {
        path: PathBuf,
        line: usize,
        material: String,
        message: String,
    },
    #[error("{path}: light '{light}' refers to unknown {kind} '{name}'")]
    UnknownLightRef {
        path: PathBuf,
        light: String,
        kind: &'static str,
        name: String,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("{0}: the scene has no usable triangles")]
    Empty(PathBuf),
}

/// `scene.toml`, as written by the user. Every key is optional.
#[derive(Debug, Default, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneToml {
    /// Display name.
    pub name: Option<String>,
    /// Length unit of the OBJ coordinates: "m" (default), "cm", "mm", "in" or "ft".
    pub units: Option<String>,
    /// Explicit factor from OBJ units to metres; overrides `units`.
    pub scale: Option<f64>,
    /// "auto" (default), "factored" or "columns".
    pub transfer: Option<TransferChoice>,
    #[serde(default)]
    pub mesh: MeshToml,
    #[serde(default)]
    pub lights: Vec<LightToml>,
    #[serde(default)]
    pub cameras: Vec<CameraToml>,
    /// Point luminaires (IES, spot or isotropic), each in a light group.
    #[serde(default)]
    pub luminaires: Vec<LuminaireToml>,
    /// Calculation grids: work planes or point lists.
    #[serde(default)]
    pub grids: Vec<GridToml>,
    /// Per-surface options, keyed by OBJ object/group name.
    #[serde(default)]
    pub surface: BTreeMap<String, FaceOptions>,
    /// Per-material options, keyed by MTL material name.
    #[serde(default)]
    pub material: BTreeMap<String, FaceOptions>,
}

#[derive(Debug, Default, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshToml {
    /// Longest patch edge, in scene units.
    pub max_edge: Option<f64>,
    /// Aim for about this many patches when `max_edge` is not given (default 4000).
    pub target_patches: Option<usize>,
}

#[derive(Debug, Default, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaceOptions {
    /// Both sides emit, reflect and receive (thin panels).
    #[serde(default)]
    pub two_sided: bool,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightToml {
    pub id: String,
    pub name: Option<String>,
    /// Emissive materials that belong to this group.
    #[serde(default)]
    pub materials: Vec<String>,
    /// Emissive surfaces (OBJ object/group names) that belong to this group.
    #[serde(default)]
    pub surfaces: Vec<String>,
    /// Total luminous flux of the group in lumens at intensity 1; rescales its Ke.
    pub lumens: Option<f64>,
    /// Default intensity (dimming factor, 1 = as modelled).
    pub intensity: Option<f32>,
    /// Default colour filter (linear RGB multipliers).
    pub color: Option<Rgb>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LuminaireToml {
    pub id: String,
    /// Light group to join (created when no `[[lights]]` entry has this id); default `id`.
    pub group: Option<String>,
    /// Position, scene units.
    pub position: [f64; 3],
    /// Photometric axis (nadir for type C); default straight down.
    #[serde(default = "default_aim")]
    pub aim: [f64; 3],
    /// Direction of the C = 0° plane (type C) / the luminaire's length axis.
    pub c0: Option<[f64; 3]>,
    /// Total flux, lm; default: the IES file's (absolute) candela integral.
    pub lumens: Option<f64>,
    /// "isotropic", "spot" or "ies"; default "ies" when `ies` is given, else "isotropic".
    pub distribution: Option<String>,
    /// IES LM-63 file, relative to the scene folder (with its place in `scene.toml`).
    pub ies: Option<toml::Spanned<String>>,
    /// Spot beam angle (50 % of peak) and field angle (cut-off), full cone, degrees.
    pub beam_deg: Option<f64>,
    pub field_deg: Option<f64>,
    /// Linear RGB colour, or a colour temperature in kelvin (blackbody).
    pub color: Option<Rgb>,
    pub cct: Option<f64>,
    /// Electrical power (W), or luminous efficacy (lm/W) to derive it.
    pub watts: Option<f64>,
    pub efficacy: Option<f64>,
}

fn default_aim() -> [f64; 3] {
    [0.0, -1.0, 0.0]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridToml {
    pub id: String,
    pub name: Option<String>,
    /// Work plane: horizontal rectangle from `min` = [x, z] to `max` = [x, z] (scene
    /// units) at `height` above the floor (the scene's lowest point), points at the centres
    /// of cells about `spacing` wide.
    pub min: Option<[f64; 2]>,
    pub max: Option<[f64; 2]>,
    pub height: Option<f64>,
    pub spacing: Option<f64>,
    /// Or explicit points (scene units).
    pub points: Option<Vec<[f64; 3]>>,
    /// Receiver normal; default up.
    #[serde(default = "default_up")]
    pub normal: [f64; 3],
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraToml {
    pub id: String,
    pub position: [f64; 3],
    pub target: [f64; 3],
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// Vertical field of view in degrees.
    pub fov_deg: f64,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

/// How the transfer is stored: see [`crate::transport::transfer`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TransferChoice {
    #[default]
    Auto,
    Factored,
    Columns,
}

/// A material after validation.
#[derive(Debug, Clone, Serialize)]
pub struct Material {
    pub name: String,
    /// Diffuse reflectance per channel, in [0, 1).
    pub kd: Rgb,
    /// Luminous exitance per channel, lm/m² (front side).
    pub ke: Rgb,
    pub two_sided: bool,
}

/// A named surface: one OBJ object/group name.
#[derive(Debug, Clone, Serialize)]
pub struct Surface {
    pub name: String,
    pub two_sided: bool,
}

/// One input triangle, in metres, counter-clockwise seen from its front.
#[derive(Debug, Clone)]
pub struct Triangle {
    pub p: [DVec3; 3],
    pub surface: u32,
    pub material: u32,
    /// Light group this emitter belongs to (None for non-emitters).
    pub group: Option<u32>,
}

/// A light group: emitters switched and dimmed together.
#[derive(Debug, Clone, Serialize)]
pub struct LightGroup {
    pub id: String,
    pub name: String,
    /// Factor applied to the members' Ke (from `lumens`, else 1).
    pub ke_scale: f64,
    /// Default intensity of the group.
    pub intensity: f32,
    /// Default colour filter.
    pub color: Rgb,
    /// Point luminaires of the group (empty for emissive-surface groups).
    #[serde(skip)]
    pub luminaires: Vec<crate::photometry::Luminaire>,
}

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

/// A camera preset, in metres.
#[derive(Debug, Clone, Serialize)]
pub struct CameraDef {
    pub id: String,
    pub position: [f64; 3],
    pub target: [f64; 3],
    pub up: [f64; 3],
    pub fov_deg: f64,
}

/// How finely to mesh, resolved to metres.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct MeshSettings {
    /// Longest patch edge, metres.
    pub max_edge: f64,
}

/// A loaded, validated scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The scene's folder name.
    pub id: String,
    pub name: String,
    pub dir: PathBuf,
    /// Every file the scene was read from (for the cache key).
    pub files: Vec<PathBuf>,
    /// Unit label ("m", "mm", …) and its factor to metres.
    pub units: String,
    pub scale: f64,
    pub materials: Vec<Material>,
    pub surfaces: Vec<Surface>,
    pub triangles: Vec<Triangle>,
    pub lights: Vec<LightGroup>,
    pub cameras: Vec<CameraDef>,
    pub grids: Vec<Grid>,
    pub mesh: MeshSettings,
    pub transfer: TransferChoice,
    /// Non-fatal problems (skipped degenerate triangles, defaulted materials).
    pub warnings: Vec<String>,
}

/// Default patch budget when `scene.toml` gives neither `max_edge` nor `target_patches`.
pub const DEFAULT_TARGET_PATCHES: usize = 4000;

impl Scene {
    /// Loads the scene folder `dir`.
    pub fn load(dir: &Path) -> Result<Scene, SceneError> {
        let sd = files::SceneDir::open(dir)?;
        let id = sd.label.clone();
        let obj_path = find_obj(&sd)?;
        let obj_name = sd.display(&obj_path);

        let toml_file = sd.root.join("scene.toml");
        let toml_path = sd.display(&toml_file);
        let toml_canon = match std::fs::symlink_metadata(&toml_file) {
            Ok(_) => Some(sd.resolve_own(&toml_file)?),
            Err(_) => None,
        };
        let (cfg, toml_text) = match &toml_canon {
            Some(p) => {
                let text = files::to_text(&toml_path, sd.read(p, MAX_TEXT_BYTES)?)?;
                (parse_toml(&toml_path, &text)?, text)
            }
            None => (SceneToml::default(), String::new()),
        };
        let (units, scale) = resolve_units(&cfg, &toml_path)?;

        let scan = {
            let text = files::to_text(&obj_name, sd.read(&obj_path, MAX_OBJ_BYTES)?)?;
            obj::scan_obj(&obj_name, &text, scale)?
        };
        let mut warnings = scan.warnings.clone();
        let mut files = vec![obj_path.clone()];

        // Materials, from relight's own MTL reader only, in order of the mtllib statements.
        let mut materials: Vec<Material> = Vec::new();
        let mut mat_index: HashMap<String, u32> = HashMap::new();
        let mut defined_in: Vec<(PathBuf, usize)> = Vec::new();
        let mut libs_read: HashSet<PathBuf> = HashSet::new();
        for (name, line) in &scan.mtllibs {
            let p = sd.resolve(name, &obj_name, *line, "mtllib")?;
            if !libs_read.insert(p.clone()) {
                continue;
            }
            let shown = sd.display(&p);
            let text = files::to_text(&shown, sd.read(&p, MAX_TEXT_BYTES)?)?;
            let lib = mtl::parse_mtl(&shown, &text)?;
            warnings.extend(lib.warnings);
            for m in lib.materials {
                if let Some(&k) = mat_index.get(&m.name) {
                    let (other, other_line) = &defined_in[k as usize];
                    return Err(SceneError::Syntax {
                        path: shown,
                        line: m.line,
                        message: format!(
                            "material '{}' is already defined in {}:{other_line}",
                            m.name,
                            other.display()
                        ),
                    });
                }
                if materials.len() >= MAX_MATERIALS {
                    return Err(SceneError::Syntax {
                        path: shown,
                        line: m.line,
                        message: format!("more than {MAX_MATERIALS} materials in the scene"),
                    });
                }
                mat_index.insert(m.name.clone(), materials.len() as u32);
                defined_in.push((shown.clone(), m.line));
                materials.push(Material {
                    two_sided: cfg.material.get(&m.name).is_some_and(|o| o.two_sided),
                    name: m.name,
                    kd: m.kd,
                    ke: m.ke,
                });
            }
            files.push(p);
        }
        if let Some(p) = &toml_canon {
            files.push(p.clone());
        }
        for name in cfg.material.keys() {
            if !mat_index.contains_key(name) {
                return Err(SceneError::Invalid {
                    path: toml_path.clone(),
                    message: format!("[material.{name}]: no such material in the MTL files"),
                });
            }
        }
        let names: Vec<String> = materials.iter().map(|m| m.name.clone()).collect();
        let parts = obj::read_obj(&obj_name, &scan, &names)?;
        drop(scan);

        let mut surfaces: Vec<Surface> = Vec::new();
        let mut surf_index: HashMap<String, u32> = HashMap::new();
        let mut triangles = Vec::new();
        let mut dropped = 0usize;
        for part in &parts {
            let mat = match part.material {
                Some(i) => i as u32,
                None => {
                    let idx = *mat_index.entry("__default".into()).or_insert_with(|| {
                        warnings.push(format!(
                            "object '{}' has no material: using grey Kd 0.5",
                            part.name
                        ));
                        materials.push(Material {
                            name: "__default".into(),
                            kd: [0.5; 3],
                            ke: [0.0; 3],
                            two_sided: false,
                        });
                        (materials.len() - 1) as u32
                    });
                    idx
                }
            };
            let sname = if part.name.is_empty() {
                "unnamed_object".to_string()
            } else {
                part.name.clone()
            };
            let surf = *surf_index.entry(sname.clone()).or_insert_with(|| {
                surfaces.push(Surface {
                    name: sname.clone(),
                    two_sided: cfg.surface.get(&sname).is_some_and(|o| o.two_sided),
                });
                (surfaces.len() - 1) as u32
            });
            let pos = &part.positions;
            let vert = |k: u32| -> DVec3 {
                let k = k as usize * 3;
                DVec3::new(pos[k] as f64, pos[k + 1] as f64, pos[k + 2] as f64) * scale
            };
            for (t, idx) in part.indices.chunks_exact(3).enumerate() {
                let p = [vert(idx[0]), vert(idx[1]), vert(idx[2])];
                let area2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
                let longest = (p[1] - p[0])
                    .length()
                    .max((p[2] - p[1]).length())
                    .max((p[0] - p[2]).length());
                // Degenerate: zero area, or a sliver thinner than 1e-6 of its longest edge.
                if area2.is_nan() || area2 <= 1e-6 * longest * longest || area2 < 1e-14 {
                    dropped += 1;
                    if dropped <= 5 {
                        warnings.push(format!(
                            "object '{}': skipped degenerate triangle #{t}",
                            part.name
                        ));
                    }
                    continue;
                }
                triangles.push(Triangle {
                    p,
                    surface: surf,
                    material: mat,
                    group: None,
                });
            }
        }
        drop(parts);
        if dropped > 5 {
            warnings.push(format!("{} degenerate triangles skipped in all", dropped));
        }
        if triangles.is_empty() {
            return Err(SceneError::Empty(obj_name));
        }
        for name in cfg.surface.keys() {
            if !surf_index.contains_key(name) {
                return Err(SceneError::Invalid {
                    path: toml_path.clone(),
                    message: format!("[surface.{name}]: no such object/group in the OBJ"),
                });
            }
        }

        let mut lights = assign_lights(
            &cfg,
            &toml_path,
            &materials,
            &surfaces,
            &mat_index,
            &surf_index,
            &mut triangles,
        )?;

        let cameras = cfg
            .cameras
            .iter()
            .map(|c| {
                let m = |v: [f64; 3]| [v[0] * scale, v[1] * scale, v[2] * scale];
                CameraDef {
                    id: c.id.clone(),
                    position: m(c.position),
                    target: m(c.target),
                    up: c.up,
                    fov_deg: c.fov_deg,
                }
            })
            .collect();

        let toml_ref = TomlRef {
            dir: &sd,
            path: &toml_path,
            newlines: toml_text
                .bytes()
                .enumerate()
                .filter(|&(_, b)| b == b'\n')
                .map(|(i, _)| i)
                .collect(),
        };
        add_luminaires(&cfg, &toml_ref, scale, &mut lights, &mut files)?;
        if lights.len() > MAX_LIGHT_GROUPS {
            return Err(SceneError::Invalid {
                path: toml_path.clone(),
                message: format!(
                    "{} light groups ([[lights]], luminaire groups and unclaimed emissive \
                     materials); the limit is {MAX_LIGHT_GROUPS}",
                    lights.len()
                ),
            });
        }
        let grids = build_grids(&cfg, &toml_path, scale, &triangles)?;

        let total_area: f64 = triangles
            .iter()
            .map(|t| {
                let a = 0.5 * (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length();
                if is_two_sided(t, &materials, &surfaces) {
                    2.0 * a
                } else {
                    a
                }
            })
            .sum();
        // Ranges were checked by parse_toml.
        let max_edge = match (cfg.mesh.max_edge, cfg.mesh.target_patches) {
            (Some(e), _) => e * scale,
            (None, t) => {
                let target = t.unwrap_or(DEFAULT_TARGET_PATCHES).max(1) as f64;
                // Longest-edge bisection leaves triangles of about max_edge² / 5.
                (5.0 * total_area / target).sqrt()
            }
        };

        Ok(Scene {
            name: cfg.name.clone().unwrap_or_else(|| id.clone()),
            id,
            dir: dir.to_path_buf(),
            files,
            units,
            scale,
            materials,
            surfaces,
            triangles,
            lights,
            cameras,
            grids,
            mesh: MeshSettings { max_edge },
            transfer: cfg.transfer.unwrap_or_default(),
            warnings,
        })
    }

    /// Scene bounds in metres (min, max).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &self.triangles {
            for p in t.p {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (lo, hi)
    }

    /// Index of the light group with this id.
    pub fn light_index(&self, id: &str) -> Option<usize> {
        self.lights.iter().position(|l| l.id == id)
    }

    /// Index of the surface with this name.
    pub fn surface_index(&self, name: &str) -> Option<usize> {
        self.surfaces.iter().position(|s| s.name == name)
    }
}

/// True when the triangle is modelled with both sides active.
pub fn is_two_sided(t: &Triangle, materials: &[Material], surfaces: &[Surface]) -> bool {
    materials[t.material as usize].two_sided || surfaces[t.surface as usize].two_sided
}

/// Parses the text of a `scene.toml` and checks every number in it against
/// [`crate::limits`] (what needs the geometry, such as material names, is checked by
/// [`Scene::load`]). `path` is the display name errors use.
pub fn parse_scene_toml(path: &str, text: &str) -> Result<SceneToml, SceneError> {
    parse_toml(Path::new(path), text)
}

fn parse_toml(path: &Path, text: &str) -> Result<SceneToml, SceneError> {
    let cfg: SceneToml = toml::from_str(text).map_err(|e| SceneError::Toml {
        path: path.to_path_buf(),
        message: e.to_string().trim_end().replace('\n', " "),
    })?;
    validate_toml(&cfg, path)?;
    Ok(cfg)
}

/// A number for a message: plain when moderate, else in exponent form (`1e300`, `1e-9`).
pub(crate) fn num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-4..1e15).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// `lo ≤ v ≤ hi` and finite, else an error naming `what` and the range.
fn in_range(what: &str, v: f64, lo: f64, hi: f64) -> Result<(), String> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(format!("{what} = {}: must be in {lo}..={hi:e}", num(v)))
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

/// Checks the ranges of every number of a `scene.toml` (see [`crate::limits`]).
fn validate_toml(cfg: &SceneToml, path: &Path) -> Result<(), SceneError> {
    let inv = |message: String| SceneError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    let (_, scale) = resolve_units(cfg, path)?;
    for (what, n, max) in [
        ("[[lights]]", cfg.lights.len(), MAX_TOML_ENTRIES),
        ("[[luminaires]]", cfg.luminaires.len(), MAX_LUMINAIRES),
        ("[[grids]]", cfg.grids.len(), MAX_TOML_ENTRIES),
        ("[[cameras]]", cfg.cameras.len(), MAX_TOML_ENTRIES),
    ] {
        if n > max {
            return Err(inv(format!("{n} {what} entries; the limit is {max}")));
        }
    }
    let mut grid_points = 0f64;
    if let Some(e) = cfg.mesh.max_edge {
        let m = e * scale;
        if !(e.is_finite() && (MIN_MAX_EDGE_M..=MAX_MAX_EDGE_M).contains(&m)) {
            return Err(inv(format!(
                "[mesh] max_edge = {}: must be a length between {MIN_MAX_EDGE_M} m and \
                 {MAX_MAX_EDGE_M:e} m (after scaling)",
                num(e)
            )));
        }
    }
    if let Some(t) = cfg.mesh.target_patches {
        if !(1..=MAX_TARGET_PATCHES).contains(&t) {
            return Err(inv(format!(
                "[mesh] target_patches = {t}: must be in 1..={MAX_TARGET_PATCHES}"
            )));
        }
    }
    for l in &cfg.lights {
        let ctx = |m: String| inv(format!("light '{}': {m}", l.id));
        if let Some(lm) = l.lumens {
            in_range("lumens", lm, 0.0, MAX_LUMENS).map_err(ctx)?;
        }
        if let Some(i) = l.intensity {
            in_range("intensity", i as f64, 0.0, MAX_INTENSITY).map_err(ctx)?;
        }
        if let Some(c) = &l.color {
            color_ok("color", c).map_err(ctx)?;
        }
    }
    for l in &cfg.luminaires {
        let ctx = |m: String| inv(format!("luminaire '{}': {m}", l.id));
        position("position", &l.position, scale).map_err(ctx)?;
        direction("aim", &l.aim).map_err(ctx)?;
        if let Some(c) = &l.c0 {
            direction("c0", c).map_err(ctx)?;
        }
        if let Some(lm) = l.lumens {
            in_range("lumens", lm, 0.0, MAX_LUMENS).map_err(ctx)?;
        }
        for (what, v) in [("beam_deg", l.beam_deg), ("field_deg", l.field_deg)] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0 && v <= 180.0) {
                    return Err(ctx(format!("{what} = {}: must be in (0, 180]", num(v))));
                }
            }
        }
        if let Some(k) = l.cct {
            if !(k.is_finite() && (MIN_CCT..=MAX_CCT).contains(&k)) {
                return Err(ctx(format!(
                    "cct = {}: must be {MIN_CCT}..{MAX_CCT} K",
                    num(k)
                )));
            }
        }
        if let Some(c) = &l.color {
            color_ok("color", c).map_err(ctx)?;
        }
        if let Some(w) = l.watts {
            in_range("watts", w, 0.0, MAX_WATTS).map_err(ctx)?;
        }
        if let Some(e) = l.efficacy {
            if !(e.is_finite() && e > 0.0 && e <= MAX_EFFICACY) {
                return Err(ctx(format!(
                    "efficacy = {}: must be in (0, {MAX_EFFICACY}] lm/W",
                    num(e)
                )));
            }
        }
    }
    for c in &cfg.cameras {
        let ctx = |m: String| inv(format!("camera '{}': {m}", c.id));
        position("position", &c.position, scale).map_err(ctx)?;
        position("target", &c.target, scale).map_err(ctx)?;
        direction("up", &c.up).map_err(ctx)?;
        if !(c.fov_deg > 0.0 && c.fov_deg < 180.0) {
            return Err(ctx(format!(
                "fov_deg = {}: must be in (0, 180)",
                num(c.fov_deg)
            )));
        }
    }
    for g in &cfg.grids {
        let ctx = |m: String| inv(format!("grid '{}': {m}", g.id));
        direction("normal", &g.normal).map_err(ctx)?;
        if let Some(p) = &g.points {
            if p.len() > MAX_GRID_POINTS {
                return Err(ctx(format!(
                    "{} points; the limit is {MAX_GRID_POINTS}",
                    p.len()
                )));
            }
            for q in p {
                position("points", q, scale).map_err(ctx)?;
            }
            grid_points += p.len() as f64;
        }
        for (what, v) in [("min", g.min), ("max", g.max)] {
            if let Some(v) = v {
                position(what, &v, scale).map_err(ctx)?;
            }
        }
        if let Some(h) = g.height {
            position("height", &[h], scale).map_err(ctx)?;
        }
        if let Some(sp) = g.spacing {
            let m = sp * scale;
            if !(sp.is_finite() && m.is_finite() && m >= MIN_GRID_SPACING_M) {
                return Err(ctx(format!(
                    "spacing = {}: must be at least {MIN_GRID_SPACING_M} m (after scaling)",
                    num(sp)
                )));
            }
        }
        if let (Some(lo), Some(hi)) = (g.min, g.max) {
            let sp = g.spacing.unwrap_or(0.25 / scale);
            // Counted in f64 before anything is allocated.
            let nx = ((hi[0] - lo[0]) / sp).ceil().max(1.0);
            let nz = ((hi[1] - lo[1]) / sp).ceil().max(1.0);
            if nx * nz > MAX_GRID_POINTS as f64 {
                return Err(ctx(format!(
                    "{} × {} points; the limit is {MAX_GRID_POINTS}",
                    num(nx),
                    num(nz)
                )));
            }
            grid_points += nx * nz;
        }
        if grid_points > MAX_GRID_POINTS_TOTAL as f64 {
            return Err(ctx(format!(
                "the grids have {} points in all; the limit is {MAX_GRID_POINTS_TOTAL}",
                num(grid_points)
            )));
        }
    }
    Ok(())
}

fn resolve_units(cfg: &SceneToml, toml_path: &Path) -> Result<(String, f64), SceneError> {
    if let Some(s) = cfg.scale {
        if !(s.is_finite() && (MIN_SCALE..=MAX_SCALE).contains(&s)) {
            return Err(SceneError::Invalid {
                path: toml_path.into(),
                message: format!(
                    "scale = {}: must be a factor to metres in {MIN_SCALE:e}..={MAX_SCALE:e}",
                    num(s)
                ),
            });
        }
        return Ok((cfg.units.clone().unwrap_or_else(|| format!("{s} m")), s));
    }
    let u = cfg.units.clone().unwrap_or_else(|| "m".into());
    let s = match u.as_str() {
        "m" | "metre" | "metres" | "meter" | "meters" => 1.0,
        "cm" => 0.01,
        "mm" | "millimetre" | "millimetres" => 0.001,
        "in" | "inch" | "inches" => 0.0254,
        "ft" | "foot" | "feet" => 0.3048,
        other => {
            return Err(SceneError::Invalid {
                path: toml_path.into(),
                message: format!(
                "units = \"{other}\": use m, cm, mm, in or ft, or give scale = <factor to metres>"
            ),
            })
        }
    };
    Ok((u, s))
}

/// The folder's one `.obj` file, canonicalized (it must resolve inside the folder).
fn find_obj(sd: &files::SceneDir) -> Result<PathBuf, SceneError> {
    let root = sd.display_root();
    let mut objs: Vec<PathBuf> = std::fs::read_dir(&sd.root)
        .map_err(|source| SceneError::Io {
            path: root.clone(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj")))
        .collect();
    objs.sort();
    match objs.len() {
        0 => Err(SceneError::NoObj(root)),
        1 => sd.resolve_own(&objs[0]),
        _ => Err(SceneError::ManyObj {
            dir: root,
            files: objs
                .iter()
                .map(|p| {
                    p.file_name()
                        .unwrap_or_default()
                        .to_string_lossy()
                        .into_owned()
                })
                .collect::<Vec<_>>()
                .join(", "),
        }),
    }
}

/// `scene.toml` as luminaires see it: to resolve `ies` references with their line.
struct TomlRef<'a> {
    dir: &'a files::SceneDir,
    path: &'a Path,
    /// Byte offsets of the text's newlines.
    newlines: Vec<usize>,
}

impl TomlRef<'_> {
    /// 1-based line of byte `offset` of the text.
    fn line_of(&self, offset: usize) -> usize {
        1 + self.newlines.partition_point(|&n| n < offset)
    }
}

fn assign_lights(
    cfg: &SceneToml,
    toml_path: &Path,
    materials: &[Material],
    surfaces: &[Surface],
    mat_index: &HashMap<String, u32>,
    surf_index: &HashMap<String, u32>,
    triangles: &mut [Triangle],
) -> Result<Vec<LightGroup>, SceneError> {
    let mut groups: Vec<LightGroup> = Vec::new();
    // Per group: member materials and surfaces.
    let mut members: Vec<(Vec<u32>, Vec<u32>)> = Vec::new();
    for l in &cfg.lights {
        if l.id.is_empty() || groups.iter().any(|g| g.id == l.id) {
            return Err(SceneError::Invalid {
                path: toml_path.into(),
                message: format!("light id '{}' is empty or used twice", l.id),
            });
        }
        let mut mats = Vec::new();
        for m in &l.materials {
            mats.push(
                *mat_index
                    .get(m)
                    .ok_or_else(|| SceneError::UnknownLightRef {
                        path: toml_path.into(),
                        light: l.id.clone(),
                        kind: "material",
                        name: m.clone(),
                    })?,
            );
        }
        let mut surfs = Vec::new();
        for s in &l.surfaces {
            surfs.push(
                *surf_index
                    .get(s)
                    .ok_or_else(|| SceneError::UnknownLightRef {
                        path: toml_path.into(),
                        light: l.id.clone(),
                        kind: "surface",
                        name: s.clone(),
                    })?,
            );
        }
        let has_luminaires = cfg
            .luminaires
            .iter()
            .any(|m| m.group.as_deref().unwrap_or(&m.id) == l.id);
        if mats.is_empty() && surfs.is_empty() && !has_luminaires {
            return Err(SceneError::Invalid {
                path: toml_path.into(),
                message: format!(
                    "light '{}' names no materials or surfaces, and no luminaire joins it",
                    l.id
                ),
            });
        }
        if let Some(c) = l.color {
            if c.iter().any(|x| !x.is_finite() || *x < 0.0) {
                return Err(SceneError::Invalid {
                    path: toml_path.into(),
                    message: format!("light '{}': color must be 3 non-negative numbers", l.id),
                });
            }
        }
        let intensity = l.intensity.unwrap_or(1.0);
        if !(intensity.is_finite() && intensity >= 0.0) {
            return Err(SceneError::Invalid {
                path: toml_path.into(),
                message: format!("light '{}': intensity must be non-negative", l.id),
            });
        }
        groups.push(LightGroup {
            id: l.id.clone(),
            name: l.name.clone().unwrap_or_else(|| l.id.clone()),
            ke_scale: 1.0,
            intensity,
            color: l.color.unwrap_or([1.0; 3]),
            luminaires: vec![],
        });
        members.push((mats, surfs));
    }
    for t in triangles.iter_mut() {
        let ke = materials[t.material as usize].ke;
        if ke.iter().all(|&x| x == 0.0) {
            continue;
        }
        let mut found: Option<u32> = None;
        for (g, (mats, surfs)) in members.iter().enumerate() {
            if mats.contains(&t.material) || surfs.contains(&t.surface) {
                if let Some(prev) = found {
                    return Err(SceneError::Invalid {
                        path: toml_path.into(),
                        message: format!(
                            "surface '{}' belongs to two lights, '{}' and '{}'",
                            surfaces[t.surface as usize].name,
                            groups[prev as usize].id,
                            groups[g].id
                        ),
                    });
                }
                found = Some(g as u32);
            }
        }
        let g = match found {
            Some(g) => g,
            None => {
                // Emitters no group claims get a group named after their material.
                let mname = &materials[t.material as usize].name;
                match groups.iter().position(|g| &g.id == mname) {
                    Some(g) => g as u32,
                    None => {
                        groups.push(LightGroup {
                            id: mname.clone(),
                            name: mname.clone(),
                            ke_scale: 1.0,
                            intensity: 1.0,
                            color: [1.0; 3],
                            luminaires: vec![],
                        });
                        members.push((vec![t.material], vec![]));
                        (groups.len() - 1) as u32
                    }
                }
            }
        };
        t.group = Some(g);
    }
    // Rescale groups that state their flux.
    for (g, l) in cfg.lights.iter().enumerate() {
        let Some(lm) = l.lumens else { continue };
        if !(lm.is_finite() && lm >= 0.0) {
            return Err(SceneError::Invalid {
                path: toml_path.into(),
                message: format!("light '{}': lumens must be non-negative", l.id),
            });
        }
        let flux: f64 = triangles
            .iter()
            .filter(|t| t.group == Some(g as u32))
            .map(|t| {
                let a = 0.5 * (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length();
                let sides = if is_two_sided(t, materials, surfaces) {
                    2.0
                } else {
                    1.0
                };
                a * sides * luminance(materials[t.material as usize].ke) as f64
            })
            .sum();
        if flux <= 0.0 {
            return Err(SceneError::Invalid {
                path: toml_path.into(),
                message: format!(
                    "light '{}' gives lumens but its members emit nothing (no Ke)",
                    l.id
                ),
            });
        }
        groups[g].ke_scale = lm / flux;
    }
    Ok(groups)
}

/// Builds the `[[luminaires]]` and attaches each to its light group (creating groups that
/// `[[lights]]` does not define). IES files join `files` for the cache key.
fn add_luminaires(
    cfg: &SceneToml,
    toml: &TomlRef<'_>,
    scale: f64,
    lights: &mut Vec<LightGroup>,
    files: &mut Vec<PathBuf>,
) -> Result<(), SceneError> {
    let toml_path = toml.path;
    use crate::photometry::{cct_to_rgb, Distribution, Luminaire};
    let bad = |id: &str, m: String| SceneError::Invalid {
        path: toml_path.into(),
        message: format!("luminaire '{id}': {m}"),
    };
    let mut seen = std::collections::HashSet::new();
    // Luminaires sharing an IES file or a spot shape share its table and its integral.
    let mut ies_read: HashMap<PathBuf, Box<crate::photometry::IesData>> = HashMap::new();
    let mut integrals: HashMap<String, f64> = HashMap::new();
    for l in &cfg.luminaires {
        let mut integral_key: Option<String> = None;
        if l.id.is_empty() || !seen.insert(l.id.clone()) {
            return Err(bad(&l.id, "id is empty or used twice".into()));
        }
        let finite3 = |v: [f64; 3]| v.iter().all(|x| x.is_finite());
        if !finite3(l.position) || !finite3(l.aim) || l.c0.is_some_and(|c| !finite3(c)) {
            return Err(bad(&l.id, "position, aim and c0 must be finite".into()));
        }
        let kind = l
            .distribution
            .clone()
            .unwrap_or_else(|| if l.ies.is_some() { "ies" } else { "isotropic" }.into());
        let distribution = match kind.as_str() {
            "isotropic" => Distribution::Isotropic,
            "spot" => {
                let beam = l.beam_deg.unwrap_or(30.0);
                let field = l.field_deg.unwrap_or(2.0 * beam);
                if !(beam > 0.0 && beam < 180.0 && field >= beam && field <= 180.0) {
                    return Err(bad(
                        &l.id,
                        format!("spot needs 0 < beam_deg ({beam}) < 180 and beam_deg ≤ field_deg ({field}) ≤ 180"),
                    ));
                }
                integral_key = Some(format!("spot:{beam:?}:{field:?}"));
                Distribution::Spot {
                    beam_deg: beam,
                    field_deg: field,
                }
            }
            "ies" => {
                let name = l.ies.as_ref().ok_or_else(|| {
                    bad(
                        &l.id,
                        "distribution \"ies\" needs ies = \"file.ies\"".into(),
                    )
                })?;
                let line = toml.line_of(name.span().start);
                let path = toml.dir.resolve(
                    name.get_ref(),
                    toml_path,
                    line,
                    &format!("luminaire '{}': ies", l.id),
                )?;
                let data = match ies_read.get(&path) {
                    Some(d) => d.clone(),
                    None => {
                        let shown = toml.dir.display(&path);
                        // IES headers are often Latin-1: only the numbers matter.
                        let bytes = toml.dir.read(&path, MAX_TEXT_BYTES)?;
                        let text = String::from_utf8_lossy(&bytes);
                        let d = Box::new(crate::photometry::parse_ies_file(&shown, &text)?);
                        ies_read.insert(path.clone(), d.clone());
                        d
                    }
                };
                if !files.contains(&path) {
                    files.push(path.clone());
                }
                integral_key = Some(format!("ies:{}", path.display()));
                Distribution::Ies(data)
            }
            other => {
                return Err(bad(
                    &l.id,
                    format!("distribution '{other}': use isotropic, spot or ies"),
                ))
            }
        };
        let color = match (l.color, l.cct) {
            (Some(_), Some(_)) => return Err(bad(&l.id, "give color or cct, not both".into())),
            (Some(c), None) => c,
            (None, Some(k)) if (MIN_CCT..=MAX_CCT).contains(&k) => cct_to_rgb(k),
            (None, Some(k)) => return Err(bad(&l.id, format!("cct = {k}: must be 1000..40000 K"))),
            (None, None) => [1.0; 3],
        };
        let v = |a: [f64; 3]| DVec3::from_array(a);
        let integral = match integral_key {
            Some(k) => *integrals
                .entry(k)
                .or_insert_with(|| distribution.integral()),
            None => distribution.integral(),
        };
        let mut lum = Luminaire::with_integral(
            &l.id,
            v(l.position) * scale,
            v(l.aim),
            l.c0.map(v),
            distribution,
            integral,
            l.lumens,
            color,
            None,
        )
        .map_err(|e| bad(&l.id, e))?;
        lum.watts = match (l.watts, l.efficacy) {
            (Some(w), _) if w.is_finite() && w >= 0.0 => Some(w),
            (None, Some(e)) if e.is_finite() && e > 0.0 => Some(lum.lumens / e),
            (None, None) => None,
            _ => return Err(bad(&l.id, "watts must be ≥ 0 and efficacy > 0".into())),
        };
        let gid = l.group.clone().unwrap_or_else(|| l.id.clone());
        let g = match lights.iter().position(|g| g.id == gid) {
            Some(g) => g,
            None => {
                lights.push(LightGroup {
                    id: gid.clone(),
                    name: gid.clone(),
                    ke_scale: 1.0,
                    intensity: 1.0,
                    color: [1.0; 3],
                    luminaires: vec![],
                });
                lights.len() - 1
            }
        };
        lights[g].luminaires.push(lum);
    }
    Ok(())
}

/// Resolves `[[grids]]` to points in metres.
fn build_grids(
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
        let (points, layout) = match (&g.points, g.min, g.max) {
            (Some(p), None, None) => {
                if p.iter().flatten().any(|x| !x.is_finite()) {
                    return Err(bad("points must be finite".into()));
                }
                (p.iter().map(|q| q.map(|x| x * scale)).collect::<Vec<_>>(), None)
            }
            (None, Some(lo), Some(hi)) => {
                let h = g.height.unwrap_or(0.75 / scale);
                let sp = g.spacing.unwrap_or(0.25 / scale);
                if !(sp > 0.0 && sp.is_finite() && h.is_finite()) {
                    return Err(bad("spacing must be positive and height finite".into()));
                }
                if !(hi[0] > lo[0] && hi[1] > lo[1]) {
                    return Err(bad("max must exceed min in x and z".into()));
                }
                let nx = ((hi[0] - lo[0]) / sp).ceil().max(1.0) as usize;
                let nz = ((hi[1] - lo[1]) / sp).ceil().max(1.0) as usize;
                if nx.saturating_mul(nz) > MAX_GRID_POINTS {
                    return Err(bad(format!(
                        "{nx} × {nz} points; the limit is {MAX_GRID_POINTS}"
                    )));
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
                (pts, Some([nx, nz]))
            }
            _ => {
                return Err(bad(
                    "give either points = [[x, y, z], ...] or min = [x, z], max = [x, z] (with height, spacing)".into(),
                ))
            }
        };
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
