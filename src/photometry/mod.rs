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
//! - [`glare`]: the CIE Unified Glare Rating and its Guth position index.
//! - [`ugr_table`]: the CIE 190 standard UGR table of a luminaire, as catalogues print it.
//! - `distribution.rs`: the shapes of the distributions and their integrals,
//!   [`Distribution`].
//! - `cct.rs`: blackbody colours from a colour temperature (K).

mod angles;
mod cct;
mod distribution;
pub mod glare;
mod ies;
mod ldt;
mod opening;
mod table;
pub mod ugr_table;

use glam::DVec3;

use crate::color::Rgb;

pub(crate) use cct::cct_to_rgb;
pub use distribution::Distribution;
pub use ies::parse_ies;
pub(crate) use ies::parse_ies_file;
pub use ldt::parse_ldt;
pub(crate) use ldt::parse_ldt_file;
pub use opening::LuminousOpening;
pub use table::{CandelaTable, LampGeometry, PhotometricFormat, PhotometricType, Tilt};

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

impl PhotometryError {
    /// A reader's rejection (the 1-based line when one applies, and the message) in file
    /// `path`.
    pub(crate) fn in_file(
        path: &std::path::Path,
        (line, message): (Option<usize>, String),
    ) -> Self {
        let path = path.to_path_buf();
        match line {
            Some(line) => PhotometryError::Syntax {
                path,
                line,
                message,
            },
            None => PhotometryError::Invalid { path, message },
        }
    }
}

/// A luminaire: a photometric centre at `position` (metres), its distribution, and the
/// luminous opening its file gives (a point when none).
#[derive(Debug, Clone)]
pub struct Luminaire {
    pub id: String,
    pub position: DVec3,
    /// Unit photometric axis.
    pub aim: DVec3,
    /// Unit direction of C = 0°, perpendicular to `aim`.
    pub c0: DVec3,
    pub distribution: Distribution,
    /// The emitting shape, metres, centred on `position` ([`LuminousOpening`]).
    pub opening: LuminousOpening,
    /// Candela per unit of `distribution.shape`.
    scale: f64,
    /// Total luminous flux, lm (with the tilt factor of the file's tilt data).
    pub lumens: f64,
    /// Linear RGB colour with luminance 1 (so lumens stay lumens).
    pub color: Rgb,
    /// Electrical power, W, when known.
    pub watts: Option<f64>,
    /// The multiplying factor of the photometric file's tilt data for this luminaire's
    /// aim ([`Tilt::factor`]); 1 without tilt data.
    pub tilt_factor: f64,
}

/// What a luminaire is built from.
#[derive(Debug, Clone)]
pub struct LuminaireSpec<'a> {
    pub id: &'a str,
    /// Photometric centre, metres.
    pub position: DVec3,
    /// Photometric axis (need not be unit).
    pub aim: DVec3,
    /// Direction of C = 0° (projected perpendicular to the aim); default world X (or Z
    /// when aiming along X).
    pub c0: Option<DVec3>,
    pub distribution: Distribution,
    /// Total flux, lm, at the tilt of the measurement; None takes it from an absolute or
    /// rated candela table. A table's tilt data scales it for the aim.
    pub lumens: Option<f64>,
    pub color: Rgb,
    /// Electrical power, W; None takes the table's input watts (None when the file
    /// gives none, and for isotropic and spot luminaires).
    pub watts: Option<f64>,
}

/// Receivers closer than this many times an opening's largest dimension see it as an area
/// (sampled over the opening); beyond, the point approximation holds (the photometric
/// "five times" rule: its error is below about 1 %).
pub const AREA_DISTANCE_FACTOR: f64 = 5.0;

/// Most sample points over an opening for one receiver point.
pub const MAX_OPENING_SAMPLES: usize = 64;

impl Luminaire {
    /// Builds a luminaire from its spec.
    pub fn new(spec: LuminaireSpec<'_>) -> Result<Luminaire, String> {
        let integral = spec.distribution.integral();
        Self::with_integral(spec, integral)
    }

