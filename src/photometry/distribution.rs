//! Luminous intensity distributions: isotropic, cos^m spots (beam and field angles in
//! degrees) and IES tables, evaluated in the luminaire frame (components along aim, c0 and
//! c90 = aim × c0), and their integral over the sphere (lm per cd of the shape; for
//! absolute IES tables, lumens).

use std::f64::consts::PI;

use super::table::{CandelaTable, PhotometricType};

/// The shape of a luminous intensity distribution.
#[derive(Debug, Clone)]
pub enum Distribution {
    /// The same intensity in every direction.
    Isotropic,
    /// A cos^m spot around the aim: 50 % of the peak at half the beam angle, zero beyond
    /// half the field angle (degrees, full cone angles).
    Spot { beam_deg: f64, field_deg: f64 },
    /// A glTF `KHR_lights_punctual` spot: full intensity inside the inner cone, zero
    /// outside the outer one, and between them the extension's falloff
    /// `t²` with `t = (cos θ − cos outer) / (cos inner − cos outer)` (degrees, half-angles
    /// from the aim, 0 ≤ inner < outer ≤ 90).
    Cone { inner_deg: f64, outer_deg: f64 },
    /// A candela table from an IES LM-63 or EULUMDAT file.
    Table(Box<CandelaTable>),
}

impl Distribution {
    /// Relative (Table: absolute) intensity towards a direction given in the luminaire frame
    /// as its components along (aim, c0, c90).
    pub(super) fn shape(&self, a: f64, c0: f64, c90: f64) -> f64 {
        match self {
            Distribution::Isotropic => 1.0,
            Distribution::Spot {
                beam_deg,
                field_deg,
            } => {
                let t = a.clamp(-1.0, 1.0).acos();
                if t > (0.5 * field_deg).to_radians() || a <= 0.0 {
                    return 0.0;
                }
                let m = 0.5f64.ln() / (0.5 * beam_deg).to_radians().cos().ln();
                a.powf(m)
            }
            Distribution::Cone {
                inner_deg,
                outer_deg,
            } => {
                let (ci, co) = (inner_deg.to_radians().cos(), outer_deg.to_radians().cos());
                let t = ((a - co) / (ci - co).max(1e-9)).clamp(0.0, 1.0);
                t * t
            }
            Distribution::Table(d) => match d.kind {
                PhotometricType::C => {
                    let gamma = super::angles::acos_deg(a);
                    let c = super::angles::atan2_deg(c90, c0);
                    d.candela_at(gamma, c)
                }
                PhotometricType::B => {
                    // Lateral axis r = c90: V is the plane's elevation towards c0, H the
                    // angle within the plane towards r.
                    // At the poles (±r) every plane meets: take V = 0.
                    let v = if a.abs() < 1e-12 && c0.abs() < 1e-12 {
                        0.0
                    } else {
                        c0.atan2(a).to_degrees()
                    };
                    let h = c90.clamp(-1.0, 1.0).asin().to_degrees();
                    d.candela_at(v, h)
                }
            },
        }
    }

    /// The largest [`Self::shape`] over the directions whose cosine to the aim lies in
    /// `lo..=hi`: exact for tables of type C (bilinear interpolation peaks at the corners
    /// of the band's cells: its bounding angles and the measured ones between them, on
    /// the measured planes) and for the profiles that grow towards the aim; the whole
    /// table's peak for type B.
    pub(super) fn peak_between(&self, lo: f64, hi: f64) -> f64 {
        let (lo, hi) = (lo.clamp(-1.0, 1.0), hi.clamp(-1.0, 1.0));
        match self {
            Distribution::Isotropic => 1.0,
            // Both grow with the cosine to the aim.
            Distribution::Spot { .. } | Distribution::Cone { .. } => {
                self.shape(hi, (1.0 - hi * hi).max(0.0).sqrt(), 0.0)
            }
            Distribution::Table(t) => match t.kind {
                PhotometricType::C => {
                    let (g0, g1) = (hi.acos().to_degrees(), lo.acos().to_degrees());
                    let at = |g: f64| -> f64 {
                        (0..t.horizontal.len())
                            .map(|i| t.candela_at(g, t.horizontal[i]))
                            .fold(0.0, f64::max)
                    };
                    t.vertical
                        .iter()
                        .copied()
                        .filter(|&v| v > g0 && v < g1)
                        .chain([g0, g1])
                        .map(at)
                        .fold(0.0, f64::max)
                }
                PhotometricType::B => t.candela.iter().flatten().copied().fold(0.0, f64::max),
            },
        }
    }

    /// ∫ shape dΩ over the sphere (lumens for absolute tables). Costs about 260,000
    /// evaluations for spots and tables: compute it once per distinct distribution
    /// (see [`Luminaire::with_integral`]).
    pub(crate) fn integral(&self) -> f64 {
        match self {
            Distribution::Isotropic => 4.0 * std::f64::consts::PI,
            Distribution::Cone {
                inner_deg,
                outer_deg,
            } => {
                // 2π ∫ shape d(cos θ): 1 − ci over the inner cone, (ci − co)/3 for the ramp.
                let (ci, co) = (inner_deg.to_radians().cos(), outer_deg.to_radians().cos());
                2.0 * std::f64::consts::PI * ((1.0 - ci) + (ci - co) / 3.0)
            }
            _ => {
                // Midpoint rule: 0.25° in θ, 1° in φ, exact enough for tables at 1–5°.
                let rings =
                    sphere_rings(720, 360, |ct, st, cp, sp| self.shape(ct, st * cp, st * sp));
                rings.iter().sum()
            }
        }
    }
}

/// The integral of `f` over each of `nt` rings of the unit sphere, in order of θ from the
/// pole: the midpoint rule on `nt` steps of θ and `np` of φ. `f` takes (cos θ, sin θ,
/// cos φ, sin φ).
pub(crate) fn sphere_rings(
    nt: usize,
    np: usize,
    f: impl Fn(f64, f64, f64, f64) -> f64,
) -> Vec<f64> {
    let (dt, dp) = (PI / nt as f64, 2.0 * PI / np as f64);
    (0..nt)
        .map(|i| {
            let (st, ct) = ((i as f64 + 0.5) * dt).sin_cos();
            let ring: f64 = (0..np)
                .map(|j| {
                    let (sp, cp) = ((j as f64 + 0.5) * dp).sin_cos();
                    f(ct, st, cp, sp)
                })
                .sum();
            ring * st * dt * dp
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::Distribution;

    /// The closed-form integral of a glTF cone equals the sphere quadrature of its shape.
    #[test]
    fn cone_integral_matches_quadrature() {
        for (inner, outer) in [(0.0, 45.0), (20.0, 30.0), (10.0, 90.0), (29.9, 30.0)] {
            let d = Distribution::Cone {
                inner_deg: inner,
                outer_deg: outer,
            };
            let nt = 4000;
            let dt = std::f64::consts::PI / nt as f64;
            let mut sum = 0.0;
            for i in 0..nt {
                let t = (i as f64 + 0.5) * dt;
                let (st, ct) = t.sin_cos();
                sum += d.shape(ct, st, 0.0) * st * dt * 2.0 * std::f64::consts::PI;
            }
            let exact = d.integral();
            assert!(
                (sum - exact).abs() < 2e-3 * exact,
                "inner {inner} outer {outer}: {sum} vs {exact}"
            );
        }
    }
}
