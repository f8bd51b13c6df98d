//! The scene's geometry: input triangles in metres, each with its surface (the OBJ
//! object/group it came from) and its material, built from the parts the OBJ reader
//! returns. Degenerate triangles are skipped with a warning.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;
use serde::Serialize;

use super::materials::{Material, MaterialTable};
use super::obj::ObjPart;
use super::{SceneError, SceneToml};

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

impl Triangle {
    /// Area, m².
    pub(crate) fn area(&self) -> f64 {
        0.5 * (self.p[1] - self.p[0])
            .cross(self.p[2] - self.p[0])
            .length()
    }
}

/// True when the triangle is modelled with both sides active.
pub(crate) fn is_two_sided(t: &Triangle, materials: &[Material], surfaces: &[Surface]) -> bool {
    materials[t.material as usize].two_sided || surfaces[t.surface as usize].two_sided
}

/// The triangles of a scene and the surfaces they belong to.
pub(crate) struct Geometry {
    pub(crate) surfaces: Vec<Surface>,
    /// Surface name → index into `surfaces`.
    pub(crate) surf_index: HashMap<String, u32>,
    pub(crate) triangles: Vec<Triangle>,
}

/// A glazing triangle, in metres, with the share of daylight it lets through.
#[derive(Debug, Clone)]
pub struct Pane {
    pub p: [DVec3; 3],
    pub transmittance: f32,
}

/// Degenerate triangles named one by one in the warnings; more are counted.
const NAMED_DROPS: usize = 5;

impl Geometry {
    /// Builds the triangles of the OBJ `parts` (positions in OBJ units, times `scale` to
    /// metres). Parts without a material get the table's grey default; `[surface.NAME]`
    /// options of `cfg` apply, and each must name an OBJ object/group. No usable triangle
    /// at all is [`SceneError::Empty`], naming `obj_name`.
    pub(crate) fn build(
        parts: &[ObjPart],
        scale: f64,
        cfg: &SceneToml,
        table: &mut MaterialTable,
        obj_name: &Path,
        toml_path: &Path,
        warnings: &mut Vec<String>,
    ) -> Result<Geometry, SceneError> {
        let mut g = Geometry {
            surfaces: Vec::new(),
            surf_index: HashMap::new(),
            triangles: Vec::new(),
        };
        let mut dropped = 0usize;
        for part in parts {
            let mat = match part.material {
                Some(i) => i as u32,
                None => table.default_for(&part.name, warnings),
            };
            let surf = g.surface_of(part, cfg);
            g.add_part(part, scale, surf, mat, &mut dropped, warnings);
        }
        if dropped > NAMED_DROPS {
            warnings.push(format!("{} degenerate triangles skipped in all", dropped));
        }
        if g.triangles.is_empty() {
            return Err(SceneError::Empty(obj_name.to_path_buf()));
        }
        for name in cfg.surface.keys() {
            if !g.surf_index.contains_key(name) {
                // A glTF node of several materials gives surfaces `node / material`.
                let prefix = format!("{name} / ");
                let mut split: Vec<&str> = g
                    .surfaces
                    .iter()
                    .map(|s| s.name.as_str())
                    .filter(|s| s.starts_with(&prefix))
                    .collect();
                split.sort_unstable();
                let hint = match split.len() {
                    0 => String::new(),
                    n => format!(
                        "; its materials make it {n} surfaces: '{}'",
                        split.join("', '")
                    ),
                };
                return Err(SceneError::Invalid {
                    path: toml_path.to_path_buf(),
                    message: format!("[surface.{name}]: no such object/group in the model{hint}"),
                });
            }
        }
        Ok(g)
    }

    /// Index of the surface of `part` (by object/group name), added on first use.
    fn surface_of(&mut self, part: &ObjPart, cfg: &SceneToml) -> u32 {
        let sname = if part.name.is_empty() {
            "unnamed_object".to_string()
        } else {
            part.name.clone()
        };
        let surfaces = &mut self.surfaces;
        *self.surf_index.entry(sname.clone()).or_insert_with(|| {
            surfaces.push(Surface {
                name: sname.clone(),
                two_sided: cfg.surface.get(&sname).is_some_and(|o| o.two_sided),
            });
            (surfaces.len() - 1) as u32
        })
    }

    /// Adds the triangles of `part`, skipping degenerate ones (counted in `dropped`).
    fn add_part(
        &mut self,
        part: &ObjPart,
        scale: f64,
        surf: u32,
        mat: u32,
        dropped: &mut usize,
        warnings: &mut Vec<String>,
    ) {
        let pos = &part.positions;
        let vert = |k: u32| -> DVec3 {
            let k = k as usize * 3;
            DVec3::new(pos[k] as f64, pos[k + 1] as f64, pos[k + 2] as f64) * scale
        };
        for (t, idx) in part.indices.chunks_exact(3).enumerate() {
            let p = [vert(idx[0]), vert(idx[1]), vert(idx[2])];
            if is_degenerate(&p) {
                *dropped += 1;
                if *dropped <= NAMED_DROPS {
                    warnings.push(format!(
                        "object '{}': skipped degenerate triangle #{t}",
                        part.name
                    ));
                }
                continue;
            }
            self.triangles.push(Triangle {
                p,
                surface: surf,
                material: mat,
                group: None,
            });
        }
    }
}

