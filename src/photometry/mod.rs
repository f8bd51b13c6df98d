//! Point luminaires and their photometry: isotropic, cosine spots, and candela tables from
//! IES LM-63 and EULUMDAT files.
//!
//! A luminaire is a point at `position` (metres) with a luminous intensity distribution
//! I(ω) in candela, oriented by `aim` (the photometric axis: nadir for type C, the beam
//! axis for spots and type B) and `c0` (the direction of the C = 0° half-plane,
//! perpendicular to the aim). Its direct illuminance at a point x on a receiver with
//! normal n is `E = I(ω) · cos θ / d²` (lux), ω the direction from the luminaire to x.
//!
//! - `table.rs`: [`CandelaTable`], a candela table (types C and B) with its symmetry
//!   unfolded on lookup, whichever file it came from.
//! - `ies.rs`: the IES LM-63 reader; `ldt.rs`: the EULUMDAT reader.
//! - `opening.rs`: [`LuminousOpening`], the emitting shape the files give (metres).
//! - `distribution.rs`: the shapes of the distributions and their integrals,
//!   [`Distribution`].
//! - `cct.rs`: blackbody colours from a colour temperature (K).

mod cct;
mod distribution;
mod ies;
mod ldt;
mod opening;
mod table;

use glam::DVec3;

use crate::color::Rgb;

pub(crate) use cct::cct_to_rgb;
pub use distribution::Distribution;
pub use ies::parse_ies;
pub(crate) use ies::parse_ies_file;
pub use ldt::parse_ldt;
pub(crate) use ldt::parse_ldt_file;
pub use opening::LuminousOpening;
pub use table::{CandelaTable, PhotometricFormat, PhotometricType};

/// A photometric file that cannot be read: the file (as the caller names it) and, where one
/// applies, its 1-based line.
#[derive(Debug, thiserror::Error)]
pub enum PhotometryError {
    #[error("{path}:{line}: {message}")]
    Syntax {
        path: std::path::PathBuf,
        line: usize,
        message: String,
    },
    #[error("{path}: {message}")]
    Invalid {
        path: std::path::PathBuf,
        message: String,
    },
}

/// A point luminaire, in metres.
#[derive(Debug, Clone)]
pub struct Luminaire {
    pub id: String,
    pub position: DVec3,
    /// Unit photometric axis.
    pub aim: DVec3,
    /// Unit direction of C = 0°, perpendicular to `aim`.
    pub c0: DVec3,
    pub distribution: Distribution,
    /// Candela per unit of `distribution.shape`.
    scale: f64,
    /// Total luminous flux, lm.
    pub lumens: f64,
    /// Linear RGB colour with luminance 1 (so lumens stay lumens).
    pub color: Rgb,
    /// Electrical power, W, when known.
    pub watts: Option<f64>,
}

