//! Rendering: the solved radiosity seen through a camera.
//!
//! Radiosity is view-independent, so an image splits into a geometric part, built once
//! per (scene, camera, size), and a cheap per-lighting part:
//!
//! 1. [`Shading`] (`shading.rs`): Gouraud values per *shading vertex*. A shading vertex is
//!    a mesh vertex together with the patches around it that lie within one surface and
//!    bend less than 30° against each other. Its value is the area-weighted mean of those
//!    patches, so creases stay sharp and no light bleeds across corners or surfaces.
//! 2. [`ViewBuffer`] (`raster.rs`): the scene, seen by a [`Camera`] (`camera.rs`),
//!    rasterized with a z-buffer at S×S samples per pixel. Every pixel keeps the few
//!    shading vertices it blends, with weights (barycentric × sample coverage). Back faces
//!    are culled; empty samples are black.
//! 3. A relit image is a gather: vertex values (radiosity B, lm/m²) → radiance B/π
//!    (lm/(m²·sr)) → the pixel's weighted sum, then exposure and tone mapping to 8-bit
//!    sRGB ([`ToneMap`], `tonemap.rs`) and encoding ([`Format`], `encode.rs`: PNG, JPEG,
//!    linear EXR, PFM). With few light groups, [`GroupImages`] (`groups.rs`) keeps one
//!    radiance image per group and sums them instead of gathering.
//!
//! Under a sky, [`daylight`] traces the sun's direct light per pixel (sharp sun patches)
//! and shows the sky where a pixel looks out of the scene; the patches carry the rest.
//!
//! False colour ([`false_color`], `falsecolor.rs`) shows illuminance H in lux (incident
//! lm/m², gathered at scale 1, not divided by π) on a log scale, with a legend bar labelled
//! in the 5×7 bitmap font of `font.rs`.

mod camera;
pub mod daylight;
mod encode;
pub mod export;
mod falsecolor;
pub mod final_gather;
mod font;
mod groups;
pub mod pipeline;
pub mod preview;
mod raster;
mod shading;
mod tonemap;

pub use camera::Camera;
pub use encode::{encode_8bit, encode_exr, encode_pfm, jpeg_strips, Format};
pub use export::{export_bytes, export_glb, ExportOptions, Exported, MAX_EXPORT_BYTES};
pub use falsecolor::{false_color, false_color_range, scale_color};
pub use groups::GroupImages;
pub use raster::{ViewBuffer, EST_WEIGHTS_PER_PIXEL, MAX_SIDE};
pub use shading::Shading;
pub use tonemap::{auto_exposure, tone_curve, tonemap, ToneMap};