impl Geometry {
    /// Takes the glazing out of the triangles: those whose surface (first) or material
    /// has a `transmittance` in `scene.toml`, or whose material the model file makes
    /// see-through (`table.glass`), unless `scene.toml` marks the surface or material
    /// `opaque`. Glazing is not meshed; a surface left with no triangle is dropped.
    /// Glazing that emits, a transmittance outside 0..1, or a scene of glazing alone is an
    /// error; a see-through material of the model file that emits stays opaque, with a
    /// warning.
    pub(crate) fn split_glazing(
        &mut self,
        cfg: &SceneToml,
        table: &MaterialTable,
        toml_path: &Path,
        obj_name: &Path,
        warnings: &mut Vec<String>,
    ) -> Result<Vec<Pane>, SceneError> {
        let bad = |message: String| SceneError::Invalid {
            path: toml_path.to_path_buf(),
            message,
        };
        check_transmittances(cfg).map_err(bad)?;
        let materials = &table.materials;
        let of_surface: Vec<Option<Option<f64>>> = self
            .surfaces
            .iter()
            .map(|s| {
                let o = cfg.surface.get(&s.name)?;
                if o.opaque {
                    Some(None)
                } else {
                    o.transmittance.map(Some)
                }
            })
            .collect();
        let of_material = material_transmittances(cfg, table, warnings);
        if of_surface.iter().all(|o| !matches!(o, Some(Some(_))))
            && of_material.iter().all(Option::is_none)
        {
            return Ok(Vec::new());
        }
        let mut panes = Vec::new();
        let mut kept = Vec::with_capacity(self.triangles.len());
        for t in self.triangles.drain(..) {
            let glazing =
                of_surface[t.surface as usize].unwrap_or(of_material[t.material as usize]);
            match glazing {
                Some(tr) => {
                    let m = &materials[t.material as usize];
                    if m.ke.iter().any(|&k| k > 0.0) {
                        return Err(bad(format!(
                            "surface '{}' is glazing (transmittance) but its material '{}' \
                             emits: glazing cannot emit",
                            self.surfaces[t.surface as usize].name, m.name
                        )));
                    }
                    panes.push(Pane {
                        p: t.p,
                        transmittance: tr as f32,
                    });
                }
                None => kept.push(t),
            }
        }
        if kept.is_empty() {
            return Err(SceneError::Empty(obj_name.to_path_buf()));
        }
        self.triangles = kept;
        self.drop_empty_surfaces();
        Ok(panes)
    }

    /// Drops the surfaces left without triangles, renumbering the rest.
    fn drop_empty_surfaces(&mut self) {
        let mut used = vec![false; self.surfaces.len()];
        for t in &self.triangles {
            used[t.surface as usize] = true;
        }
        let mut new_index = vec![u32::MAX; self.surfaces.len()];
        let mut surfaces = Vec::new();
        for (i, s) in self.surfaces.drain(..).enumerate() {
            if used[i] {
                new_index[i] = surfaces.len() as u32;
                surfaces.push(s);
            }
        }
        for t in &mut self.triangles {
            t.surface = new_index[t.surface as usize];
        }
        self.surf_index = surfaces
            .iter()
            .enumerate()
            .map(|(i, s)| (s.name.clone(), i as u32))
            .collect();
        self.surfaces = surfaces;
    }
}

/// Checks that every `transmittance` of `[surface.*]` and `[material.*]` is in 0..1.
fn check_transmittances(cfg: &SceneToml) -> Result<(), String> {
    for (kind, opts) in [("surface", &cfg.surface), ("material", &cfg.material)] {
        for (name, o) in opts {
            if let Some(t) = o.transmittance {
                if !(0.0..=1.0).contains(&t) {
                    return Err(format!(
                        "[{kind}.{name}] transmittance = {t}: must be in 0..1"
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Zero area, or a sliver thinner than 1e-6 of its longest edge.
fn is_degenerate(p: &[DVec3; 3]) -> bool {
    let area2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
    let longest = (p[1] - p[0])
        .length()
        .max((p[2] - p[1]).length())
        .max((p[0] - p[2]).length());
    area2.is_nan() || area2 <= 1e-6 * longest * longest || area2 < 1e-14
}

/// Each material's transmittance when it is glazing: set in `scene.toml`, else made
/// see-through by the model file (`table.glass`), unless `scene.toml` marks it `opaque`; a
/// see-through material of the model file that emits stays opaque, with a warning.
fn material_transmittances(
    cfg: &SceneToml,
    table: &MaterialTable,
    warnings: &mut Vec<String>,
) -> Vec<Option<f64>> {
    table
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| match cfg.material.get(&m.name) {
            Some(o) if o.opaque => None,
            Some(o) if o.transmittance.is_some() => o.transmittance,
            _ => {
                let t = table.glass.get(&(i as u32)).copied()?;
                if m.ke.iter().any(|&k| k > 0.0) {
                    warnings.push(format!(
                        "material '{}' is see-through in the model file but emits: it \
                         stays an opaque emitter",
                        m.name
                    ));
                    return None;
                }
                Some(t)
            }
        })
        .collect()
}
