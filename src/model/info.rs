//! What a baked scene is made of, for clients: units, bounds, luminaires, calculation
//! grids, surfaces with their patch ranges, and patches. The server lists them in its
//! scene details and its patch listing.

use serde::Serialize;

use super::Model;
use crate::photometry::{Distribution, PhotometricFormat};

/// The units of the answers, and the scene's own length unit.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct Units {
    /// Lengths in answers: metres.
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::metre))]
    pub length: &'static str,
    /// The length unit of the scene's files (`units` in `scene.toml`).
    pub source_units: String,
    /// Metres per `source_units`.
    pub scale_to_m: f64,
    /// Radiosity and exitance: lm/m².
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::lm_per_m2))]
    pub radiosity: &'static str,
    /// Illuminance: lux.
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::lx))]
    pub illuminance: &'static str,
    /// Luminous flux: lumens.
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::lm))]
    pub flux: &'static str,
}

/// Where a scene with daylight stands, and the weather files in its folder.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct SiteInfo {
    /// Degrees north.
    pub latitude: f64,
    /// Degrees east.
    pub longitude: f64,
    /// Hours east of UTC (standard time).
    pub timezone: f64,
    /// The scene's unit direction of north.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub north: [f64; 3],
    pub ground_reflectance: f64,
    /// `.epw` files in the scene's folder, for `POST /annual`.
    pub weather_files: Vec<String>,
}

/// The scene's axis-aligned bounds, in metres (the model's coordinates after `units` or
/// `scale` of `scene.toml`): the box of its triangles.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct Bounds {
    /// The lowest corner [x, y, z], m.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub min: [f64; 3],
    /// The highest corner [x, y, z], m.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub max: [f64; 3],
    /// The size along x, y and z (`max` − `min`), m.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub size: [f64; 3],
}

impl Bounds {
    /// The bounds from their corners, in metres.
    pub fn new(min: glam::DVec3, max: glam::DVec3) -> Bounds {
        Bounds {
            min: min.to_array(),
            max: max.to_array(),
            size: (max - min).to_array(),
        }
    }
}

/// Most photometric files a scene's details list.
pub const MAX_LISTED_PHOTOMETRIC_FILES: usize = 256;
/// Most entries of a scene folder looked at for them.
const MAX_SCANNED_ENTRIES: usize = 10_000;

/// The kind of a luminaire's intensity distribution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum DistributionKind {
    Isotropic,
    Spot,
    /// An IES LM-63 file.
    Ies,
    /// An EULUMDAT file.
    Ldt,
}

impl From<&Distribution> for DistributionKind {
    fn from(d: &Distribution) -> DistributionKind {
        match d {
            Distribution::Isotropic => DistributionKind::Isotropic,
            Distribution::Spot { .. } | Distribution::Cone { .. } => DistributionKind::Spot,
            Distribution::Table(t) => match t.format {
                PhotometricFormat::Ies => DistributionKind::Ies,
                PhotometricFormat::Eulumdat => DistributionKind::Ldt,
            },
        }
    }
}

/// A point luminaire.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct LuminaireInfo {
    pub id: String,
    /// Its light group's id.
    pub group: String,
    /// m.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub position: [f64; 3],
    /// Unit photometric axis.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub aim: [f64; 3],
    /// Direction of C = 0°, unit, perpendicular to `aim`.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub c0: [f64; 3],
    /// Its photometric file in the scene folder, as scene.toml names it; null for an
    /// isotropic or spot luminaire, or when scene.toml cannot be read.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub photometry: Option<String>,
    /// Luminous flux, lm.
    pub lumens: f64,
    /// Electrical power, W: `scene.toml`'s `watts` (or lumens over `efficacy`), else the
    /// photometric file's input watts or lamp-set wattage; null when none gives it.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub watts: Option<f64>,
    #[cfg_attr(feature = "server", schema(inline))]
    pub distribution: DistributionKind,
}

/// A calculation grid: its points and their common normal.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct GridInfo {
    pub id: String,
    pub name: String,
    /// Number of points.
    pub count: usize,
    #[cfg_attr(feature = "server", schema(schema_with = crate::schema::layout, required = true))]
    pub layout: Option<[usize; 2]>,
    /// Unit normal of the points.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub normal: [f64; 3],
    /// m, in grid order.
    #[cfg_attr(feature = "server", schema(value_type = Vec<crate::schema::Rgb>))]
    pub points: Vec<[f64; 3]>,
}

/// A surface's patches: `start..end` in patch order.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct PatchRange {
    pub start: u32,
    pub end: u32,
    pub count: usize,
}

/// A surface (an OBJ object or group).
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct SurfaceInfo {
    pub id: String,
    /// Index in the scene's surface order.
    pub index: usize,
    /// Area of its patches, m².
    pub area: f64,
    #[cfg_attr(feature = "server", schema(inline))]
    pub patches: PatchRange,
    /// Whether it has patches on both sides.
    pub two_sided: bool,
}

