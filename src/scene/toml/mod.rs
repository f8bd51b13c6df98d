//! `scene.toml`: the serde structs of the file as written by the user, reading it from the
//! scene folder, and the range checks of every number in it against [`crate::input_limits`].
//!
//! Lengths in the file are in scene units (`units`/`scale`, converted to metres on load);
//! range checks on lengths apply after scaling, in metres. Angles are in degrees, flux in
//! lumens (lm), power in watts (W), efficacy in lm/W, colour temperature in kelvin (K).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::files::{self, SceneDir};
use super::SceneError;
use crate::color::Rgb;
use crate::input_limits::*;

mod checks;

use checks::validate_toml;

/// `scene.toml`, as written by the user. Every key is optional.
#[derive(Debug, Default, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneToml {
    /// Display name.
    pub(crate) name: Option<String>,
    /// Length unit of the OBJ coordinates: "m" (default), "cm", "mm", "in" or "ft".
    pub(crate) units: Option<String>,
    /// Explicit factor from OBJ units to metres; overrides `units`.
    pub(crate) scale: Option<f64>,
    /// "auto" (default: factored up to 6,000 patches, hierarchical beyond), "factored",
    /// "columns" (light groups only) or "hierarchical".
    pub(crate) transfer: Option<TransferChoice>,
    /// Hierarchical mode: refine the links again after a first solve, so that each light
    /// group alone is right in rooms it lights only through openings (default false).
    #[serde(default)]
    pub(crate) per_group_accuracy: bool,
    /// Refuse what a lenient load fixes with a warning: a `Kd` of 1 or more, a missing MTL
    /// file or texture, an unknown material (default false).
    #[serde(default)]
    pub(crate) strict: bool,
    #[serde(default)]
    pub(crate) mesh: MeshToml,
    #[serde(default)]
    pub(crate) lights: Vec<LightToml>,
    #[serde(default)]
    pub(crate) cameras: Vec<CameraToml>,
    /// Point luminaires (IES, spot or isotropic), each in a light group.
    #[serde(default)]
    pub(crate) luminaires: Vec<LuminaireToml>,
    /// Calculation grids: work planes or point lists.
    #[serde(default)]
    pub(crate) grids: Vec<GridToml>,
    /// Per-surface options, keyed by OBJ object/group name.
    #[serde(default)]
    pub(crate) surface: BTreeMap<String, FaceOptions>,
    /// Per-material options, keyed by MTL material name.
    #[serde(default)]
    pub(crate) material: BTreeMap<String, FaceOptions>,
    /// Where the scene stands on Earth; a scene without it has no daylight.
    pub(crate) site: Option<SiteToml>,
    /// Maintenance factor MF (CIE 97, EN 12464-1) of every light group that does not give
    /// its own, in (0, 1]: maintained illuminance = MF × initial. Default 1.
    pub(crate) maintenance_factor: Option<f64>,
}

/// `[site]`: latitude (°N), longitude (°E), timezone (hours east of UTC, standard time),
/// north (the scene's horizontal direction of north; default -z, so east is +x), and the
/// outside ground's reflectance (default 0.2).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SiteToml {
    pub(crate) latitude: f64,
    pub(crate) longitude: f64,
    pub(crate) timezone: f64,
    #[serde(default = "default_north")]
    pub(crate) north: [f64; 3],
    #[serde(default = "default_ground")]
    pub(crate) ground_reflectance: f64,
}

fn default_north() -> [f64; 3] {
    [0.0, 0.0, -1.0]
}

fn default_ground() -> f64 {
    0.2
}

impl SiteToml {
    /// The checked site.
    pub(crate) fn site(&self) -> Result<crate::daylight::Site, String> {
        crate::daylight::Site::new(
            self.latitude,
            self.longitude,
            self.timezone,
            glam::DVec3::from_array(self.north),
            self.ground_reflectance,
        )
        .map_err(|m| format!("[site]: {m}"))
    }
}

#[derive(Debug, Default, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct MeshToml {
    /// Longest patch edge, in scene units.
    pub(crate) max_edge: Option<f64>,
    /// Aim for about this many patches when `max_edge` is not given (default 4000).
    pub(crate) target_patches: Option<usize>,
    /// Cluster the model's small triangles into patches of about `max_edge` (default
    /// true); false gives every triangle its own patch.
    pub(crate) cluster: Option<bool>,
}

