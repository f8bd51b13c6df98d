//! Scenes: a folder under `scenes/` holding one OBJ file, its MTL, and an optional
//! `scene.toml`. Loading validates everything a later stage relies on and reports broken
//! input as a [`SceneError`] that names the file and line (or the object).
//!
//! Units: positions are converted to metres on load (`units`/`scale` in `scene.toml`).
//! A model whose size makes no sense in metres, when `scene.toml` gives neither, loads
//! with a warning that suggests the setting ([`extent`]).
//! `Kd` is diffuse reflectance in [0, 1) per channel; `Ke` is luminous exitance in lm/m²
//! per channel (see [`crate::color`]).
//!
//! Safety of input: every referenced file must resolve inside the scene folder and be a
//! regular file within a size limit ([`files`]); every number is range-checked in the type
//! it is computed in, against the bounds of [`crate::input_limits`]. Error messages name files
//! as `<scene id>/<path in the folder>`, never by their absolute path.
//!
//! Loading runs in named steps, each in its own module: `scene.toml` ([`SceneToml`]), the
//! OBJ ([`parse_obj_str`]) and its MTL files ([`parse_mtl_str`]) into materials and
//! triangles, then light groups and luminaires, calculation grids ([`Grid`]) and camera
//! presets ([`CameraDef`]).

pub mod archive;
mod cameras;
mod extent;
pub(crate) mod files;
mod gltf;
pub mod grids;
mod lights;
mod luminaires;
mod materials;
mod mtl;
mod obj;
mod polygon;
mod texture;
mod toml;
mod triangles;

use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::Serialize;

pub use self::toml::{parse_scene_toml, SceneToml, TransferChoice};
pub use cameras::CameraDef;
pub(crate) use files::read_regular_file;
pub use grids::{Grid, Requirements};
pub use lights::LightGroup;
pub use materials::{Gloss, Material};
pub use mtl::{parse_mtl_str, MtlLibrary, MtlMaterial};
pub use obj::{parse_obj_str, ObjPart, ObjScan};
pub(crate) use triangles::is_two_sided;
pub use triangles::{Pane, Surface, Triangle};

use crate::input_limits::MAX_OBJ_BYTES;
use materials::MaterialTable;
use triangles::Geometry;

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
    #[error("{0}: not a scene folder (no .obj, .gltf or .glb file in it)")]
    NoObj(PathBuf),
    #[error(
        "{dir}: more than one model file ({files}); a scene folder holds exactly one \
         .obj, .gltf or .glb"
    )]
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

impl From<crate::photometry::PhotometryError> for SceneError {
    fn from(e: crate::photometry::PhotometryError) -> Self {
        use crate::photometry::PhotometryError as P;
        match e {
            P::Syntax {
                path,
                line,
                message,
            } => SceneError::Syntax {
                path,
                line,
                message,
            },
            P::Invalid { path, message } => SceneError::Invalid { path, message },
        }
    }
}

/// How finely to mesh, resolved to metres.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct MeshSettings {
    /// Longest patch edge, metres.
    pub max_edge: f64,
    /// Small triangles of the model are clustered into patches of about `max_edge`
    /// (`[mesh] cluster`, default true; see [`crate::geometry::mesh`]).
    pub cluster: bool,
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
    /// Glazing: not meshed, it scales the daylight that crosses it.
    pub glazing: Vec<Pane>,
    pub lights: Vec<LightGroup>,
    pub cameras: Vec<CameraDef>,
    pub grids: Vec<Grid>,
    pub mesh: MeshSettings,
    pub transfer: TransferChoice,
    /// Hierarchical mode: every light group right on its own, also where its light reaches
    /// a room only through an opening (scene.toml `per_group_accuracy`; see
    /// [`crate::transport::hierarchy::refine`]). About doubles the refinement's time.
    pub per_group_accuracy: bool,
    /// Where the scene stands, for daylight (`[site]`); None: no daylight.
    pub site: Option<crate::daylight::Site>,
    /// Non-fatal problems (skipped degenerate triangles, defaulted materials).
    pub warnings: Vec<String>,
    /// The maintenance factor of groups that give none (`maintenance_factor`, default 1).
    pub maintenance_factor: f64,
}

