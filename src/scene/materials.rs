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
use super::{mtl, SceneError, SceneToml};
use crate::color::Rgb;
use crate::limits::{MAX_MATERIALS, MAX_TEXT_BYTES};

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

/// The materials of a scene and their index by name.
#[derive(Debug, Default)]
pub(crate) struct MaterialTable {
    pub(crate) materials: Vec<Material>,
    /// Material name → index into `materials`.
    pub(crate) index: HashMap<String, u32>,
}

/// Name of the material given to objects that name none.
const DEFAULT_MATERIAL: &str = "__default";

impl MaterialTable {
    /// Reads the MTL files of the OBJ's `mtllib` statements (each once, in order): relight's
    /// own MTL reader is the only source of materials. Each file read joins `files` (for
    /// the cache key); the readers' warnings join `warnings`. A material defined in two
    /// files, or more than [`MAX_MATERIALS`] in all, is an error.
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
        for (name, line) in &scan.mtllibs {
            let p = sd.resolve(name, obj_name, *line, "mtllib")?;
            if !libs_read.insert(p.clone()) {
                continue;
            }
            let shown = sd.display(&p);
            let text = files::to_text(&shown, sd.read(&p, MAX_TEXT_BYTES)?)?;
            let lib = mtl::parse_mtl(&shown, &text)?;
            warnings.extend(lib.warnings);
            for m in lib.materials {
                table.add(m, &shown, &mut defined_in, cfg)?;
            }
            files.push(p);
        }
        Ok(table)
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
                    kd: [0.5; 3],
                    ke: [0.0; 3],
                    two_sided: false,
                });
                (self.materials.len() - 1) as u32
            })
    }
}
