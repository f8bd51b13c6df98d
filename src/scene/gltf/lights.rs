//! glTF `KHR_lights_punctual` lights as luminaires, grouped per light definition.

use glam::{DMat4, DVec3};

use super::walk::LightNames;
use super::{GltfModel, Reader};
use crate::input_limits::MAX_LIGHT_GROUPS;
use crate::photometry::{Distribution, Luminaire, LuminaireSpec};
use crate::scene::lights::LightGroup;
use crate::scene::SceneError;

impl Reader<'_> {
    /// A `KHR_lights_punctual` light on `node`: a luminaire in the light's group.
    pub(super) fn light(
        &mut self,
        node: &gltf::Node<'_>,
        light: &gltf::khr_lights_punctual::Light<'_>,
        world: &DMat4,
        names: &mut LightNames,
        out: &mut GltfModel,
    ) -> Result<(), SceneError> {
        use gltf::khr_lights_punctual::Kind;
        let distribution = match light.kind() {
            Kind::Directional => {
                names.skipped_directional += 1;
                return Ok(());
            }
            Kind::Point => Distribution::Isotropic,
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let (i, o) = (
                    (inner_cone_angle as f64).to_degrees(),
                    (outer_cone_angle as f64).to_degrees(),
                );
                if !(i >= 0.0 && i < o && o <= 90.0) {
                    return Err(self.err(format!(
                        "light '{}': spot cone angles need 0 ≤ inner ({i:.3}°) < outer \
                         ({o:.3}°) ≤ 90°",
                        light.name().unwrap_or("?")
                    )));
                }
                Distribution::Cone {
                    inner_deg: i,
                    outer_deg: o,
                }
            }
        };
        let group = match names.groups.get(&light.index()) {
            Some(g) => g.clone(),
            None => {
                if names.groups.len() >= MAX_LIGHT_GROUPS {
                    return Err(self.err(format!("more than {MAX_LIGHT_GROUPS} lights")));
                }
                let g = names
                    .group_names
                    .take(light.name().map(sanitize_id).as_deref(), || {
                        format!("light{}", light.index())
                    });
                names.groups.insert(light.index(), g.clone());
                g
            }
        };
        let id = names
            .ids
            .take(node.name(), || format!("node{}", node.index()));
        let position = world.transform_point3(DVec3::ZERO) * self.scale;
        let aim = world.transform_vector3(DVec3::NEG_Z);
        let candela = light.intensity() as f64;
        if !(candela.is_finite() && candela >= 0.0) {
            return Err(self.err(format!("light '{id}': intensity must be finite and ≥ 0")));
        }
        let color = crate::color::Rgb(light.color());
        let integral = distribution.integral();
        let spec = LuminaireSpec {
            id: &id,
            position,
            aim,
            c0: None,
            distribution,
            lumens: Some(candela * integral),
            color,
            watts: None,
        };
        let lum = Luminaire::with_integral(spec, integral)
            .map_err(|m| self.err(format!("light on node '{id}': {m}")))?;
        out.luminaires.push((group, lum));
        Ok(())
    }
}

/// A light name as a group id: lower case, runs of other characters than `a-z0-9_` as `-`.
pub(super) fn sanitize_id(name: &str) -> String {
    let mut s = String::new();
    for c in name.chars().flat_map(char::to_lowercase) {
        if c.is_ascii_alphanumeric() || c == '_' {
            s.push(c);
        } else if !s.ends_with('-') {
            s.push('-');
        }
    }
    s.trim_matches('-').chars().take(64).collect()
}

/// Attaches the glTF luminaires to their groups, creating groups `[[lights]]` does not
/// define.
pub(crate) fn add_gltf_luminaires(
    lights: &mut Vec<LightGroup>,
    luminaires: Vec<(String, Luminaire)>,
) {
    for (gid, lum) in luminaires {
        crate::scene::lights::add_luminaire(lights, &gid, lum, None);
    }
}
