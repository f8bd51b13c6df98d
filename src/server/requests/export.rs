//! The query of `GET …/export.glb`: a lighting state and the look of the exported colours.

use std::collections::BTreeMap;

use super::lighting::{lighting, Lights};
use super::render::{
    given_once, query_choice, query_light, query_number, TonemapName, MAX_EXPOSURE,
};
use crate::model::Lighting;
use crate::model::Model;
use crate::render::ExportOptions;
use crate::server::parse::{number, shorten};
use crate::server::AppError;

/// `export.glb?light.ceiling=0.5&exposure=-2&tonemap=clamp&relightable=false`.
pub(crate) struct ExportRequest {
    lights: Lights,
    exposure: Option<f64>,
    tonemap: TonemapName,
    relightable: bool,
}

impl ExportRequest {
    /// 400 for a parameter given twice, unknown, or not a number where one is expected.
    pub(crate) fn from_query(q: &[(String, String)]) -> Result<ExportRequest, AppError> {
        let mut lights = BTreeMap::new();
        let mut r = ExportRequest {
            lights: Lights(BTreeMap::new()),
            exposure: None,
            tonemap: TonemapName::default(),
            relightable: true,
        };
        let mut seen: Vec<&str> = Vec::with_capacity(q.len());
        for (k, v) in q {
            given_once(&mut seen, k, k)?;
            match k.as_str() {
                "exposure" if v == "auto" => r.exposure = None,
                "exposure" => r.exposure = Some(query_number(k, v)?),
                "tonemap" => r.tonemap = query_choice("tonemap", v)?,
                "relightable" => {
                    r.relightable = match v.as_str() {
                        "true" => true,
                        "false" => false,
                        _ => {
                            return Err(AppError::BadRequest(format!(
                                "query parameter relightable={}: use true or false",
                                shorten(v)
                            )))
                        }
                    }
                }
                _ => {
                    if !query_light(k, v, &mut lights)? {
                        return Err(AppError::BadRequest(format!(
                            "unknown query parameter '{}' (exposure, tonemap, relightable, \
                             light.<group>)",
                            shorten(k)
                        )));
                    }
                }
            }
        }
        r.lights = Lights(lights);
        Ok(r)
    }

    /// The group weights (422 for unknown groups and values out of range) and options.
    pub(crate) fn resolve(
        &self,
        model: &Model,
    ) -> Result<(Vec<crate::color::Rgb>, ExportOptions), AppError> {
        let weights = match lighting(Some(&self.lights), None, model)? {
            Lighting::Groups(w) => w,
            Lighting::Emission(_) => {
                return Err(AppError::Internal("export: lights gave an emission".into()))
            }
        };
        let exposure = match self.exposure {
            None => None,
            Some(e) => {
                let e = number(e, "exposure")?;
                if e.abs() > MAX_EXPOSURE {
                    return Err(AppError::Invalid(format!(
                        "exposure {e} stops is outside ±{MAX_EXPOSURE}"
                    )));
                }
                Some(e as f32)
            }
        };
        Ok((
            weights,
            ExportOptions {
                exposure,
                tonemap: self.tonemap.0,
                relightable: self.relightable,
            },
        ))
    }
}

/// The query of `export.glb` as documented (read as a list of pairs, to refuse repeats).
#[derive(utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
#[allow(dead_code)]
pub(crate) struct ExportQuery {
    /// Stops, or auto (default: the log-average vertex luminance to middle grey).
    #[param(value_type = Option<super::render::Exposure>)]
    exposure: Option<f64>,
    #[param(inline)]
    tonemap: Option<TonemapName>,
    /// Write one `_LIGHT_<GROUP>` attribute per light group (default true).
    relightable: Option<bool>,
}
