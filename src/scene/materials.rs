//! The scene's material table: every material of the MTL files named by the OBJ's
//! `mtllib` statements, in the order they are read, with `[material.NAME]` options of
//! `scene.toml` applied, plus a grey default for objects that name no material.
//!
//! `kd` is diffuse reflectance in [0, 1) per channel; `ke` is luminous exitance in lm/m²
//! per channel (front side).

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::files::{self, SceneDir};
use super::obj::ObjScan;
use super::{mtl, texture, SceneError, SceneToml};
use crate::color::Rgb;
use crate::input_limits::{MAX_MATERIALS, MAX_TEXTURES, MAX_TEXTURE_BYTES, MAX_TEXT_BYTES};

/// A material after validation.
#[derive(Debug, Clone, Serialize)]
pub struct Material {
    pub name: String,
    /// Diffuse reflectance per channel, in [0, 1).
    pub kd: Rgb,
    /// Luminous exitance per channel, lm/m² (front side).
    pub ke: Rgb,
    pub two_sided: bool,
    /// A specular lobe on top of the diffuse reflectance (glTF materials with a
    /// roughness below 1 or a metallic part), shown in `final` images only: the
    /// radiosity solution is diffuse. None for OBJ materials.
    pub gloss: Option<Gloss>,
}

/// A microfacet specular lobe: GGX normals with Smith's height-correlated masking and
/// Schlick's Fresnel, as glTF's metallic-roughness model defines it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Gloss {
    /// Specular reflectance at normal incidence per channel, in [0, 1]: 0.04 for a
    /// dielectric of index 1.5, the base colour for a metal (glTF's `F0`).
    pub f0: Rgb,
    /// Specular reflectance at grazing incidence per channel, in [0, 1]: 1, or a
    /// dielectric's `KHR_materials_specular` factor (glTF's `F90`).
    pub f90: Rgb,
    /// GGX width α (the square of glTF's perceptual roughness), in
    /// [[`Gloss::MIN_ALPHA`], 1].
    pub alpha: f32,
}

impl Gloss {
    /// The narrowest lobe (α; perceptual roughness 0.03): a perfect mirror would show a
    /// point luminaire's highlight as a single point, below every pixel's size.
    pub const MIN_ALPHA: f32 = 1e-3;
}

/// The materials of a scene and their index by name.
#[derive(Debug, Default)]
pub(crate) struct MaterialTable {
    pub(crate) materials: Vec<Material>,
    /// Material name → index into `materials`.
    pub(crate) index: HashMap<String, u32>,
    /// The glazing transmittance (0..1) the model file gives a material, by index: glTF
    /// `KHR_materials_transmission` and `alphaMode` BLEND (see `scene::gltf`).
    /// `[material.NAME]` in `scene.toml` overrides it.
    pub(crate) glass: HashMap<u32, f64>,
    /// Textures read so far.
    textures: usize,
}

/// Name of the material given to objects that name none.
const DEFAULT_MATERIAL: &str = "__default";

impl MaterialTable {
    /// Reads the MTL files of the OBJ's `mtllib` statements (each once, in order): relight's
    /// own MTL reader is the only source of materials. A statement may name several files
    /// (`mtllib a.mtl b.mtl`, unless the whole text names one file). Each file read joins
    /// `files` (for the cache key); the readers' warnings join `warnings`. A material
    /// defined in two files, or more than [`MAX_MATERIALS`] in all, is an error.
    ///
    /// Lenient (unless `strict = true`): a missing MTL file or texture is a warning (its
    /// materials turn grey, see [`MaterialTable::add_missing`]; the texture is left out).
    /// A file outside the scene folder is always an error.
    pub(crate) fn read(
        sd: &SceneDir,
        obj_name: &Path,
        scan: &ObjScan,
        cfg: &SceneToml,
        files: &mut Vec<PathBuf>,
        warnings: &mut Vec<String>,
    ) -> Result<MaterialTable, SceneError> {
        let mut table = MaterialTable::default();
        // Per material: the file and line that define it.
        let mut defined_in: Vec<(PathBuf, usize)> = Vec::new();
        let mut libs_read: HashSet<PathBuf> = HashSet::new();
        for (raw, line) in &scan.mtllibs {
            let whole = mtllib_names(raw).len() <= 1 && !raw.contains('\\')
                || sd
                    .resolve_lenient(raw, obj_name, *line, "mtllib")?
                    .is_some();
            let names: Vec<String> = if whole {
                vec![raw.clone()]
            } else {
                mtllib_names(raw)
            };
            for name in names.iter().map(String::as_str) {
                let p = if cfg.strict {
                    sd.resolve(name, obj_name, *line, "mtllib")?
                } else {
                    match sd.resolve_lenient(name, obj_name, *line, "mtllib")? {
                        Some(p) => p,
                        None => {
                            warnings.push(format!(
                                "{}:{line}: mtllib '{name}' not found in the scene folder: \
                                 its materials are grey (Kd 0.5)",
                                obj_name.display()
                            ));
                            continue;
                        }
                    }
                };
                if !libs_read.insert(p.clone()) {
                    continue;
                }
                let shown = sd.display(&p);
                let text = files::to_text(&shown, sd.read(&p, MAX_TEXT_BYTES)?)?;
                let lib = mtl::parse_mtl(&shown, &text, cfg.strict)?;
                warnings.extend(lib.warnings);
                for m in lib.materials {
                    let m = table.textured(m, sd, &shown, cfg.strict, files, warnings)?;
                    table.add(m, &shown, &mut defined_in, cfg)?;
                }
                files.push(p);
            }
        }
        Ok(table)
    }

