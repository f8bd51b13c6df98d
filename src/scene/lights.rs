//! Light groups: emitters switched and dimmed together. `[[lights]]` entries of
//! `scene.toml` claim emissive materials and surfaces; emissive triangles no entry claims
//! get a group named after their material. A group that states `lumens` (lm) has its
//! members' exitance `Ke` (lm/m²) rescaled to give that flux. Point luminaires join groups
//! in [`super::luminaires`].

use std::collections::HashMap;
use std::path::Path;

use serde::Serialize;

use super::materials::Material;
use super::toml::LightToml;
use super::triangles::{is_two_sided, Surface, Triangle};
use super::{SceneError, SceneToml};
use crate::color::Rgb;
use crate::input_limits::MAX_LIGHT_GROUPS;

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
    /// Maintenance factor MF in (0, 1]: the group's own, else the scene's (default 1).
    pub maintenance_factor: f64,
    /// Colour rendering index Ra of the group's lamps (the lowest given), when known.
    pub ra: Option<f64>,
}

impl LightGroup {
    /// A group with default settings (intensity 1, white, Ke as modelled), named `id`.
    pub(crate) fn plain(id: &str) -> LightGroup {
        LightGroup {
            id: id.to_string(),
            name: id.to_string(),
            ke_scale: 1.0,
            intensity: 1.0,
            color: Rgb::ONE,
            luminaires: vec![],
            maintenance_factor: 1.0,
            ra: None,
        }
    }
}

/// Adds a luminaire to the group `gid`, creating the group (with default settings) when
/// `lights` has none of that id.
pub(crate) fn add_luminaire(
    lights: &mut Vec<LightGroup>,
    gid: &str,
    lum: crate::photometry::Luminaire,
    ra: Option<f64>,
) {
    let g = match lights.iter().position(|g| g.id == gid) {
        Some(g) => g,
        None => {
            lights.push(LightGroup::plain(gid));
            lights.len() - 1
        }
    };
    lights[g].luminaires.push(lum);
    if let Some(ra) = ra {
        let r = lights[g].ra.get_or_insert(ra);
        *r = r.min(ra);
    }
}

/// Gives every group its maintenance factor: its `[[lights]]` entry's, else the scene's.
pub(crate) fn apply_maintenance_factors(cfg: &SceneToml, lights: &mut [LightGroup]) {
    let scene = cfg.maintenance_factor.unwrap_or(1.0);
    for g in lights {
        let own = cfg.lights.iter().find(|l| l.id == g.id);
        g.maintenance_factor = own.and_then(|l| l.maintenance_factor).unwrap_or(scene);
    }
}

/// The members a group claims: material and surface indices.
type Members = (Vec<u32>, Vec<u32>);

/// Name tables the `[[lights]]` entries refer to.
pub(crate) struct Names<'a> {
    pub(crate) materials: &'a HashMap<String, u32>,
    pub(crate) surfaces: &'a HashMap<String, u32>,
    /// Light groups the model file defines (glTF `KHR_lights_punctual`).
    pub(crate) model_groups: &'a [String],
}

/// Builds the light groups of `[[lights]]`, sets the group of every emissive triangle
/// (creating a group per unclaimed emissive material), and applies `lumens`.
pub(crate) fn assign_lights(
    cfg: &SceneToml,
    toml_path: &Path,
    materials: &[Material],
    surfaces: &[Surface],
    names: &Names<'_>,
    triangles: &mut [Triangle],
) -> Result<Vec<LightGroup>, SceneError> {
    let mut groups: Vec<LightGroup> = Vec::new();
    // Per group: member materials and surfaces.
    let mut members: Vec<Members> = Vec::new();
    for l in &cfg.lights {
        if l.id.is_empty() || groups.iter().any(|g| g.id == l.id) {
            return Err(SceneError::Invalid {
                path: toml_path.into(),
                message: format!("light id '{}' is empty or used twice", l.id),
            });
        }
        let (group, claimed) = configured_group(l, cfg, toml_path, names)?;
        groups.push(group);
        members.push(claimed);
    }
    for t in triangles.iter_mut() {
        let ke = materials[t.material as usize].ke;
        if ke.iter().all(|&x| x == 0.0) {
            continue;
        }
        t.group = Some(group_of(
            t,
            materials,
            surfaces,
            &mut groups,
            &mut members,
            toml_path,
        )?);
    }
    rescale_to_lumens(cfg, toml_path, materials, surfaces, triangles, &mut groups)?;
    Ok(groups)
}

