//! relight: relights static 3D scenes in milliseconds from a precomputed radiosity
//! transfer. See `ARCHITECTURE.md` for the map of the crate.
//!
//! Data path: [`scene`] → [`mesh`] → [`bvh`] → [`formfactor`] (+ [`direct`] light of
//! [`photometry`] luminaires) → [`solve`]/[`transfer`]
//! → [`cache`], orchestrated by [`bake`]; [`report`] turns solutions into per-surface
//! answers.

// The OpenAPI document is one large json! literal.
#![recursion_limit = "256"]

pub mod bake;
pub mod bench;
pub mod budget;
pub mod bvh;
pub mod cache;
pub mod color;
pub mod direct;
pub mod formfactor;
pub mod grid;
pub mod lighting;
pub mod limits;
pub mod mesh;
pub mod optimize;
pub mod photometry;
pub mod probe;
pub mod render;
pub mod report;
pub mod scene;
pub mod server;
pub mod solve;
pub mod transfer;
