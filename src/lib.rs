//! relight: relights static 3D scenes in milliseconds from a precomputed radiosity
//! transfer. See `ARCHITECTURE.md` for the map of the crate.
//!
//! Data path: [`scene`] → [`geometry`] (mesh, BVH) → [`transport`] (form factors, direct
//! light of [`photometry`] luminaires, solve, transfer) → [`bake`] (pipeline and cache) →
//! [`model`] (the queries: lighting states, per-patch answers, points, grids, optimize,
//! reports) → [`render`] (images) and, with the default `server` feature, [`server`]
//! (HTTP).

pub mod bake;
pub mod bench;
pub mod budget;
pub mod color;
pub mod daylight;
pub mod geometry;
pub mod input_limits;
pub mod model;
pub mod photometry;
pub mod render;
pub(crate) mod sampling;
pub mod scene;
#[cfg(feature = "server")]
pub(crate) mod schema;
#[cfg(feature = "server")]
pub mod server;
pub mod transport;
