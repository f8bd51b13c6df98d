//! Lighting states: which light groups are on, how bright, in what colour.
//!
//! A state maps group ids to a [`LightSetting`]; groups left out keep the default from
//! `scene.toml` (intensity 1, colour white unless configured). Resolving a state against
//! a scene validates it and yields one RGB weight per group: `intensity × colour`.
//!
//! This is the one grammar of a lighting state. Every front end sets a group through
//! [`LightState::set`] (what it leaves out keeps the scene's default), and the text form
//! `ID=VALUE` of the command line (`--light ceiling=0.5`) and of query strings
//! (`light.ceiling=0.5`) is read by [`parse_value`]:
//! - `ID=I`: intensity I (a dimming factor, 1 = as modelled), the group's own colour;
//! - `ID=R,G,B`: intensity 1, linear RGB colour filter (R, G, B).
//!
//! [`Lighting`] is a state resolved for a scene: per-group weights, or (factored
//! transfer only) a per-patch emission vector in lm/m².

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::color::{Rgb, Rgb64};
use crate::input_limits::MAX_STATE_INTENSITY;
use crate::scene::Scene;

/// Setting of one light group.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LightSetting {
    /// Dimming factor, ≥ 0 (1 = the group's modelled output).
    pub intensity: f32,
    /// Linear RGB colour filter, each channel ≥ 0.
    pub color: Rgb,
}

/// A lighting state: settings for some groups; the rest keep their defaults.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LightState {
    pub lights: BTreeMap<String, LightSetting>,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LightError {
    /// A setting's text form does not parse (`ID=I` or `ID=R,G,B`).
    #[error("{0}")]
    Syntax(String),
    #[error("unknown light group '{id}' (known: {known})")]
    UnknownGroup { id: String, known: String },
    #[error("light '{id}': {message}")]
    Invalid { id: String, message: String },
}

impl LightSetting {
    /// Checks that the numbers are finite, non-negative and not absurdly large.
    pub fn validate(&self, id: &str) -> Result<(), LightError> {
        let bad = |message: String| LightError::Invalid {
            id: id.into(),
            message,
        };
        if !self.intensity.is_finite() || self.intensity < 0.0 {
            return Err(bad(format!(
                "intensity must be a finite number ≥ 0, got {}",
                self.intensity
            )));
        }
        if self.intensity > MAX_STATE_INTENSITY {
            return Err(bad(format!(
                "intensity {} exceeds the limit {MAX_STATE_INTENSITY}",
                self.intensity
            )));
        }
        if self
            .color
            .iter()
            .any(|c| !c.is_finite() || *c < 0.0 || *c > MAX_STATE_INTENSITY)
        {
            return Err(bad(format!(
                "color must be three finite numbers in [0, {MAX_STATE_INTENSITY}], got {:?}",
                self.color
            )));
        }
        Ok(())
    }
}

impl LightState {
    /// Per-group RGB weights for `scene`, in the order of `scene.lights`.
    pub fn weights(&self, scene: &Scene) -> Result<Vec<Rgb>, LightError> {
        for (id, s) in &self.lights {
            if scene.light_index(id).is_none() {
                return Err(LightError::UnknownGroup {
                    id: id.clone(),
                    known: known_ids(scene),
                });
            }
            s.validate(id)?;
        }
        Ok(scene
            .lights
            .iter()
            .map(|g| {
                let s = self.lights.get(&g.id).copied().unwrap_or(LightSetting {
                    intensity: g.intensity,
                    color: g.color,
                });
                s.color * s.intensity
            })
            .collect())
    }

    /// Sets group `id` of `scene`: `intensity` and `color` where given; what is left
    /// out keeps the scene's default. Checks the id and the numbers.
    pub fn set(
        &mut self,
        scene: &Scene,
        id: &str,
        intensity: Option<f32>,
        color: Option<Rgb>,
    ) -> Result<(), LightError> {
        let g = scene
            .light_index(id)
            .ok_or_else(|| LightError::UnknownGroup {
                id: id.into(),
                known: known_ids(scene),
            })?;
        let def = &scene.lights[g];
        let setting = LightSetting {
            intensity: intensity.unwrap_or(def.intensity),
            color: color.unwrap_or(def.color),
        };
        setting.validate(id)?;
        self.lights.insert(id.to_string(), setting);
        Ok(())
    }

    /// Applies command-line settings `ID=I` or `ID=R,G,B` (see [`parse_value`]).
    pub fn parse_args<S: AsRef<str>>(scene: &Scene, args: &[S]) -> Result<LightState, LightError> {
        let mut state = LightState::default();
        for arg in args {
            let arg = arg.as_ref();
            let (id, val) = arg.split_once('=').ok_or_else(|| {
                LightError::Syntax(format!("'{arg}': expected ID=INTENSITY or ID=R,G,B"))
            })?;
            let (intensity, color) =
                parse_value(val).map_err(|e| LightError::Syntax(format!("'{arg}': {e}")))?;
            // Out-of-range values become inf here and are refused by `set`.
            state.set(
                scene,
                id,
                intensity.map(|x| x as f32),
                color.map(|c| Rgb64(c).to_f32()),
            )?;
        }
        Ok(state)
    }
}

