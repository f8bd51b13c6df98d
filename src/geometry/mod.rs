//! Geometry: the scene's surfaces as patches ([`mesh`]), the ray queries over its
//! triangles ([`bvh`]), the panes daylight crosses ([`glazing`]) and the calculation
//! points buried in objects ([`obstructed`]). Lengths are metres.

pub mod blocker;
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

/// How far a ray's origin at `x` is lifted off its surface: 10⁻⁶ m plus 10⁻⁶ of `x`'s
/// largest coordinate, so the lift stays above `f32`/`f64` rounding far from the origin.
pub fn ray_offset(x: DVec3) -> f64 {
    1e-6 * (1.0 + x.abs().max_element())
}

/// `x` lifted a hair along `n`, off its surface ([`ray_offset`]).
pub fn lifted(x: DVec3, n: DVec3) -> DVec3 {
    x + n * ray_offset(x)
}

/// Barycentric coordinates of `p` projected onto the plane of triangle `c` (a third each
/// for a degenerate triangle).
pub fn barycentric(c: &[DVec3; 3], p: DVec3) -> [f64; 3] {
    let (e0, e1, d) = (c[1] - c[0], c[2] - c[0], p - c[0]);
    let (d00, d01, d11) = (e0.dot(e0), e0.dot(e1), e1.dot(e1));
    let (d20, d21) = (d.dot(e0), d.dot(e1));
    let den = d00 * d11 - d01 * d01;
    if den <= 0.0 {
        return [1.0 / 3.0; 3];
    }
    let v = (d11 * d20 - d01 * d21) / den;
    let w = (d00 * d21 - d01 * d20) / den;
    [1.0 - v - w, v, w]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barycentric_coordinates_rebuild_the_point() {
        let c = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
        ];
        let p = DVec3::new(0.5, 0.0, 0.25);
        let l = barycentric(&c, p);
        let q = c[0] * l[0] + c[1] * l[1] + c[2] * l[2];
        assert!((q - p).length() < 1e-12, "{l:?}");
        assert!((l[0] - 0.5).abs() < 1e-12 && (l[1] - 0.25).abs() < 1e-12);
    }
}
