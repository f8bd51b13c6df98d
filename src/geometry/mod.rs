//! Geometry: the scene's surfaces as patches ([`mesh`]) and the ray queries over its
//! triangles ([`bvh`]). Lengths are metres.

pub mod bvh;
pub mod mesh;