/// The text form of one group's setting: `I` (intensity; the group keeps its colour) or
/// `R,G,B` (intensity 1 and this colour), in f64 so that callers check ranges before
/// narrowing. Numbers are checked later ([`LightState::set`], or the server's limits).
pub fn parse_value(val: &str) -> Result<(Option<f64>, Option<[f64; 3]>), String> {
    let nums: Result<Vec<f64>, _> = val.split(',').map(|v| v.trim().parse::<f64>()).collect();
    let nums = nums.map_err(|_| "not a number".to_string())?;
    match nums.as_slice() {
        [v] => Ok((Some(*v), None)),
        [r, g, b] => Ok((Some(1.0), Some([*r, *g, *b]))),
        _ => Err("give one intensity or three RGB values".into()),
    }
}

/// A lighting state resolved for one scene.
#[derive(Debug, Clone)]
pub enum Lighting {
    /// Per light group, RGB weights (intensity × colour), in the order of `scene.lights`.
    Groups(Vec<Rgb>),
    /// Per patch, RGB emission in lm/m², n × 3 interleaved (factored transfer only).
    Emission(Vec<f32>),
    /// Group weights with luminaires placed, moved or removed for this request
    /// ([`super::placed`]; factored and hierarchical transfers).
    Placed(super::placed::Placed),
}

impl Lighting {
    /// The group weights, when this is a group state.
    pub fn weights(&self) -> Option<&[Rgb]> {
        match self {
            Lighting::Groups(w) => Some(w),
            Lighting::Emission(_) | Lighting::Placed(_) => None,
        }
    }
}

/// Comma-separated ids of the scene's light groups.
pub fn known_ids(scene: &Scene) -> String {
    super::error::known_list(scene.lights.iter().map(|l| l.id.as_str()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The office: groups `window_row` and `corridor_row`, both at intensity 1, white.
    fn office() -> Scene {
        Scene::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office"))
            .expect("the office scene loads")
    }

    #[test]
    fn parse_value_reads_an_intensity_or_a_colour() {
        assert_eq!(parse_value("0.25"), Ok((Some(0.25), None)));
        assert_eq!(
            parse_value(" 1, 0.5 ,0"),
            Ok((Some(1.0), Some([1.0, 0.5, 0.0])))
        );
        assert_eq!(parse_value("half"), Err("not a number".to_string()));
        assert_eq!(
            parse_value("1,2"),
            Err("give one intensity or three RGB values".to_string())
        );
    }

    #[test]
    fn validate_refuses_negative_non_finite_and_huge_numbers() {
        let ok = |intensity: f32, color: Rgb| LightSetting { intensity, color }.validate("g");
        assert!(ok(0.0, Rgb::ZERO).is_ok());
        assert!(ok(MAX_STATE_INTENSITY, Rgb::splat(MAX_STATE_INTENSITY)).is_ok());
        for bad in [
            ok(-0.1, Rgb::ONE),
            ok(f32::NAN, Rgb::ONE),
            ok(2e6, Rgb::ONE),
            ok(1.0, Rgb::new(1.0, -1.0, 1.0)),
            ok(1.0, Rgb::new(1.0, f32::INFINITY, 1.0)),
            ok(1.0, Rgb::new(2e6, 1.0, 1.0)),
        ] {
            assert!(matches!(bad, Err(LightError::Invalid { ref id, .. }) if id == "g"));
        }
    }

    #[test]
    fn weights_are_intensity_times_colour_with_defaults_for_groups_left_out() {
        let scene = office();
        let mut state = LightState::default();
        assert_eq!(state.weights(&scene).unwrap(), vec![[1.0; 3], [1.0; 3]]);
        state
            .set(
                &scene,
                "corridor_row",
                Some(0.5),
                Some(Rgb::new(1.0, 0.5, 0.0)),
            )
            .unwrap();
        assert_eq!(
            state.weights(&scene).unwrap(),
            vec![[1.0; 3], [0.5, 0.25, 0.0]]
        );
        // A colour alone keeps the default intensity, an intensity alone the colour.
        state
            .set(&scene, "window_row", None, Some(Rgb::new(0.0, 1.0, 2.0)))
            .unwrap();
        assert_eq!(state.weights(&scene).unwrap()[0], [0.0, 1.0, 2.0]);
        state.set(&scene, "window_row", Some(3.0), None).unwrap();
        assert_eq!(state.weights(&scene).unwrap()[0], [3.0; 3]);
    }

    #[test]
    fn parse_args_reads_command_line_settings_and_names_the_known_groups() {
        let scene = office();
        let state =
            LightState::parse_args(&scene, &["window_row=0.25", "corridor_row=0,1,0.5"]).unwrap();
        assert_eq!(
            state.weights(&scene).unwrap(),
            vec![[0.25; 3], [0.0, 1.0, 0.5]]
        );
        let e = LightState::parse_args(&scene, &["desk=1"]).unwrap_err();
        assert_eq!(
            e,
            LightError::UnknownGroup {
                id: "desk".into(),
                known: "window_row, corridor_row".into()
            }
        );
        assert!(matches!(
            LightState::parse_args(&scene, &["window_row"]),
            Err(LightError::Syntax(_))
        ));
        // Out of f32's range: refused, not infinite.
        assert!(matches!(
            LightState::parse_args(&scene, &["window_row=1e40"]),
            Err(LightError::Invalid { .. })
        ));
        // A state naming an unknown group is refused when resolved.
        let mut bad = LightState::default();
        bad.lights.insert(
            "nowhere".into(),
            LightSetting {
                intensity: 1.0,
                color: Rgb::ONE,
            },
        );
        assert!(matches!(
            bad.weights(&scene),
            Err(LightError::UnknownGroup { .. })
        ));
    }

    #[test]
    fn known_ids_lists_the_groups_or_none() {
        assert_eq!(known_ids(&office()), "window_row, corridor_row");
        assert_eq!(super::super::error::known_list([]), "none");
    }
}