/// Default patch budget when `scene.toml` gives neither `max_edge` nor `target_patches`.
const DEFAULT_TARGET_PATCHES: usize = 4000;

impl Scene {
    /// Loads the scene folder `dir`.
    pub fn load(dir: &Path) -> Result<Scene, SceneError> {
        let sd = files::SceneDir::open(dir)?;
        let id = sd.label.clone();
        let model = sd.find_model()?;
        let toml = self::toml::read_scene_toml(&sd)?;
        let cfg = &toml.cfg;
        let (units, scale) = self::toml::resolve_units(cfg, &toml.path)?;
        let mut warnings = Vec::new();
        let mut files = Vec::new();
        let ModelRead {
            name: model_name,
            table,
            parts,
            luminaires: model_luminaires,
        } = read_model(&sd, model, cfg, scale, &mut files, &mut warnings)?;
        if let Some(p) = &toml.canon {
            files.push(p.clone());
        }
        let (geometry, glazing, table) =
            build_geometry(&model_name, table, parts, &toml, scale, &mut warnings)?;
        let Geometry {
            surfaces,
            surf_index,
            mut triangles,
        } = geometry;
        let MaterialTable {
            materials,
            index: mat_index,
            ..
        } = table;

        let names = lights::Names {
            materials: &mat_index,
            surfaces: &surf_index,
            model_groups: &model_luminaires
                .iter()
                .map(|(g, _)| g.clone())
                .collect::<Vec<_>>(),
        };
        let mut lights = lights::assign_lights(
            cfg,
            &toml.path,
            &materials,
            &surfaces,
            &names,
            &mut triangles,
        )?;
        let cameras = cameras::build_cameras(cfg, scale);
        let toml_ref = luminaires::TomlRef::new(&sd, &toml.path, &toml.text);
        luminaires::add_luminaires(cfg, &toml_ref, scale, &mut lights, &mut files)?;
        gltf::add_gltf_luminaires(&mut lights, model_luminaires);
        lights::check_group_count(&lights, &toml.path)?;
        lights::apply_maintenance_factors(cfg, &mut lights);
        let grids = grids::build_grids(cfg, &toml.path, scale, &triangles)?;
        let mesh = mesh_settings(cfg, scale, &triangles, &materials, &surfaces);

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
            glazing,
            lights,
            cameras,
            grids,
            mesh,
            transfer: cfg.transfer.unwrap_or_default(),
            per_group_accuracy: cfg.per_group_accuracy,
            site: cfg.site.as_ref().and_then(|s| s.site().ok()),
            warnings,
            maintenance_factor: cfg.maintenance_factor.unwrap_or(1.0),
        })
    }

    /// Scene bounds in metres (min, max): the axis-aligned box of its triangles.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        bounds_of(&self.triangles)
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

