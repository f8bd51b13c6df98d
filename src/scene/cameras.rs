//! Camera presets: the `[[cameras]]` of `scene.toml`, with positions scaled to metres and
//! the vertical field of view in degrees.

use serde::Serialize;

use super::SceneToml;

/// A camera preset, in metres.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct CameraDef {
    pub id: String,
    /// Eye, m.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub position: [f64; 3],
    /// The point looked at, m.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub target: [f64; 3],
    /// Up direction.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
}

/// The camera presets of `cfg`, positions times `scale` (to metres). Their ranges were
/// checked when `scene.toml` was parsed.
pub(crate) fn build_cameras(cfg: &SceneToml, scale: f64) -> Vec<CameraDef> {
    cfg.cameras
        .iter()
        .map(|c| {
            let m = |v: [f64; 3]| [v[0] * scale, v[1] * scale, v[2] * scale];
            CameraDef {
                id: c.id.clone(),
                position: m(c.position),
                target: m(c.target),
                up: c.up,
                fov_deg: c.fov_deg,
            }
        })
        .collect()
}
