//! Scenes: a folder under `scenes/` holding one OBJ file, its MTL, and an optional
//! `scene.toml`. Loading validates everything a later stage relies on and reports broken
//! input as a [`SceneError`] that names the file and line (or the object).
//!
//! Units: positions are converted to metres on load (`units`/`scale` in `scene.toml`).
//! `Kd` is diffuse reflectance in [0, 1) per channel; `Ke` is luminous exitance in lm/m²
//! per channel (see [`crate::color`]).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::color::{luminance, Rgb};

/// Everything that can be wrong with a scene on disk.
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
    #[error("{path}:{line}: material library '{mtl}' not found")]
    MissingMtl {
        path: PathBuf,
        line: usize,
        mtl: String,
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

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SceneError + '_ {
    move |source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    }
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
    /// IES LM-63 file, relative to the scene folder.
    pub ies: Option<String>,
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

/// How the transfer is stored: see [`crate::transfer`].
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

/// Most points in one grid.
pub const MAX_GRID_POINTS: usize = 20_000;

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
        let dir = dir.to_path_buf();
        let meta = std::fs::metadata(&dir).map_err(io_err(&dir))?;
        if !meta.is_dir() {
            return Err(SceneError::Invalid {
                path: dir,
                message: "not a directory".into(),
            });
        }
        let obj_path = find_obj(&dir)?;
        let toml_path = dir.join("scene.toml");
        let cfg: SceneToml = if toml_path.exists() {
            let text = std::fs::read_to_string(&toml_path).map_err(io_err(&toml_path))?;
            toml::from_str(&text).map_err(|e| SceneError::Toml {
                path: toml_path.clone(),
                message: e.to_string().trim_end().replace('\n', " "),
            })?
        } else {
            SceneToml::default()
        };
        let id = dir
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into());
        let (units, scale) = resolve_units(&cfg, &toml_path)?;

        let obj_text = std::fs::read_to_string(&obj_path).map_err(io_err(&obj_path))?;
        let scan = prescan_obj(&obj_path, &obj_text)?;
        let mut files = vec![obj_path.clone()];
        let mut mtl_defs: Vec<MtlDef> = Vec::new();
        for mtl in &scan.mtllibs {
            let defs = parse_mtl(mtl)?;
            mtl_defs.extend(defs);
            files.push(mtl.clone());
        }
        if toml_path.exists() {
            files.push(toml_path.clone());
        }
        for (name, line) in &scan.usemtl {
            if !mtl_defs.iter().any(|m| &m.name == name) {
                return Err(SceneError::UnknownMaterial {
                    path: obj_path.clone(),
                    line: *line,
                    name: name.clone(),
                });
            }
        }

        let (models, _mats) = tobj::load_obj(
            &obj_path,
            &tobj::LoadOptions {
                triangulate: true,
                single_index: false,
                ignore_points: true,
                ignore_lines: true,
            },
        )
        .map_err(|e| SceneError::Invalid {
            path: obj_path.clone(),
            message: format!("OBJ parse error: {e}"),
        })?;
        // tobj numbers materials in the order of the MTL files it read; we map by name.
        let tobj_mats = _mats.unwrap_or_default();

        let mut warnings = Vec::new();
        let mut materials: Vec<Material> = Vec::new();
        let mut mat_index: HashMap<String, u32> = HashMap::new();
        for d in &mtl_defs {
            if mat_index.contains_key(&d.name) {
                continue;
            }
            mat_index.insert(d.name.clone(), materials.len() as u32);
            materials.push(Material {
                name: d.name.clone(),
                kd: d.kd,
                ke: d.ke,
                two_sided: cfg.material.get(&d.name).is_some_and(|o| o.two_sided),
            });
        }
        for name in cfg.material.keys() {
            if !mat_index.contains_key(name) {
                return Err(SceneError::Invalid {
                    path: toml_path.clone(),
                    message: format!("[material.{name}]: no such material in the MTL files"),
                });
            }
        }

        let mut surfaces: Vec<Surface> = Vec::new();
        let mut surf_index: HashMap<String, u32> = HashMap::new();
        let mut triangles = Vec::new();
        let mut dropped = 0usize;
        for model in &models {
            let mesh = &model.mesh;
            let mat = match mesh.material_id.and_then(|i| tobj_mats.get(i)) {
                Some(m) => *mat_index.get(&m.name).expect("material scanned"),
                None => {
                    let idx = *mat_index.entry("__default".into()).or_insert_with(|| {
                        warnings.push(format!(
                            "object '{}' has no material: using grey Kd 0.5",
                            model.name
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
            let sname = if model.name.is_empty() {
                "unnamed_object".to_string()
            } else {
                model.name.clone()
            };
            let surf = *surf_index.entry(sname.clone()).or_insert_with(|| {
                surfaces.push(Surface {
                    name: sname.clone(),
                    two_sided: cfg.surface.get(&sname).is_some_and(|o| o.two_sided),
                });
                (surfaces.len() - 1) as u32
            });
            let pos = &mesh.positions;
            let vert = |k: u32| -> DVec3 {
                let k = k as usize * 3;
                DVec3::new(pos[k] as f64, pos[k + 1] as f64, pos[k + 2] as f64) * scale
            };
            for (t, idx) in mesh.indices.chunks_exact(3).enumerate() {
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
                            model.name
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
        if dropped > 5 {
            warnings.push(format!("{} degenerate triangles skipped in all", dropped));
        }
        if triangles.is_empty() {
            return Err(SceneError::Empty(obj_path));
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
                if !(c.fov_deg > 0.0 && c.fov_deg < 180.0) {
                    return Err(SceneError::Invalid {
                        path: toml_path.clone(),
                        message: format!("camera '{}': fov_deg must be in (0, 180)", c.id),
                    });
                }
                let m = |v: [f64; 3]| [v[0] * scale, v[1] * scale, v[2] * scale];
                Ok(CameraDef {
                    id: c.id.clone(),
                    position: m(c.position),
                    target: m(c.target),
                    up: c.up,
                    fov_deg: c.fov_deg,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;

        add_luminaires(&cfg, &dir, &toml_path, scale, &mut lights, &mut files)?;
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
        let max_edge = match (cfg.mesh.max_edge, cfg.mesh.target_patches) {
            (Some(e), _) if e > 0.0 && e.is_finite() => e * scale,
            (Some(e), _) => {
                return Err(SceneError::Invalid {
                    path: toml_path,
                    message: format!("[mesh] max_edge = {e}: must be a positive length"),
                })
            }
            (None, t) => {
                let target = t.unwrap_or(DEFAULT_TARGET_PATCHES).max(1) as f64;
                // Longest-edge bisection leaves triangles of about max_edge² / 5.
                (5.0 * total_area / target).sqrt()
            }
        };

        Ok(Scene {
            name: cfg.name.clone().unwrap_or_else(|| id.clone()),
            id,
            dir,
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

fn resolve_units(cfg: &SceneToml, toml_path: &Path) -> Result<(String, f64), SceneError> {
    if let Some(s) = cfg.scale {
        if !(s > 0.0 && s.is_finite()) {
            return Err(SceneError::Invalid {
                path: toml_path.into(),
                message: format!("scale = {s}: must be a positive factor to metres"),
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

fn find_obj(dir: &Path) -> Result<PathBuf, SceneError> {
    let mut objs: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(io_err(dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj")))
        .collect();
    objs.sort();
    match objs.len() {
        0 => Err(SceneError::NoObj(dir.into())),
        1 => Ok(objs.remove(0)),
        _ => Err(SceneError::ManyObj {
            dir: dir.into(),
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

/// What a line-level pass over the OBJ learns before tobj parses it.
struct ObjScan {
    mtllibs: Vec<PathBuf>,
    usemtl: Vec<(String, usize)>,
}

/// Checks the OBJ line by line so errors name a line: non-finite or malformed vertices,
/// face indices out of range, missing material libraries.
fn prescan_obj(path: &Path, text: &str) -> Result<ObjScan, SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut nverts = 0i64;
    let mut mtllibs = Vec::new();
    let mut usemtl = Vec::new();
    let syntax = |line: usize, message: String| SceneError::Syntax {
        path: path.into(),
        line,
        message,
    };
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.trim();
        let mut words = l.split_whitespace();
        match words.next() {
            Some("v") => {
                let vals: Vec<&str> = words.collect();
                if vals.len() < 3 {
                    return Err(syntax(line, format!("vertex needs 3 coordinates: '{l}'")));
                }
                for w in &vals[..3] {
                    let v: f64 = w
                        .parse()
                        .map_err(|_| syntax(line, format!("bad vertex coordinate '{w}'")))?;
                    if !v.is_finite() {
                        return Err(syntax(line, format!("vertex coordinate is {w}")));
                    }
                }
                nverts += 1;
            }
            Some("f") => {
                let idx: Vec<&str> = words.collect();
                if idx.len() < 3 {
                    return Err(syntax(line, "face needs at least 3 vertices".into()));
                }
                for w in idx {
                    let first = w.split('/').next().unwrap_or("");
                    let k: i64 = first
                        .parse()
                        .map_err(|_| syntax(line, format!("bad face index '{w}'")))?;
                    let ok = (k > 0 && k <= nverts) || (k < 0 && -k <= nverts);
                    if !ok {
                        return Err(syntax(
                            line,
                            format!("face index {k} out of range (1..={nverts} defined so far)"),
                        ));
                    }
                }
            }
            Some("mtllib") => {
                let name = l["mtllib".len()..].trim();
                let p = dir.join(name);
                if !p.is_file() {
                    return Err(SceneError::MissingMtl {
                        path: path.into(),
                        line,
                        mtl: name.into(),
                    });
                }
                mtllibs.push(p);
            }
            Some("usemtl") => {
                usemtl.push((l["usemtl".len()..].trim().to_string(), line));
            }
            _ => {}
        }
    }
    Ok(ObjScan { mtllibs, usemtl })
}

struct MtlDef {
    name: String,
    kd: Rgb,
    ke: Rgb,
}

/// Reads the Kd/Ke of each material, validating ranges with line numbers.
fn parse_mtl(path: &Path) -> Result<Vec<MtlDef>, SceneError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    let mut out: Vec<MtlDef> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.trim();
        let mut words = l.split_whitespace();
        let key = words.next();
        let bad = |material: &str, message: String| SceneError::BadMaterial {
            path: path.into(),
            line,
            material: material.into(),
            message,
        };
        match key {
            Some("newmtl") => out.push(MtlDef {
                name: l["newmtl".len()..].trim().to_string(),
                kd: [0.0; 3],
                ke: [0.0; 3],
            }),
            Some(k @ ("Kd" | "Ke")) => {
                let Some(cur) = out.last_mut() else {
                    return Err(SceneError::Syntax {
                        path: path.into(),
                        line,
                        message: format!("{k} before any newmtl"),
                    });
                };
                let vals: Vec<&str> = words.collect();
                if vals.first() == Some(&"spectral") || vals.first() == Some(&"xyz") {
                    return Err(bad(
                        &cur.name,
                        format!("{k}: only RGB values are supported"),
                    ));
                }
                let mut v = [0f32; 3];
                let parsed: Result<Vec<f32>, _> = vals.iter().map(|w| w.parse::<f32>()).collect();
                let parsed =
                    parsed.map_err(|_| bad(&cur.name, format!("{k}: not numbers: '{l}'")))?;
                match parsed.len() {
                    1 => v = [parsed[0]; 3],
                    3 => v.copy_from_slice(&parsed),
                    _ => return Err(bad(&cur.name, format!("{k} needs 1 or 3 numbers"))),
                }
                if v.iter().any(|x| !x.is_finite()) {
                    return Err(bad(&cur.name, format!("{k} is not finite")));
                }
                if k == "Kd" {
                    if v.iter().any(|&x| !(0.0..1.0).contains(&x)) {
                        return Err(bad(
                            &cur.name,
                            format!(
                                "Kd {} {} {}: diffuse reflectance must be in [0, 1) per channel \
                                 (a surface cannot reflect all the light it receives)",
                                v[0], v[1], v[2]
                            ),
                        ));
                    }
                    cur.kd = v;
                } else {
                    if v.iter().any(|&x| x < 0.0) {
                        return Err(bad(&cur.name, "Ke must not be negative".into()));
                    }
                    cur.ke = v;
                }
            }
            _ => {}
        }
    }
    Ok(out)
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
    dir: &Path,
    toml_path: &Path,
    scale: f64,
    lights: &mut Vec<LightGroup>,
    files: &mut Vec<PathBuf>,
) -> Result<(), SceneError> {
    use crate::photometry::{cct_to_rgb, Distribution, IesData, Luminaire};
    let bad = |id: &str, m: String| SceneError::Invalid {
        path: toml_path.into(),
        message: format!("luminaire '{id}': {m}"),
    };
    let mut seen = std::collections::HashSet::new();
    for l in &cfg.luminaires {
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
                let path = dir.join(name);
                let text = std::fs::read(&path)
                    .map_err(|e| bad(&l.id, format!("cannot read {}: {e}", path.display())))?;
                let data = IesData::parse(&String::from_utf8_lossy(&text))
                    .map_err(|e| bad(&l.id, format!("{}: {e}", path.display())))?;
                if !files.contains(&path) {
                    files.push(path);
                }
                Distribution::Ies(Box::new(data))
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
            (None, Some(k)) if (1000.0..=40000.0).contains(&k) => cct_to_rgb(k),
            (None, Some(k)) => return Err(bad(&l.id, format!("cct = {k}: must be 1000..40000 K"))),
            (None, None) => [1.0; 3],
        };
        let v = |a: [f64; 3]| DVec3::from_array(a);
        let mut lum = Luminaire::new(
            &l.id,
            v(l.position) * scale,
            v(l.aim),
            l.c0.map(v),
            distribution,
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