/// A patch.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct PatchInfo<'a> {
    /// Its surface's id.
    pub surface: &'a str,
    /// m².
    pub area: f64,
    /// m.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub centroid: [f64; 3],
    /// Unit normal of the front.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub normal: [f64; 3],
}

impl Model {
    /// The units of the answers and of the scene's files.
    /// The site, when the scene has daylight.
    pub fn site_info(&self) -> Option<SiteInfo> {
        let s = self.site().ok()?;
        let mut weather_files: Vec<String> = std::fs::read_dir(&self.baked.scene.dir)
            .map(|rd| {
                rd.flatten()
                    .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
                    .filter_map(|e| e.file_name().into_string().ok())
                    .filter(|n| n.to_ascii_lowercase().ends_with(".epw") && !n.starts_with('.'))
                    .take(100)
                    .collect()
            })
            .unwrap_or_default();
        weather_files.sort();
        Some(SiteInfo {
            latitude: s.latitude_deg,
            longitude: s.longitude_deg,
            timezone: s.timezone_h,
            north: s.north.to_array(),
            ground_reflectance: s.ground_reflectance,
            weather_files,
        })
    }

    pub fn units(&self) -> Units {
        let s = &self.baked.scene;
        Units {
            length: "m",
            source_units: s.units.clone(),
            scale_to_m: s.scale,
            radiosity: "lm/m2",
            illuminance: "lx",
            flux: "lm",
        }
    }

    /// The scene's bounds, m.
    pub fn bounds(&self) -> Bounds {
        let (lo, hi) = self.baked.scene.bounds();
        Bounds::new(lo, hi)
    }

    /// Every point luminaire, by group in scene order.
    pub fn luminaires(&self) -> Vec<LuminaireInfo> {
        let groups = &self.baked.scene.lights;
        let files = super::design_report::photometric_files(&self.baked.scene);
        groups
            .iter()
            .flat_map(|g| {
                let files = &files;
                g.luminaires.iter().map(move |l| LuminaireInfo {
                    id: l.id.clone(),
                    group: g.id.clone(),
                    position: l.position.to_array(),
                    aim: l.aim.to_array(),
                    c0: l.c0.to_array(),
                    photometry: files.get(&l.id).cloned(),
                    lumens: l.lumens,
                    watts: l.watts,
                    distribution: (&l.distribution).into(),
                })
            })
            .collect()
    }

    /// The photometric files (`.ies`, `.ldt`) at the top of the scene folder, sorted, at
    /// most [`MAX_LISTED_PHOTOMETRIC_FILES`]: what a luminaire placed per request may name
    /// as its `photometry`.
    pub fn photometric_file_names(&self) -> Vec<String> {
        let Ok(dir) = std::fs::read_dir(&self.baked.scene.dir) else {
            return vec![];
        };
        let mut names: Vec<String> = dir
            .filter_map(|e| e.ok())
            .take(MAX_SCANNED_ENTRIES)
            .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
            .filter_map(|e| e.file_name().into_string().ok())
            .filter(|n| {
                let lower = n.to_ascii_lowercase();
                lower.ends_with(".ies") || lower.ends_with(".ldt")
            })
            .collect();
        names.sort();
        names.truncate(MAX_LISTED_PHOTOMETRIC_FILES);
        names
    }

    /// Every calculation grid, in scene order.
    pub fn grid_infos(&self) -> Vec<GridInfo> {
        self.grids
            .iter()
            .map(|g| GridInfo {
                id: g.grid.id.clone(),
                name: g.grid.name.clone(),
                count: g.len(),
                layout: g.grid.layout,
                normal: g.grid.normal,
                points: g.grid.points.clone(),
            })
            .collect()
    }

    /// Every surface with its area and patch range, in surface order.
    pub fn surface_infos(&self) -> Vec<SurfaceInfo> {
        let b = &self.baked;
        b.scene
            .surfaces
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let range = &b.mesh.surface_patches[k];
                let area: f64 = range.clone().map(|i| b.mesh.patches[i as usize].area).sum();
                SurfaceInfo {
                    id: s.name.clone(),
                    index: k,
                    area,
                    patches: PatchRange {
                        start: range.start,
                        end: range.end,
                        count: range.len(),
                    },
                    two_sided: s.two_sided,
                }
            })
            .collect()
    }

    /// Every patch, in patch order.
    pub fn patch_infos(&self) -> Vec<PatchInfo<'_>> {
        let names = &self.baked.scene.surfaces;
        self.baked
            .mesh
            .patches
            .iter()
            .map(|p| PatchInfo {
                surface: &names[p.surface as usize].name,
                area: p.area,
                centroid: p.centroid.to_array(),
                normal: p.normal.to_array(),
            })
            .collect()
    }
}