/// The group of one `[[lights]]` entry and the members it claims.
fn configured_group(
    l: &LightToml,
    cfg: &SceneToml,
    toml_path: &Path,
    names: &Names<'_>,
) -> Result<(LightGroup, Members), SceneError> {
    let lookup = |table: &HashMap<String, u32>, kind: &'static str, list: &[String]| {
        list.iter()
            .map(|name| {
                table
                    .get(name)
                    .copied()
                    .ok_or_else(|| SceneError::UnknownLightRef {
                        path: toml_path.into(),
                        light: l.id.clone(),
                        kind,
                        name: name.clone(),
                    })
            })
            .collect::<Result<Vec<u32>, SceneError>>()
    };
    let mats = lookup(names.materials, "material", &l.materials)?;
    let surfs = lookup(names.surfaces, "surface", &l.surfaces)?;
    let invalid = |message: String| SceneError::Invalid {
        path: toml_path.into(),
        message,
    };
    let has_luminaires = cfg
        .luminaires
        .iter()
        .any(|m| m.group.as_deref().unwrap_or(&m.id) == l.id)
        || names.model_groups.contains(&l.id);
    if mats.is_empty() && surfs.is_empty() && !has_luminaires {
        return Err(invalid(format!(
            "light '{}' names no materials or surfaces, and no luminaire or model light \
             joins it",
            l.id
        )));
    }
    if let Some(c) = l.color {
        if c.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(invalid(format!(
                "light '{}': color must be 3 non-negative numbers",
                l.id
            )));
        }
    }
    let intensity = l.intensity.unwrap_or(1.0);
    if !(intensity.is_finite() && intensity >= 0.0) {
        return Err(invalid(format!(
            "light '{}': intensity must be non-negative",
            l.id
        )));
    }
    let group = LightGroup {
        id: l.id.clone(),
        name: l.name.clone().unwrap_or_else(|| l.id.clone()),
        ke_scale: 1.0,
        intensity,
        color: l.color.unwrap_or(Rgb::ONE),
        luminaires: vec![],
        // The scene's default is applied by `apply_maintenance_factors`.
        maintenance_factor: l.maintenance_factor.unwrap_or(1.0),
        ra: l.ra,
    };
    Ok((group, (mats, surfs)))
}

/// The group of emissive triangle `t`: the one group that claims its material or surface,
/// else the group named after its material (created on first use).
fn group_of(
    t: &Triangle,
    materials: &[Material],
    surfaces: &[Surface],
    groups: &mut Vec<LightGroup>,
    members: &mut Vec<Members>,
    toml_path: &Path,
) -> Result<u32, SceneError> {
    let mut found: Option<u32> = None;
    for (g, (mats, surfs)) in members.iter().enumerate() {
        if mats.contains(&t.material) || surfs.contains(&t.surface) {
            if let Some(prev) = found {
                return Err(SceneError::Invalid {
                    path: toml_path.into(),
                    message: format!(
                        "surface '{}' belongs to two lights, '{}' and '{}'",
                        surfaces[t.surface as usize].name, groups[prev as usize].id, groups[g].id
                    ),
                });
            }
            found = Some(g as u32);
        }
    }
    if let Some(g) = found {
        return Ok(g);
    }
    // Emitters no group claims get a group named after their material.
    let mname = &materials[t.material as usize].name;
    Ok(match groups.iter().position(|g| &g.id == mname) {
        Some(g) => g as u32,
        None => {
            groups.push(LightGroup::plain(mname));
            members.push((vec![t.material], vec![]));
            (groups.len() - 1) as u32
        }
    })
}

/// Sets `ke_scale` of every `[[lights]]` group that states its flux (`lumens`, lm).
fn rescale_to_lumens(
    cfg: &SceneToml,
    toml_path: &Path,
    materials: &[Material],
    surfaces: &[Surface],
    triangles: &[Triangle],
    groups: &mut [LightGroup],
) -> Result<(), SceneError> {
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
                let sides = if is_two_sided(t, materials, surfaces) {
                    2.0
                } else {
                    1.0
                };
                t.area() * sides * materials[t.material as usize].ke.luminance() as f64
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
    Ok(())
}

/// At most [`MAX_LIGHT_GROUPS`] groups in all.
pub(crate) fn check_group_count(lights: &[LightGroup], toml_path: &Path) -> Result<(), SceneError> {
    if lights.len() > MAX_LIGHT_GROUPS {
        return Err(SceneError::Invalid {
            path: toml_path.to_path_buf(),
            message: format!(
                "{} light groups ([[lights]], luminaire groups and unclaimed emissive \
                 materials); the limit is {MAX_LIGHT_GROUPS}",
                lights.len()
            ),
        });
    }
    Ok(())
}