    /// `m` with its `map_Kd` texture averaged into its reflectance: `Kd` (1 if not given)
    /// times the texture's mean linear colour ([`texture::mean_linear_rgb`]), scaled down
    /// like a `Kd` of 1 or more if a channel reaches 1.
    fn textured(
        &mut self,
        mut m: mtl::MtlMaterial,
        sd: &SceneDir,
        shown: &Path,
        strict: bool,
        files: &mut Vec<PathBuf>,
        warnings: &mut Vec<String>,
    ) -> Result<mtl::MtlMaterial, SceneError> {
        let Some((name, line)) = m.map_kd.take() else {
            return Ok(m);
        };
        let lenient = |problem: String, warnings: &mut Vec<String>| {
            if strict {
                Err(SceneError::Reference {
                    path: shown.to_path_buf(),
                    line,
                    what: "map_Kd".into(),
                    name: name.clone(),
                    problem: format!("{problem} (strict = true)"),
                })
            } else {
                warnings.push(format!(
                    "{}:{line}: map_Kd '{name}' of material '{}' {problem}: its Kd is used alone",
                    shown.display(),
                    m.name
                ));
                Ok(m.clone())
            }
        };
        let p = if strict {
            sd.resolve(&name, shown, line, "map_Kd")?
        } else {
            match sd.resolve_lenient(&name, shown, line, "map_Kd")? {
                Some(p) => p,
                None => return lenient("is not in the scene folder".into(), warnings),
            }
        };
        if self.textures >= MAX_TEXTURES {
            return Err(SceneError::Syntax {
                path: shown.to_path_buf(),
                line,
                message: format!("more than {MAX_TEXTURES} textures in the scene"),
            });
        }
        self.textures += 1;
        let bytes = sd.read(&p, MAX_TEXTURE_BYTES)?;
        files.push(p);
        let mean = match texture::mean_linear_rgb(&bytes) {
            Ok(v) => v,
            Err(e) => return lenient(format!("cannot be read ({e})"), warnings),
        };
        let base = if m.kd_given { m.kd } else { Rgb::ONE };
        let kd = base * mean;
        m.kd = textured_kd(&m, kd, (shown, line), strict, warnings)?;
        Ok(m)
    }

    /// Every `usemtl` name that no MTL file defines becomes a grey material (Kd 0.5) with
    /// one warning listing them; with `strict = true` the first is an error.
    pub(crate) fn add_missing(
        &mut self,
        usemtl: &[(String, usize)],
        obj_name: &Path,
        cfg: &SceneToml,
        warnings: &mut Vec<String>,
    ) -> Result<(), SceneError> {
        let mut missing: Vec<(String, usize)> = Vec::new();
        for (name, line) in usemtl {
            if self.index.contains_key(name) || missing.iter().any(|(n, _)| n == name) {
                continue;
            }
            if cfg.strict {
                return Err(SceneError::UnknownMaterial {
                    path: obj_name.to_path_buf(),
                    line: *line,
                    name: name.clone(),
                });
            }
            if self.materials.len() >= MAX_MATERIALS {
                return Err(SceneError::Syntax {
                    path: obj_name.to_path_buf(),
                    line: *line,
                    message: format!("more than {MAX_MATERIALS} materials in the scene"),
                });
            }
            self.index.insert(name.clone(), self.materials.len() as u32);
            self.materials.push(Material {
                name: name.clone(),
                kd: Rgb::splat(0.5),
                ke: Rgb::ZERO,
                two_sided: cfg.material.get(name).is_some_and(|o| o.two_sided),
                gloss: None,
            });
            missing.push((name.clone(), *line));
        }
        if !missing.is_empty() {
            const SHOWN: usize = 8;
            let listed: Vec<String> = missing
                .iter()
                .take(SHOWN)
                .map(|(n, l)| format!("'{n}' (line {l})"))
                .collect();
            warnings.push(format!(
                "{}: {} material(s) not defined in any MTL file, using grey Kd 0.5: {}{}",
                obj_name.display(),
                missing.len(),
                listed.join(", "),
                if missing.len() > SHOWN { ", …" } else { "" }
            ));
        }
        Ok(())
    }

