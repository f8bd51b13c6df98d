//! The query of `GET …/export.glb` and the body of `POST …/export.glb`: a lighting state
//! and the look of the exported colours.

use std::collections::BTreeMap;

use super::lighting::{light_weights, Lights};
use super::query::{as_written, read_query};
use super::render::{Exposure, TonemapName, MAX_EXPOSURE};
use super::{lit_request, some, Resolve};
use crate::budget::human_bytes;
use crate::model::{Lighting, Model};
use crate::render::{export_bytes, ExportOptions, ToneMap, MAX_EXPORT_BYTES};
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
        let mut r = ExportRequest {
            lights: Lights(BTreeMap::new()),
            exposure: None,
            tonemap: TonemapName::default(),
            relightable: true,
        };
        let known = "exposure, tonemap, relightable, light.<group>";
        r.lights = read_query(q, as_written, known, |p| {
            match p.name {
                "exposure" if p.value == "auto" => r.exposure = None,
                "exposure" => r.exposure = Some(p.number()?),
                "tonemap" => r.tonemap = p.choice()?,
                "relightable" => {
                    r.relightable = match p.value {
                        "true" => true,
                        "false" => false,
                        v => {
                            return Err(AppError::BadRequest(format!(
                                "query parameter relightable={}: use true or false",
                                shorten(v)
                            )))
                        }
                    }
                }
                _ => return Ok(false),
            }
            Ok(true)
        })?;
        Ok(r)
    }
}

/// An export in the model's terms: the lighting state and the look of the colours.
pub(crate) struct ExportAsk {
    pub lighting: Lighting,
    pub options: ExportOptions,
    /// The file's size at most, bytes (within [`MAX_EXPORT_BYTES`]).
    pub bytes: u64,
}

impl Resolve for ExportRequest {
    type Resolved = ExportAsk;

    /// The group weights (422 for unknown groups and values out of range) and options,
    /// and the file's size, refused over [`MAX_EXPORT_BYTES`].
    fn resolve(&self, model: &Model) -> Result<ExportAsk, AppError> {
        let weights = light_weights(Some(&self.lights), model)?;
        let look = (self.exposure, self.tonemap.0, self.relightable);
        ask(Lighting::Groups(weights), look, model)
    }
}

lit_request! {
    /// A lighting state (light groups, luminaires placed per request or a per-patch
    /// emission) and the look of the exported colours.
    #[derive(Default)]
    ExportBody, "a JSON object" {
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        exposure: Option<Exposure>,
        #[serde(default)]
        #[schema(inline)]
        tonemap: TonemapName,
        /// Write one `_LIGHT_<GROUP>` attribute per light group, and `_LIGHT_REQUEST` for
        /// the light of placed luminaires or an emission (default true).
        #[serde(default, deserialize_with = "some")]
        #[schema(nullable = false)]
        relightable: Option<bool>,
    }
}

impl Resolve for ExportBody {
    type Resolved = ExportAsk;

    /// The lighting state and options, and the file's size, refused over
    /// [`MAX_EXPORT_BYTES`].
    fn resolve(&self, model: &Model) -> Result<ExportAsk, AppError> {
        let lighting = self.lighting(model)?;
        let exposure = match self.exposure {
            None | Some(Exposure::Auto) => None,
            Some(Exposure::Stops(e)) => Some(e),
        };
        let look = (exposure, self.tonemap.0, self.relightable.unwrap_or(true));
        ask(lighting, look, model)
    }
}

/// An export of `lighting` with the exposure (stops; None: auto), tone map and
/// relightable attributes of `look`: the exposure checked, the file's size refused over
/// [`MAX_EXPORT_BYTES`].
fn ask(
    lighting: Lighting,
    (exposure, tonemap, relightable): (Option<f64>, ToneMap, bool),
    model: &Model,
) -> Result<ExportAsk, AppError> {
    let exposure = match exposure {
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
    let options = ExportOptions {
        exposure,
        tonemap,
        relightable,
    };
    // Shading vertices are at most three per patch.
    let bytes = export_bytes(model, 3 * model.baked.mesh.len(), options.relightable);
    if bytes > MAX_EXPORT_BYTES {
        return Err(AppError::Invalid(format!(
            "the export could take up to {} (limit {}): ask with relightable=false",
            human_bytes(bytes),
            human_bytes(MAX_EXPORT_BYTES)
        )));
    }
    Ok(ExportAsk {
        lighting,
        options,
        bytes,
    })
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
