//! Geometry: the scene's surfaces as patches ([`mesh`]), the ray queries over its
//! triangles ([`bvh`]), the panes daylight crosses ([`glazing`]) and the calculation
//! points buried in objects ([`obstructed`]). Lengths are metres.

pub mod bvh;
pub mod glazing;
pub mod mesh;
pub mod obstructed;
pub mod patch_locator;
pub mod shaft;

use glam::DVec3;

/// An orthonormal pair (t, b) perpendicular to unit `n`, with `t × b = n`.
pub fn frame(n: DVec3) -> (DVec3, DVec3) {
    let t = if n.x.abs() < 0.9 {
        DVec3::X.cross(n).normalize()
    } else {
        DVec3::Y.cross(n).normalize()
    };
    (t, n.cross(t))
}
