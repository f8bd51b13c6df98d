//! Calculation points that measure nothing: a point inside a closed solid (a plinth, a box
//! on the floor, the footprint of furniture standing on it) or tucked under a surface at
//! close range reads 0 lx or near it, and would drag Emin and U₀ of its grid to zero.
//! Lighting-design tools leave such points out of their calculation surfaces; so does
//! relight, by this rule:
//!
//! From the point, [`OBSTRUCTION_RAYS`] stratified cosine-weighted rays leave over the
//! hemisphere of its receiver normal. A ray is *blocked* when the first surface it meets
//! is seen from behind (the back of a one-sided triangle: the point is inside a solid or
//! behind a surface), or lies within [`CLOSE_RANGE_M`] of the point. The point is left
//! out when at least [`OBSTRUCTED_SHARE`] of the rays are blocked. Two-sided surfaces have
//! no back, so only their distance counts.

use glam::{DVec3, Vec3A};

use super::bvh::Bvh;
use super::lifted;
use crate::scene::Scene;

/// Rays per point (an 8 × 8 stratification of the cosine-weighted hemisphere).
pub const OBSTRUCTION_RAYS: usize = 64;
/// A surface nearer than this (m) along a ray blocks it, whichever side faces the point.
pub const CLOSE_RANGE_M: f64 = 0.1;
/// Share of blocked rays from which a point is left out.
pub const OBSTRUCTED_SHARE: f64 = 0.5;

/// True when the point `x` with unit receiver normal `n` (metres) is inside an object or
/// under a surface at close range, by the rule of this module.
pub fn is_obstructed(scene: &Scene, bvh: &Bvh, x: DVec3, n: DVec3) -> bool {
    let side = (OBSTRUCTION_RAYS as f64).sqrt() as usize;
    let (t, b) = super::frame(n);
    let o = lifted(x, n);
    let from = Vec3A::from(o.as_vec3());
    let mut blocked = 0usize;
    for r in 0..side * side {
        let u = ((r % side) as f64 + 0.5) / side as f64;
        let v = ((r / side) as f64 + 0.5) / side as f64;
        // Cosine-weighted: a uniform point of the unit disk lifted to the hemisphere.
        let (rad, phi) = (u.sqrt(), std::f64::consts::TAU * v);
        let (px, py) = (rad * phi.cos(), rad * phi.sin());
        let d = (t * px + b * py + n * (1.0 - u).max(0.0).sqrt()).normalize();
        let Some((dist, id)) = bvh.nearest(from, Vec3A::from(d.as_vec3()), 0.0, f32::INFINITY)
        else {
            continue;
        };
        let tri = &scene.triangles[id as usize];
        let normal = (tri.p[1] - tri.p[0]).cross(tri.p[2] - tri.p[0]);
        let two_sided = crate::scene::is_two_sided(tri, &scene.materials, &scene.surfaces);
        let from_behind = !two_sided && normal.dot(d) > 0.0;
        if from_behind || (dist as f64) < CLOSE_RANGE_M {
            blocked += 1;
        }
    }
    blocked as f64 >= OBSTRUCTED_SHARE * (side * side) as f64
}