    /// Adds material `m` of the MTL file `shown`.
    fn add(
        &mut self,
        m: mtl::MtlMaterial,
        shown: &Path,
        defined_in: &mut Vec<(PathBuf, usize)>,
        cfg: &SceneToml,
    ) -> Result<(), SceneError> {
        if let Some(&k) = self.index.get(&m.name) {
            let (other, other_line) = &defined_in[k as usize];
            return Err(SceneError::Syntax {
                path: shown.to_path_buf(),
                line: m.line,
                message: format!(
                    "material '{}' is already defined in {}:{other_line}",
                    m.name,
                    other.display()
                ),
            });
        }
        if self.materials.len() >= MAX_MATERIALS {
            return Err(SceneError::Syntax {
                path: shown.to_path_buf(),
                line: m.line,
                message: format!("more than {MAX_MATERIALS} materials in the scene"),
            });
        }
        self.index
            .insert(m.name.clone(), self.materials.len() as u32);
        defined_in.push((shown.to_path_buf(), m.line));
        self.materials.push(Material {
            two_sided: cfg.material.get(&m.name).is_some_and(|o| o.two_sided),
            name: m.name,
            kd: m.kd,
            ke: m.ke,
            gloss: None,
        });
        Ok(())
    }

    /// Every `[material.NAME]` of `scene.toml` must name a material of the MTL files.
    pub(crate) fn check_options(
        &self,
        cfg: &SceneToml,
        toml_path: &Path,
    ) -> Result<(), SceneError> {
        for name in cfg.material.keys() {
            if !self.index.contains_key(name) {
                return Err(SceneError::Invalid {
                    path: toml_path.to_path_buf(),
                    message: format!("[material.{name}]: no such material in the MTL files"),
                });
            }
        }
        Ok(())
    }

    /// The material names, in table order.
    pub(crate) fn names(&self) -> Vec<String> {
        self.materials.iter().map(|m| m.name.clone()).collect()
    }

    /// Index of the grey default material (Kd 0.5), added on first use with a warning
    /// naming `object`, the first object that needs it.
    pub(crate) fn default_for(&mut self, object: &str, warnings: &mut Vec<String>) -> u32 {
        *self
            .index
            .entry(DEFAULT_MATERIAL.into())
            .or_insert_with(|| {
                warnings.push(format!(
                    "object '{object}' has no material: using grey Kd 0.5"
                ));
                self.materials.push(Material {
                    name: DEFAULT_MATERIAL.into(),
                    kd: Rgb::splat(0.5),
                    ke: Rgb::ZERO,
                    two_sided: false,
                    gloss: None,
                });
                (self.materials.len() - 1) as u32
            })
    }
}

/// The file names of an `mtllib` line: split at whitespace, except where a backslash
/// escapes a space (`mtllib my\ file.mtl other.mtl`, as Blender writes them).
pub(crate) fn mtllib_names(raw: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut cur = String::new();
    let mut chars = raw.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\\' && chars.peek().is_some_and(|n| n.is_whitespace()) {
            cur.push(chars.next().unwrap_or(' '));
        } else if c.is_whitespace() {
            if !cur.is_empty() {
                names.push(std::mem::take(&mut cur));
            }
        } else {
            cur.push(c);
        }
    }
    if !cur.is_empty() {
        names.push(cur);
    }
    names
}

/// The reflectance `kd` (`Kd` × `map_Kd`) of material `m`, defined at `line` of `shown`,
/// scaled down like a `Kd` of 1 or more if a channel reaches 1 (strict: an error).
fn textured_kd(
    m: &mtl::MtlMaterial,
    kd: Rgb,
    (shown, line): (&Path, usize),
    strict: bool,
    warnings: &mut Vec<String>,
) -> Result<Rgb, SceneError> {
    Ok(match mtl::clamp_kd(kd) {
        Some(k) if strict => {
            return Err(SceneError::BadMaterial {
                path: shown.to_path_buf(),
                line,
                material: m.name.clone(),
                message: format!(
                    "Kd × map_Kd = {} {} {}: diffuse reflectance must be in [0, 1) per \
                     channel (strict = true; a lenient load would use {} {} {})",
                    kd[0], kd[1], kd[2], k[0], k[1], k[2]
                ),
            });
        }
        Some(k) => {
            warnings.push(format!(
                "{}:{line}: material '{}': Kd × map_Kd reaches 1: scaled to {} {} {}",
                shown.display(),
                m.name,
                k[0],
                k[1],
                k[2]
            ));
            k
        }
        None => kd,
    })
}