impl Luminaire {
    /// Builds a luminaire. `lumens` None takes the flux from an absolute or rated IES file.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        id: &str,
        position: DVec3,
        aim: DVec3,
        c0: Option<DVec3>,
        distribution: Distribution,
        lumens: Option<f64>,
        color: Rgb,
        watts: Option<f64>,
    ) -> Result<Luminaire, String> {
        let integral = distribution.integral();
        Self::with_integral(
            id,
            position,
            aim,
            c0,
            distribution,
            integral,
            lumens,
            color,
            watts,
        )
    }

    /// Like [`Luminaire::new`], with `integral = distribution.integral()` already known
    /// (luminaires sharing a distribution share it).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn with_integral(
        id: &str,
        position: DVec3,
        aim: DVec3,
        c0: Option<DVec3>,
        distribution: Distribution,
        integral: f64,
        lumens: Option<f64>,
        color: Rgb,
        watts: Option<f64>,
    ) -> Result<Luminaire, String> {
        let aim = aim.try_normalize().ok_or("aim must be a non-zero vector")?;
        let c0 = match c0 {
            Some(c) => (c - aim * c.dot(aim))
                .try_normalize()
                .ok_or("c0 must not be parallel to aim")?,
            None => {
                // Default: world X projected, or Z when aiming along X.
                let guess = if aim.x.abs() < 0.9 {
                    DVec3::X
                } else {
                    DVec3::Z
                };
                (guess - aim * guess.dot(aim)).normalize()
            }
        };
        if !(integral > 0.0 && integral.is_finite()) {
            return Err("the distribution emits no light".into());
        }
        let lumens = match (lumens, &distribution) {
            (Some(l), _) if l.is_finite() && l >= 0.0 => l,
            (Some(l), _) => return Err(format!("lumens = {l}: must be non-negative")),
            // The table is in absolute candela (rated or measured): its integral is the flux.
            (None, Distribution::Table(_)) => integral,
            (None, _) => return Err("lumens is required for isotropic and spot luminaires".into()),
        };
        let y = crate::color::luminance(color);
        if y.is_nan() || y <= 0.0 || color.iter().any(|c| !c.is_finite() || *c < 0.0) {
            return Err("color must be non-negative with a positive luminance".into());
        }
        Ok(Luminaire {
            id: id.to_string(),
            position,
            aim,
            c0,
            distribution,
            scale: lumens / integral,
            lumens,
            color: color.map(|c| c / y),
            watts,
        })
    }

    /// Luminous intensity (cd) towards the unit world direction `d`.
    pub fn intensity(&self, d: DVec3) -> f64 {
        let c90 = self.aim.cross(self.c0);
        self.scale
            * self
                .distribution
                .shape(d.dot(self.aim), d.dot(self.c0), d.dot(c90))
    }

    /// Unoccluded illuminance (lux) at `x` on a receiver facing `n` (unit).
    pub fn illuminance(&self, x: DVec3, n: DVec3) -> f64 {
        let v = x - self.position;
        let d2 = v.length_squared();
        if d2 <= 0.0 {
            return 0.0;
        }
        let d = v / d2.sqrt();
        let cos = -n.dot(d);
        if cos <= 0.0 {
            return 0.0;
        }
        self.intensity(d) * cos / d2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flux_of_known_distributions() {
        // Isotropic: I = Φ / 4π.
        let l = Luminaire::new(
            "a",
            DVec3::ZERO,
            -DVec3::Y,
            None,
            Distribution::Isotropic,
            Some(1000.0),
            [1.0; 3],
            None,
        )
        .unwrap();
        let i = l.intensity(DVec3::X);
        assert!((i - 1000.0 / (4.0 * std::f64::consts::PI)).abs() < 1e-9);
        // A Lambertian downward hemisphere, I = I0 cos γ: Φ = π I0.
        let d = Distribution::Table(Box::new(CandelaTable {
            format: PhotometricFormat::Ies,
            opening: LuminousOpening::Point,
            kind: PhotometricType::C,
            vertical: (0..=90).map(|g| g as f64).collect(),
            horizontal: vec![0.0],
            candela: vec![(0..=90)
                .map(|g| 1000.0 * (g as f64).to_radians().cos())
                .collect()],
            lamp_lumens: None,
            input_watts: 0.0,
        }));
        let phi = d.integral();
        assert!(
            (phi / (std::f64::consts::PI * 1000.0) - 1.0).abs() < 1e-3,
            "{phi}"
        );
    }

    /// Type B orientation: V is the elevation towards c0, H the angle towards aim × c0,
    /// and a table from H = 0 is mirrored.
    #[test]
    fn type_b_tables_follow_the_documented_axes() {
        let text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 2 2 2 0 0 0\n1 1 0\n\
                    -90 0 90\n0 90\n10 1000 20\n30 40 50\n";
        let data = CandelaTable::parse_ies(text).unwrap();
        assert_eq!(data.kind, PhotometricType::B);
        let l = Luminaire::new(
            "b",
            DVec3::ZERO,
            DVec3::X,
            Some(DVec3::Y),
            Distribution::Table(Box::new(data)),
            None,
            [1.0; 3],
            None,
        )
        .unwrap();
        for (d, cd) in [
            (DVec3::X, 1000.0),
            (DVec3::Y, 20.0),
            (-DVec3::Y, 10.0),
            (DVec3::Z, 40.0),
            (-DVec3::Z, 40.0),
        ] {
            assert!(
                (l.intensity(d) - cd).abs() < 1e-6,
                "{d}: {}",
                l.intensity(d)
            );
        }
    }
}
