//! Lighting states: which light groups are on, how bright, in what colour.
//!
//! A state maps group ids to a [`LightSetting`]; groups left out keep the default from
//! `scene.toml` (intensity 1, colour white unless configured). Resolving a state against
//! a scene validates it and yields one RGB weight per group: `intensity × colour`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::color::Rgb;
use crate::scene::Scene;

/// Largest accepted intensity (a dimming factor; 1 = as modelled).
pub const MAX_INTENSITY: f32 = 1e6;

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
        if self.intensity > MAX_INTENSITY {
            return Err(bad(format!(
                "intensity {} exceeds the limit {MAX_INTENSITY}",
                self.intensity
            )));
        }
        if self
            .color
            .iter()
            .any(|c| !c.is_finite() || *c < 0.0 || *c > MAX_INTENSITY)
        {
            return Err(bad(format!(
                "color must be three finite numbers in [0, {MAX_INTENSITY}], got {:?}",
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
                s.color.map(|c| c * s.intensity)
            })
            .collect())
    }

    /// Parses a command-line setting `id=v` (intensity) or `id=r,g,b` (RGB weights).
    pub fn parse_arg(&mut self, arg: &str) -> Result<(), String> {
        let (id, val) = arg
            .split_once('=')
            .ok_or_else(|| format!("'{arg}': expected ID=INTENSITY or ID=R,G,B"))?;
        let nums: Result<Vec<f32>, _> = val.split(',').map(|v| v.trim().parse::<f32>()).collect();
        let nums = nums.map_err(|_| format!("'{arg}': not numbers"))?;
        let setting = match nums.as_slice() {
            [v] => LightSetting {
                intensity: *v,
                color: [1.0; 3],
            },
            [r, g, b] => LightSetting {
                intensity: 1.0,
                color: [*r, *g, *b],
            },
            _ => return Err(format!("'{arg}': give one intensity or three RGB values")),
        };
        setting.validate(id).map_err(|e| e.to_string())?;
        self.lights.insert(id.to_string(), setting);
        Ok(())
    }
}

/// Comma-separated ids of the scene's light groups.
pub fn known_ids(scene: &Scene) -> String {
    let ids: Vec<&str> = scene.lights.iter().map(|l| l.id.as_str()).collect();
    if ids.is_empty() {
        "none".into()
    } else {
        ids.join(", ")
    }
}
