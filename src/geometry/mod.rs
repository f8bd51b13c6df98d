//! Geometry: the scene's surfaces as patches ([`mesh`]), the ray queries over its
//! triangles ([`bvh`]), the panes daylight crosses ([`glazing`]) and the calculation
//! points buried in objects ([`obstructed`]). Lengths are metres.

pub mod bvh;
pub mod glazing;
pub mod mesh;
pub mod obstructed;