    /// Like [`Luminaire::new`], with `integral = distribution.integral()` already known
    /// (luminaires sharing a distribution share it).
    pub(crate) fn with_integral(
        spec: LuminaireSpec<'_>,
        integral: f64,
    ) -> Result<Luminaire, String> {
        let LuminaireSpec {
            id,
            position,
            aim,
            c0,
            distribution,
            lumens,
            color,
            watts,
        } = spec;
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
        let y = color.luminance();
        if y.is_nan() || y <= 0.0 || color.iter().any(|c| !c.is_finite() || *c < 0.0) {
            return Err("color must be non-negative with a positive luminance".into());
        }
        let (opening, tilt_factor, file_watts) = match &distribution {
            Distribution::Table(t) => (
                t.opening,
                t.tilt.as_ref().map_or(1.0, |tilt| tilt.factor(aim, c0)),
                t.input_watts,
            ),
            _ => (LuminousOpening::Point, 1.0, None),
        };
        // The candela values hold for the lamp at the tilt of the measurement; the tilt
        // data scales every one of them for the luminaire's aim.
        let lumens = lumens * tilt_factor;
        Ok(Luminaire {
            id: id.to_string(),
            position,
            aim,
            c0,
            distribution,
            opening,
            scale: lumens / integral,
            lumens,
            color: color / y,
            watts: watts.or(file_watts),
            tilt_factor,
        })
    }

    /// Unit direction of C = 90°: `aim × c0`.
    pub fn c90(&self) -> DVec3 {
        self.aim.cross(self.c0)
    }

    /// Luminous intensity (cd) towards the unit world direction `d`.
    pub fn intensity(&self, d: DVec3) -> f64 {
        self.scale
            * self
                .distribution
                .shape(d.dot(self.aim), d.dot(self.c0), d.dot(self.c90()))
    }

    /// Per band of `bands` equal steps of the cosine to the aim (from −1 to 1), the
    /// largest intensity towards a direction in it, cd.
    pub fn peak_intensities(&self, bands: usize) -> Vec<f64> {
        let step = 2.0 / bands as f64;
        (0..bands)
            .map(|k| {
                let lo = -1.0 + k as f64 * step;
                self.scale * self.distribution.peak_between(lo, lo + step)
            })
            .collect()
    }

    /// Unoccluded illuminance (lux) at `x` on a receiver facing `n` (unit), from the
    /// whole luminaire (sampled over its opening when `x` is near).
    pub fn illuminance(&self, x: DVec3, n: DVec3) -> f64 {
        let mut e = 0.0;
        self.for_each_emitter(x, |p, w| e += w * self.illuminance_from(p, x, n));
        e
    }