/// The axis-aligned box of `triangles` (min, max), in their units.
fn bounds_of(triangles: &[Triangle]) -> (DVec3, DVec3) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for t in triangles {
        for p in t.p {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (lo, hi)
}

/// What the scene's model file gives: its name in messages, the materials, one part per
/// object (file units) and, from glTF, luminaires (metres) with their light group's id.
struct ModelRead {
    name: PathBuf,
    table: MaterialTable,
    parts: Vec<ObjPart>,
    luminaires: Vec<(String, crate::photometry::Luminaire)>,
}

/// Reads the model file (OBJ with its MTL files, or glTF), adding the files read to
/// `files`.
fn read_model(
    sd: &files::SceneDir,
    model: files::ModelFile,
    cfg: &SceneToml,
    scale: f64,
    files: &mut Vec<PathBuf>,
    warnings: &mut Vec<String>,
) -> Result<ModelRead, SceneError> {
    match model {
        files::ModelFile::Obj(obj_path) => {
            let obj_name = sd.display(&obj_path);
            let scan = {
                let text = files::to_text(&obj_name, sd.read(&obj_path, MAX_OBJ_BYTES)?)?;
                obj::scan_obj(&obj_name, &text, scale, cfg.strict)?
            };
            warnings.extend(scan.warnings.iter().cloned());
            files.push(obj_path);
            let mut table = MaterialTable::read(sd, &obj_name, &scan, cfg, files, warnings)?;
            table.add_missing(&scan.usemtl, &obj_name, cfg, warnings)?;
            let parts = obj::read_obj(&obj_name, &scan, &table.names())?;
            Ok(ModelRead {
                name: obj_name,
                table,
                parts,
                luminaires: Vec::new(),
            })
        }
        files::ModelFile::Gltf(path) => {
            let name = sd.display(&path);
            files.push(path.clone());
            let m = gltf::read_gltf(sd, &path, cfg, scale, files, warnings)?;
            Ok(ModelRead {
                name,
                table: m.table,
                parts: m.parts,
                luminaires: m.luminaires,
            })
        }
    }
}

/// The model's triangles by surface (file units to metres), its glazing split off, and
/// the materials table as the triangles left it; the model's materials checked against
/// `scene.toml`, and a units hint among the warnings when its size makes no sense.
fn build_geometry(
    model_name: &Path,
    mut table: MaterialTable,
    parts: Vec<ObjPart>,
    toml: &self::toml::TomlFile,
    scale: f64,
    warnings: &mut Vec<String>,
) -> Result<(Geometry, Vec<Pane>, MaterialTable), SceneError> {
    let cfg = &toml.cfg;
    table.check_options(cfg, &toml.path)?;
    let mut geometry = Geometry::build(
        &parts, scale, cfg, &mut table, model_name, &toml.path, warnings,
    )?;
    drop(parts);
    let glazing = geometry.split_glazing(cfg, &table, &toml.path, model_name, warnings)?;
    if cfg.units.is_none() && cfg.scale.is_none() {
        let (lo, hi) = bounds_of(&geometry.triangles);
        warnings.extend(extent::units_hint(model_name, (hi - lo).max_element()));
    }
    Ok((geometry, glazing, table))
}

/// Reads the regular file at `path`, refusing anything over `limit` bytes; the message
/// says why (for files clients name, such as weather files).
pub fn read_file_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, String> {
    files::read_bounded(path, limit).map_err(|e| match e {
        files::ReadError::Io(e) => format!("cannot be read ({})", e.kind()),
        files::ReadError::NotRegular(kind) => format!("not a regular file ({kind})"),
        files::ReadError::TooLarge(_) => format!("larger than {} bytes", limit),
    })
}

/// How finely to mesh: `max_edge` from `[mesh]` (scene units, scaled to metres), else
/// from the patch budget over the total active area (m², two-sided triangles twice).
/// Ranges were checked by the `scene.toml` parser.
fn mesh_settings(
    cfg: &SceneToml,
    scale: f64,
    triangles: &[Triangle],
    materials: &[Material],
    surfaces: &[Surface],
) -> MeshSettings {
    let max_edge = match (cfg.mesh.max_edge, cfg.mesh.target_patches) {
        (Some(e), _) => e * scale,
        (None, t) => {
            let total_area: f64 = triangles
                .iter()
                .map(|t| {
                    let a = t.area();
                    if is_two_sided(t, materials, surfaces) {
                        2.0 * a
                    } else {
                        a
                    }
                })
                .sum();
            let target = t.unwrap_or(DEFAULT_TARGET_PATCHES).max(1) as f64;
            // Longest-edge bisection leaves triangles of about max_edge² / 5.
            (5.0 * total_area / target).sqrt()
        }
    };
    MeshSettings {
        max_edge,
        cluster: cfg.mesh.cluster.unwrap_or(true),
    }
}