#[derive(Debug, Default, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FaceOptions {
    /// Both sides emit, reflect and receive (thin panels).
    #[serde(default)]
    pub(crate) two_sided: bool,
    /// Glazing: the share of daylight that passes straight through, 0..1 (see
    /// [`crate::geometry::glazing`]).
    pub(crate) transmittance: Option<f64>,
    /// Keeps a surface or material that the model file makes see-through (glTF
    /// transmission or alpha blending) an opaque, meshed one.
    #[serde(default)]
    pub(crate) opaque: bool,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LightToml {
    pub(crate) id: String,
    pub(crate) name: Option<String>,
    /// Emissive materials that belong to this group.
    #[serde(default)]
    pub(crate) materials: Vec<String>,
    /// Emissive surfaces (OBJ object/group names) that belong to this group.
    #[serde(default)]
    pub(crate) surfaces: Vec<String>,
    /// Total luminous flux of the group in lumens at intensity 1; rescales its Ke.
    pub(crate) lumens: Option<f64>,
    /// Default intensity (dimming factor, 1 = as modelled).
    pub(crate) intensity: Option<f32>,
    /// Default colour filter (linear RGB multipliers).
    pub(crate) color: Option<Rgb>,
    /// The group's maintenance factor, in (0, 1]; default the scene's.
    pub(crate) maintenance_factor: Option<f64>,
    /// Colour rendering index Ra of the group's lamps, 0..100.
    pub(crate) ra: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LuminaireToml {
    pub(crate) id: String,
    /// Light group to join (created when no `[[lights]]` entry has this id); default `id`.
    pub(crate) group: Option<String>,
    /// Position, scene units.
    pub(crate) position: [f64; 3],
    /// Photometric axis (nadir for type C); default straight down.
    #[serde(default = "default_aim")]
    pub(crate) aim: [f64; 3],
    /// Direction of the C = 0° plane (type C) / the luminaire's length axis.
    pub(crate) c0: Option<[f64; 3]>,
    /// Total flux, lm; default: the IES file's (absolute) candela integral.
    pub(crate) lumens: Option<f64>,
    /// "isotropic", "spot" or "photometry" (also spelled "ies"); default "photometry" when
    /// a file is given, else "isotropic".
    pub(crate) distribution: Option<String>,
    /// Photometric file relative to the scene folder (with its place in `scene.toml`):
    /// EULUMDAT when it ends in `.ldt`, else IES LM-63. `ies` is the same key.
    pub(crate) photometry: Option<::toml::Spanned<String>>,
    pub(crate) ies: Option<::toml::Spanned<String>>,
    /// The EULUMDAT lamp set whose flux scales the table and whose wattage is the
    /// default `watts` (1-based; default 1).
    pub(crate) lamp_set: Option<usize>,
    /// Spot beam angle (50 % of peak) and field angle (cut-off), full cone, degrees.
    pub(crate) beam_deg: Option<f64>,
    pub(crate) field_deg: Option<f64>,
    /// Linear RGB colour, or a colour temperature in kelvin (blackbody).
    pub(crate) color: Option<Rgb>,
    pub(crate) cct: Option<f64>,
    /// Electrical power (W), or luminous efficacy (lm/W) to derive it; default the
    /// photometric file's input watts (IES) or lamp-set wattage (EULUMDAT), if any.
    pub(crate) watts: Option<f64>,
    pub(crate) efficacy: Option<f64>,
    /// Colour rendering index Ra of the lamps, 0..100 (its group takes the lowest).
    pub(crate) ra: Option<f64>,
}

fn default_aim() -> [f64; 3] {
    [0.0, -1.0, 0.0]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct GridToml {
    pub(crate) id: String,
    pub(crate) name: Option<String>,
    /// Work plane: horizontal rectangle from `min` = [x, z] to `max` = [x, z] (scene
    /// units) at `height` above the floor (the scene's lowest point), points at the centres
    /// of cells about `spacing` wide.
    pub(crate) min: Option<[f64; 2]>,
    pub(crate) max: Option<[f64; 2]>,
    pub(crate) height: Option<f64>,
    pub(crate) spacing: Option<f64>,
    /// Or explicit points (scene units).
    pub(crate) points: Option<Vec<[f64; 3]>>,
    /// Or a polygon [[x, z], ...] (scene units) at `height`, points at the centres of the
    /// cells whose centre lies inside it.
    pub(crate) area: Option<Vec<[f64; 2]>>,
    /// An EN 12464-1 area: `task`, `surrounding` or `background`. Its points are placed by
    /// the standard's spacing unless `spacing` is given.
    pub(crate) kind: Option<crate::scene::grids::GridKind>,
    /// Task areas: width of the immediate surrounding band (scene units; default 0.5 m, 0
    /// for none), a grid of its own named `<id>-surrounding`.
    pub(crate) surrounding: Option<f64>,
    /// Background areas: width of the band along the area's edges (the walls) left out
    /// (scene units; default 0.5 m).
    pub(crate) wall_band: Option<f64>,
    /// Keep points inside objects or under surfaces at close range in the statistics.
    #[serde(default)]
    pub(crate) keep_obstructed: bool,
    /// Receiver normal; default up.
    #[serde(default = "default_up")]
    pub(crate) normal: [f64; 3],
    /// What the area must achieve (EN 12464-1): maintained illuminance, uniformity, glare
    /// limit, colour rendering.
    pub(crate) requirements: Option<crate::scene::Requirements>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraToml {
    pub(crate) id: String,
    pub(crate) position: [f64; 3],
    pub(crate) target: [f64; 3],
    #[serde(default = "default_up")]
    pub(crate) up: [f64; 3],
    /// Vertical field of view in degrees.
    pub(crate) fov_deg: f64,
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
    Hierarchical,
}

impl TransferChoice {
    /// The lowercase name used in scene.toml and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            TransferChoice::Auto => "auto",
            TransferChoice::Factored => "factored",
            TransferChoice::Columns => "columns",
            TransferChoice::Hierarchical => "hierarchical",
        }
    }
}

/// `scene.toml` as read from a scene folder.
pub(crate) struct TomlFile {
    /// The name errors use (`<scene id>/scene.toml`), also when there is no such file.
    pub(crate) path: PathBuf,
    /// Canonical path of the file, when the folder has one (for the cache key).
    pub(crate) canon: Option<PathBuf>,
    /// Its text (empty without a file), for the lines of `ies` references.
    pub(crate) text: String,
    /// The parsed and range-checked content (defaults without a file).
    pub(crate) cfg: SceneToml,
}

/// Reads and checks the folder's `scene.toml`; a folder without one gets the defaults.
pub(crate) fn read_scene_toml(sd: &SceneDir) -> Result<TomlFile, SceneError> {
    let file = sd.root.join("scene.toml");
    let path = sd.display(&file);
    let canon = match std::fs::symlink_metadata(&file) {
        Ok(_) => Some(sd.resolve_own(&file)?),
        Err(_) => None,
    };
    let (cfg, text) = match &canon {
        Some(p) => {
            let text = files::to_text(&path, sd.read(p, MAX_TEXT_BYTES)?)?;
            (parse_toml(&path, &text)?, text)
        }
        None => (SceneToml::default(), String::new()),
    };
    Ok(TomlFile {
        path,
        canon,
        text,
        cfg,
    })
}

/// Parses the text of a `scene.toml` and checks every number in it against
/// [`crate::input_limits`] (what needs the geometry, such as material names, is checked by
/// [`super::Scene::load`]). `path` is the display name errors use.
pub fn parse_scene_toml(path: &str, text: &str) -> Result<SceneToml, SceneError> {
    parse_toml(Path::new(path), text)
}

fn parse_toml(path: &Path, text: &str) -> Result<SceneToml, SceneError> {
    let cfg: SceneToml = ::toml::from_str(text).map_err(|e| SceneError::Toml {
        path: path.to_path_buf(),
        message: e.to_string().trim_end().replace('\n', " "),
    })?;
    validate_toml(&cfg, path)?;
    Ok(cfg)
}

/// The unit label ("m", "mm", …) and its factor to metres.
pub(crate) fn resolve_units(
    cfg: &SceneToml,
    toml_path: &Path,
) -> Result<(String, f64), SceneError> {
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