    /// Unoccluded illuminance (lux) at `x` (normal `n`) from the whole distribution
    /// placed at `p`.
    pub fn illuminance_from(&self, p: DVec3, x: DVec3, n: DVec3) -> f64 {
        let v = x - p;
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

    /// Calls `f(point, weight)` for the points that stand for the luminaire as seen from a
    /// receiver at `x`, weights summing to 1: the photometric centre alone when `x` is
    /// farther than [`AREA_DISTANCE_FACTOR`] × the opening's largest dimension, else a
    /// midpoint grid over the opening (the flat face of a rectangle or disk, or a
    /// sphere's cross-section facing `x`) with cells at most a sixth of the distance from
    /// `x` to the opening, at most 16 along a side and [`MAX_OPENING_SAMPLES`] in all. Each point carries the whole distribution, so a
    /// Lambertian opening gives the configuration-factor illuminance in the limit.
    pub fn for_each_emitter(&self, x: DVec3, mut f: impl FnMut(DVec3, f64)) {
        let size = self.opening.largest_dimension();
        let dist = (x - self.position).length();
        if size <= 0.0 || dist >= AREA_DISTANCE_FACTOR * size {
            f(self.position, 1.0);
            return;
        }
        let (u_axis, v_axis, lu, lv, round) = match self.opening {
            LuminousOpening::Point => return f(self.position, 1.0),
            LuminousOpening::Rectangle {
                along_c0,
                along_c90,
                ..
            } => (self.c0, self.c90(), along_c0, along_c90, false),
            LuminousOpening::Disk {
                along_c0,
                along_c90,
                ..
            } => (self.c0, self.c90(), along_c0, along_c90, true),
            LuminousOpening::Sphere {
                along_c0,
                along_c90,
                ..
            } => {
                // The cross-section facing the receiver.
                let w = (x - self.position).normalize_or(self.aim);
                let (u, v) = crate::geometry::frame(w);
                (u, v, along_c0, along_c90, true)
            }
        };
        // The midpoint rule's error grows with (cell / distance)²: cells of at most a sixth
        // of the distance to the opening's nearest point keep it near 1 % but at grazing
        // angles.
        let local = x - self.position;
        let (du, dv) = (local.dot(u_axis), local.dot(v_axis));
        let gap_u = (du.abs() - 0.5 * lu).max(0.0);
        let gap_v = (dv.abs() - 0.5 * lv).max(0.0);
        let off = (local - u_axis * du - v_axis * dv).length();
        let near = (gap_u * gap_u + gap_v * gap_v + off * off).sqrt().max(1e-6);
        let per = |len: f64| ((6.0 * len / near).ceil() as usize).clamp(1, 16);
        let (mut nu, mut nv) = (per(lu), per(lv));
        while nu * nv > MAX_OPENING_SAMPLES {
            if nu >= nv {
                nu -= 1
            } else {
                nv -= 1
            }
        }
        let mut pts = [(0.0, 0.0); MAX_OPENING_SAMPLES];
        let mut k = 0;
        for i in 0..nu {
            for j in 0..nv {
                let a = (i as f64 + 0.5) / nu as f64 - 0.5;
                let b = (j as f64 + 0.5) / nv as f64 - 0.5;
                if !round || a * a + b * b <= 0.25 {
                    pts[k] = (a, b);
                    k += 1;
                }
            }
        }
        if k == 0 {
            f(self.position, 1.0);
            return;
        }
        let w = 1.0 / k as f64;
        for &(a, b) in &pts[..k] {
            f(self.position + u_axis * (a * lu) + v_axis * (b * lv), w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flux_of_known_distributions() {
        // Isotropic: I = Φ / 4π.
        let l = Luminaire::new(LuminaireSpec {
            id: "a",
            position: DVec3::ZERO,
            aim: -DVec3::Y,
            c0: None,
            distribution: Distribution::Isotropic,
            lumens: Some(1000.0),
            color: Rgb::ONE,
            watts: None,
        })
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
            input_watts: None,
            tilt: None,
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
        let l = Luminaire::new(LuminaireSpec {
            id: "b",
            position: DVec3::ZERO,
            aim: DVec3::X,
            c0: Some(DVec3::Y),
            distribution: Distribution::Table(Box::new(data)),
            lumens: None,
            color: Rgb::ONE,
            watts: None,
        })
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

    /// The band peaks bound the intensity in every direction of their band, and are
    /// reached: on the bundled IES files (type C, quadrant and full tables), a cone and
    /// a spot, over 200,000 random directions each.
    #[test]
    fn peak_intensities_bound_every_direction_of_their_band() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut dists = vec![
            Distribution::Cone {
                inner_deg: 20.0,
                outer_deg: 35.0,
            },
            Distribution::Spot {
                beam_deg: 30.0,
                field_deg: 60.0,
            },
        ];
        for f in [
            "scenes/office-floor/downlight.ies",
            "scenes/office-floor/panel.ies",
        ] {
            let text = std::fs::read_to_string(root.join(f)).unwrap();
            dists.push(Distribution::Table(Box::new(
                crate::photometry::ies::parse_ies(f, &text).unwrap(),
            )));
        }
        let mut rng = crate::sampling::Rng::new(4, 5);
        for distribution in dists {
            let l = Luminaire::new(LuminaireSpec {
                id: "l",
                position: DVec3::ZERO,
                aim: DVec3::new(0.3, -1.0, 0.1),
                c0: None,
                distribution,
                lumens: Some(1000.0),
                color: Rgb::ONE,
                watts: None,
            })
            .unwrap();
            let bands = 64;
            let peak = l.peak_intensities(bands);
            let mut seen = vec![0f64; bands];
            for _ in 0..200_000 {
                let z = 2.0 * rng.next_f64() - 1.0;
                let phi = std::f64::consts::TAU * rng.next_f64();
                let r = (1.0 - z * z).sqrt();
                let d = DVec3::new(r * phi.cos(), z, r * phi.sin());
                let band = (((d.dot(l.aim) + 1.0) * 0.5 * bands as f64) as usize).min(bands - 1);
                let i = l.intensity(d);
                assert!(
                    i <= peak[band] * (1.0 + 1e-9),
                    "{i} cd above the band's {}",
                    peak[band]
                );
                seen[band] = seen[band].max(i);
            }
            // Reached: random directions come within 5 % of each band's peak.
            let top = peak.iter().copied().fold(0.0, f64::max);
            for (p, s) in peak.iter().zip(&seen) {
                assert!(*s >= 0.95 * p - 1e-3 * top, "seen {s} of a peak {p}");
            }
        }
    }

    /// A luminaire of a uniform 1000 cd table with `tilt`, aimed along `aim` with `c0`.
    fn tilted(tilt: Tilt, aim: DVec3, c0: DVec3, watts: Option<f64>) -> Luminaire {
        let table = CandelaTable {
            format: PhotometricFormat::Ies,
            opening: LuminousOpening::Point,
            kind: PhotometricType::C,
            vertical: vec![0.0, 180.0],
            horizontal: vec![0.0],
            candela: vec![vec![1000.0, 1000.0]],
            lamp_lumens: None,
            input_watts: Some(250.0),
            tilt: Some(tilt),
        };
        Luminaire::new(LuminaireSpec {
            id: "t",
            position: DVec3::ZERO,
            aim,
            c0: Some(c0),
            distribution: Distribution::Table(Box::new(table)),
            lumens: None,
            color: Rgb::ONE,
            watts,
        })
        .unwrap()
    }

    /// The tilt factor for the aim scales every intensity and the flux; the file's watts
    /// are the default power, a given one wins.
    #[test]
    fn tilt_data_scale_the_luminaire_for_its_aim() {
        let tilt = |geometry| Tilt {
            geometry,
            angles: vec![0.0, 30.0, 60.0, 90.0],
            factors: vec![1.0, 0.8, 0.5, 0.4],
        };
        let flux = 4.0 * std::f64::consts::PI * 1000.0;
        let at = |deg: f64| {
            let (s, c) = deg.to_radians().sin_cos();
            DVec3::new(s, -c, 0.0)
        };
        // Lamp vertical: the aim's angle from straight down, folded past 90° (the table
        // stops at 90°: base up reads as base down).
        for (deg, factor) in [
            (0.0, 1.0),
            (30.0, 0.8),
            (45.0, 0.65),
            (60.0, 0.5),
            (120.0, 0.5),
        ] {
            let l = tilted(tilt(LampGeometry::Vertical), at(deg), DVec3::Z, None);
            assert!(
                (l.tilt_factor - factor).abs() < 1e-9,
                "{deg}°: {}",
                l.tilt_factor
            );
            assert!((l.intensity(DVec3::X) - 1000.0 * factor).abs() < 1e-6);
            assert!((l.lumens / flux - factor).abs() < 1e-3, "{}", l.lumens);
            assert_eq!(l.watts, Some(250.0));
        }
        // Lamp horizontal and staying so: the same angle.
        let l = tilted(
            tilt(LampGeometry::HorizontalStays),
            at(60.0),
            DVec3::Z,
            None,
        );
        assert!((l.tilt_factor - 0.5).abs() < 1e-9);
        // Lamp horizontal along c0, tilting with the luminaire: aimed 60° within its
        // C0–C180 plane the lamp tilts 60°; turned 60° about c0 it stays level.
        let along = tilted(
            tilt(LampGeometry::HorizontalTilts),
            at(60.0),
            at(150.0),
            None,
        );
        assert!(
            (along.tilt_factor - 0.5).abs() < 1e-9,
            "{}",
            along.tilt_factor
        );
        let across = tilted(
            tilt(LampGeometry::HorizontalTilts),
            at(60.0),
            DVec3::Z,
            None,
        );
        assert!(
            (across.tilt_factor - 1.0).abs() < 1e-9,
            "{}",
            across.tilt_factor
        );
        // A given wattage wins over the file's.
        let l = tilted(tilt(LampGeometry::Vertical), at(0.0), DVec3::Z, Some(400.0));
        assert_eq!(l.watts, Some(400.0));
    }
}
