//! Geometry: the scene's surfaces as patches ([`mesh`]), the ray queries over its
//! triangles ([`bvh`]) and the panes daylight crosses ([`glazing`]). Lengths are metres.

pub mod bvh;
pub mod glazing;
pub mod mesh;
