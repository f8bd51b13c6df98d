//! Point luminaires and their photometry: isotropic, cosine spots, and IES LM-63 files.
//!
//! A luminaire is a point at `position` with a luminous intensity distribution I(ω) in
//! candela, oriented by `aim` (the photometric axis: nadir for type C, the beam axis for
//! spots and type B) and `c0` (the direction of the C = 0° half-plane, perpendicular to the
//! aim). Its direct illuminance at a point x on a receiver with normal n is
//! `E = I(ω) · cos θ / d²` (lux), ω the direction from the luminaire to x.
//!
//! IES LM-63 (1986, 1991, 1995, 2002 and 2019 headers; TILT=NONE or INCLUDE) is parsed
//! here; types C and B are supported:
//! - **Type C**: vertical angle γ from the nadir (0°) to the zenith (180°), horizontal
//!   angle C about the axis from `c0` towards `c90 = aim × c0`. Symmetric files (last C of
//!   0°, 90° or 180°) are unfolded.
//! - **Type B**: the polar axis is the luminaire's lateral axis `r = aim × c0`. The
//!   vertical angle V is the elevation of the plane through that axis, measured from the
//!   aim towards `c0`, and the horizontal angle H is the angle within that plane towards
//!   `r`. A file with H from 0° only is mirrored.

use glam::DVec3;

use crate::color::Rgb;
use crate::limits::*;
use crate::scene::SceneError;

/// Photometric type of an IES file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PhotometricType {
    C,
    B,
}

/// Candela table of an IES file, already multiplied by the candela multiplier and the
/// ballast factors.
#[derive(Debug, Clone)]
pub struct IesData {
    pub kind: PhotometricType,
    /// Vertical angles, degrees, ascending.
    pub vertical: Vec<f64>,
    /// Horizontal angles, degrees, ascending.
    pub horizontal: Vec<f64>,
    /// `candela[h][v]`.
    pub candela: Vec<Vec<f64>>,
    /// Rated lamp lumens (lamps × lumens per lamp); None for absolute photometry (-1).
    pub lamp_lumens: Option<f64>,
    /// Input watts from the file.
    pub input_watts: f64,
}

/// Parses the text of an IES LM-63 file; `path` is the display name errors use. Every
/// rejection is a [`SceneError::Syntax`] naming the line (or [`SceneError::Invalid`] when no
/// line applies). Counts and values are bounded by [`crate::limits`] before anything is
/// allocated for them.
pub fn parse_ies(path: &str, text: &str) -> Result<IesData, SceneError> {
    parse_ies_file(std::path::Path::new(path), text)
}

pub(crate) fn parse_ies_file(path: &std::path::Path, text: &str) -> Result<IesData, SceneError> {
    IesData::parse_lines(text).map_err(|(line, message)| match line {
        Some(line) => SceneError::Syntax {
            path: path.to_path_buf(),
            line,
            message,
        },
        None => SceneError::Invalid {
            path: path.to_path_buf(),
            message,
        },
    })
}

impl IesData {
    /// Parses the text of an LM-63 file. Errors name what is wrong, and the line.
    pub fn parse(text: &str) -> Result<IesData, String> {
        Self::parse_lines(text).map_err(|(line, m)| match line {
            Some(l) => format!("line {l}: {m}"),
            None => m,
        })
    }

    fn parse_lines(text: &str) -> Result<IesData, (Option<usize>, String)> {
        let mut lines = text.lines().enumerate();
        let mut tilt = None;
        for (_, line) in lines.by_ref() {
            let t = line.trim();
            if let Some(rest) = t.strip_prefix("TILT=") {
                tilt = Some(rest.trim().to_string());
                break;
            }
        }
        let tilt = tilt.ok_or((None, "no TILT= line: not an IES LM-63 file".to_string()))?;
        let mut last_line = 0usize;
        let mut nums = lines.flat_map(|(i, l)| {
            l.split(|c: char| c.is_whitespace() || c == ',')
                .filter(|s| !s.is_empty())
                .map(move |s| (i + 1, s))
        });
        let mut next = |what: &str| -> Result<(usize, f64), (Option<usize>, String)> {
            let (line, s) = nums.next().ok_or_else(|| {
                (
                    (last_line > 0).then_some(last_line),
                    format!("file ends before {what}"),
                )
            })?;
            last_line = line;
            let v: f64 = s
                .parse()
                .map_err(|_| (Some(line), format!("'{s}' is not a number ({what})")))?;
            if !v.is_finite() {
                return Err((Some(line), format!("{what} is not finite")));
            }
            Ok((line, v))
        };
        // A value that must lie in lo..=hi.
        let mut field =
            |what: &str, lo: f64, hi: f64| -> Result<(usize, f64), (Option<usize>, String)> {
                let (line, v) = next(what)?;
                if !(lo..=hi).contains(&v) {
                    return Err((
                        Some(line),
                        format!(
                            "{what} = {}: must be in {lo}..={hi:e}",
                            crate::scene::num(v)
                        ),
                    ));
                }
                Ok((line, v))
            };
        let integer =
            |(line, v): (usize, f64), what: &str| -> Result<usize, (Option<usize>, String)> {
                if v.fract() != 0.0 {
                    return Err((Some(line), format!("{what} = {v}: must be a whole number")));
                }
                Ok(v as usize)
            };
        match tilt.as_str() {
            "NONE" => {}
            "INCLUDE" => {
                // Lamp-to-luminaire geometry, then angle/factor pairs: read and ignore
                // (relight does not tilt lamps).
                field("TILT geometry", 1.0, 3.0)?;
                let n = field("TILT pair count", 0.0, MAX_IES_TILT_PAIRS as f64)?;
                let n = integer(n, "TILT pair count")?;
                for _ in 0..2 * n {
                    field("TILT values", -1e6, 1e6)?;
                }
            }
            other => {
                return Err((
                    None,
                    format!(
                        "TILT={other}: separate tilt files are not supported (use NONE or INCLUDE)"
                    ),
                ))
            }
        }
        let (_, lamps) = field("number of lamps", 0.0, MAX_IES_LAMPS)?;
        let (_, lumens_per_lamp) = field("lumens per lamp", -1.0, MAX_LUMENS)?;
        let (mline, multiplier) = field("candela multiplier", 0.0, MAX_IES_MULTIPLIER)?;
        let nv = field("number of vertical angles", 1.0, MAX_IES_ANGLES as f64)?;
        let nv_line = nv.0;
        let nv = integer(nv, "number of vertical angles")?;
        let nh = field("number of horizontal angles", 1.0, MAX_IES_ANGLES as f64)?;
        let nh = integer(nh, "number of horizontal angles")?;
        if nv * nh > MAX_IES_VALUES {
            return Err((
                Some(nv_line),
                format!("{nv} × {nh} candela values; the limit is {MAX_IES_VALUES}"),
            ));
        }
        let ptype = field("photometric type", 1.0, 3.0)?;
        let ptype_line = ptype.0;
        let ptype = integer(ptype, "photometric type")?;
        field("units type", 1.0, 2.0)?;
        field("width", -1e6, 1e6)?;
        field("length", -1e6, 1e6)?;
        field("height", -1e6, 1e6)?;
        let (_, ballast) = field("ballast factor", 0.0, MAX_IES_BALLAST)?;
        let (_, ballast_lamp) = field("ballast-lamp photometric factor", 0.0, MAX_IES_BALLAST)?;
        let (_, input_watts) = field("input watts", 0.0, MAX_WATTS)?;
        let kind = match ptype {
            1 => PhotometricType::C,
            2 => PhotometricType::B,
            _ => {
                return Err((
                    Some(ptype_line),
                    "photometric type A is not supported (use type B or C)".into(),
                ))
            }
        };
        let vertical = (0..nv)
            .map(|_| field("vertical angles", -360.0, 360.0))
            .collect::<Result<Vec<_>, _>>()?;
        let horizontal = (0..nh)
            .map(|_| field("horizontal angles", -360.0, 360.0))
            .collect::<Result<Vec<_>, _>>()?;
        for (name, a) in [("vertical", &vertical), ("horizontal", &horizontal)] {
            if let Some(w) = a.windows(2).find(|w| w[1].1 <= w[0].1) {
                return Err((Some(w[1].0), format!("{name} angles must increase")));
            }
        }
        let vertical: Vec<f64> = vertical.into_iter().map(|x| x.1).collect();
        let horizontal: Vec<f64> = horizontal.into_iter().map(|x| x.1).collect();
        let scale = multiplier * ballast * ballast_lamp;
        if !(scale > 0.0 && scale.is_finite()) {
            return Err((
                Some(mline),
                "candela multiplier × ballast factors must be positive".into(),
            ));
        }
        let mut candela = Vec::with_capacity(nh);
        for _ in 0..nh {
            let mut row = Vec::with_capacity(nv);
            for _ in 0..nv {
                let (line, c) = field("candela values", 0.0, f64::MAX)?;
                let c = c * scale;
                if !(c.is_finite() && c <= MAX_CANDELA) {
                    return Err((
                        Some(line),
                        format!(
                            "candela value {} (after the multiplier) exceeds {MAX_CANDELA:e} cd",
                            crate::scene::num(c)
                        ),
                    ));
                }
                row.push(c);
            }
            candela.push(row);
        }
        let (lo, hi) = match kind {
            PhotometricType::C => ((0.0, 180.0), (0.0, 360.0)),
            PhotometricType::B => ((-90.0, 90.0), (-90.0, 90.0)),
        };
        let t = if kind == PhotometricType::C { "C" } else { "B" };
        if vertical[0] < lo.0 || vertical[nv - 1] > lo.1 {
            return Err((
                None,
                format!("type {t} vertical angles must lie in {}..{}", lo.0, lo.1),
            ));
        }
        if horizontal[0] < hi.0 || horizontal[nh - 1] > hi.1 {
            return Err((
                None,
                format!("type {t} horizontal angles must lie in {}..{}", hi.0, hi.1),
            ));
        }
        Ok(IesData {
            kind,
            vertical,
            horizontal,
            candela,
            lamp_lumens: (lumens_per_lamp > 0.0).then_some(lamps * lumens_per_lamp),
            input_watts,
        })
    }

    /// Candela at vertical angle `v` and horizontal angle `h` (degrees, in the file's own
    /// system), with the file's symmetry unfolded. Zero outside the measured vertical range.
    pub fn candela_at(&self, v: f64, h: f64) -> f64 {
        let (hs, vs) = (&self.horizontal, &self.vertical);
        let h = match self.kind {
            PhotometricType::C => {
                let first = hs[0];
                let last = *hs.last().unwrap_or(&0.0);
                let c = h.rem_euclid(360.0);
                if hs.len() == 1 {
                    first
                } else if first == 0.0 && last == 90.0 {
                    let c = c % 180.0;
                    if c > 90.0 {
                        180.0 - c
                    } else {
                        c
                    }
                } else if first == 0.0 && last == 180.0 {
                    if c > 180.0 {
                        360.0 - c
                    } else {
                        c
                    }
                } else if first == 90.0 && last == 270.0 {
                    if c < 90.0 {
                        180.0 - c
                    } else if c > 270.0 {
                        540.0 - c
                    } else {
                        c
                    }
                } else {
                    c
                }
            }
            PhotometricType::B => {
                if hs[0] >= 0.0 {
                    h.abs()
                } else {
                    h
                }
            }
        };
        if v < vs[0] - 1e-9 || v > vs[vs.len() - 1] + 1e-9 {
            return 0.0;
        }
        let (iv, fv) = bracket(vs, v);
        // Full-circle type C tables wrap from the last plane back to 0°/360°.
        let (ih, fh, wrap) = if self.kind == PhotometricType::C
            && hs.len() > 1
            && h > hs[hs.len() - 1]
            && hs[0] == 0.0
        {
            let span = 360.0 - hs[hs.len() - 1];
            (hs.len() - 1, (h - hs[hs.len() - 1]) / span.max(1e-9), true)
        } else {
            let (i, f) = bracket(hs, h);
            (i, f, false)
        };
        let row = |i: usize| -> f64 {
            let r = &self.candela[i];
            let a = r[iv];
            let b = r[(iv + 1).min(r.len() - 1)];
            a + (b - a) * fv
        };
        let h1 = if wrap { 0 } else { (ih + 1).min(hs.len() - 1) };
        row(ih) * (1.0 - fh) + row(h1) * fh
    }
}

/// Index i and fraction f with `a[i] + f·(a[i+1] − a[i]) = x`, clamped to the ends.
fn bracket(a: &[f64], x: f64) -> (usize, f64) {
    if a.len() == 1 || x <= a[0] {
        return (0, 0.0);
    }
    if x >= a[a.len() - 1] {
        return (a.len() - 1, 0.0);
    }
    let i = a.partition_point(|&v| v <= x) - 1;
    (i, (x - a[i]) / (a[i + 1] - a[i]))
}

/// The shape of a luminous intensity distribution.
#[derive(Debug, Clone)]
pub enum Distribution {
    /// The same intensity in every direction.
    Isotropic,
    /// A cos^m spot around the aim: 50 % of the peak at half the beam angle, zero beyond
    /// half the field angle (degrees, full cone angles).
    Spot { beam_deg: f64, field_deg: f64 },
    /// An IES LM-63 table.
    Ies(Box<IesData>),
}

impl Distribution {
    /// Relative (Ies: absolute) intensity towards a direction given in the luminaire frame
    /// as its components along (aim, c0, c90).
    fn shape(&self, a: f64, c0: f64, c90: f64) -> f64 {
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
            Distribution::Ies(d) => match d.kind {
                PhotometricType::C => {
                    let gamma = a.clamp(-1.0, 1.0).acos().to_degrees();
                    let c = c90.atan2(c0).to_degrees();
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

    /// ∫ shape dΩ over the sphere (lumens for absolute tables). Costs about 260,000
    /// evaluations for spots and tables: compute it once per distinct distribution
    /// (see [`Luminaire::with_integral`]).
    pub fn integral(&self) -> f64 {
        match self {
            Distribution::Isotropic => 4.0 * std::f64::consts::PI,
            _ => {
                // Midpoint rule: 0.25° in θ, 1° in φ, exact enough for tables at 1–5°.
                let (nt, np) = (720, 360);
                let (dt, dp) = (
                    std::f64::consts::PI / nt as f64,
                    2.0 * std::f64::consts::PI / np as f64,
                );
                let mut sum = 0.0;
                for i in 0..nt {
                    let t = (i as f64 + 0.5) * dt;
                    let (st, ct) = t.sin_cos();
                    let mut ring = 0.0;
                    for j in 0..np {
                        let p = (j as f64 + 0.5) * dp;
                        ring += self.shape(ct, st * p.cos(), st * p.sin());
                    }
                    sum += ring * st * dt * dp;
                }
                sum
            }
        }
    }
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
    pub fn with_integral(
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
            (None, Distribution::Ies(_)) => integral,
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

/// Linear sRGB colour of a blackbody at `kelvin` (1000–40000 K), with luminance 1.
///
/// Planck's law integrated against the CIE 1931 2° colour-matching functions (the
/// analytic multi-lobe fit of Wyman, Sloan and Shirley, 2013) at 5 nm, then XYZ → linear
/// sRGB. Negative components (very low CCTs are outside sRGB) are clipped.
pub fn cct_to_rgb(kelvin: f64) -> Rgb {
    let g = |x: f64, mu: f64, s1: f64, s2: f64| {
        let t = (x - mu) / if x < mu { s1 } else { s2 };
        (-0.5 * t * t).exp()
    };
    let (mut xx, mut yy, mut zz) = (0.0, 0.0, 0.0);
    let mut nm = 380.0f64;
    while nm <= 780.0 {
        let l = nm * 1e-9;
        let planck = 1.0 / (l.powi(5) * ((1.438_776_9e-2 / (l * kelvin)).exp() - 1.0));
        let x = 1.056 * g(nm, 599.8, 37.9, 31.0) + 0.362 * g(nm, 442.0, 16.0, 26.7)
            - 0.065 * g(nm, 501.1, 20.4, 26.2);
        let y = 0.821 * g(nm, 568.8, 46.9, 40.5) + 0.286 * g(nm, 530.9, 16.3, 31.1);
        let z = 1.217 * g(nm, 437.0, 11.8, 36.0) + 0.681 * g(nm, 459.0, 26.0, 13.8);
        xx += planck * x;
        yy += planck * y;
        zz += planck * z;
        nm += 5.0;
    }
    let (x, y, z) = (xx / yy, 1.0, zz / yy);
    let r = 3.2406 * x - 1.5372 * y - 0.4986 * z;
    let gg = -0.9689 * x + 1.8758 * y + 0.0415 * z;
    let b = 0.0557 * x - 0.2040 * y + 1.0570 * z;
    let rgb = [r.max(0.0), gg.max(0.0), b.max(0.0)];
    let lum = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    rgb.map(|c| (c / lum) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TYPE_C: &str = "IESNA:LM-63-2002
[TEST] cosine downlight
TILT=NONE
1 1000 1 3 1 1 2 0.1 0.1 0
1 1 20
0 45 90
0
1000 707.1 0
";

    #[test]
    fn parses_and_interpolates_a_type_c_file() {
        let d = IesData::parse(TYPE_C).unwrap();
        assert_eq!(d.kind, PhotometricType::C);
        assert_eq!(d.lamp_lumens, Some(1000.0));
        assert!((d.candela_at(0.0, 123.0) - 1000.0).abs() < 1e-9);
        assert!((d.candela_at(22.5, 0.0) - 853.55).abs() < 1e-9);
        assert_eq!(d.candela_at(120.0, 0.0), 0.0);
    }

    #[test]
    fn bad_files_get_clear_errors() {
        assert!(IesData::parse("hello").unwrap_err().contains("TILT"));
        let e = IesData::parse(&TYPE_C.replace("1000 707.1 0", "1000 x 0")).unwrap_err();
        assert!(e.contains("'x'"), "{e}");
        let e = IesData::parse(&TYPE_C.replace("1000 707.1 0\n", "1000\n")).unwrap_err();
        assert!(e.contains("ends"), "{e}");
        let e = IesData::parse(&TYPE_C.replace("1 1 2 0.1", "1 3 2 0.1")).unwrap_err();
        assert!(e.contains("type A"), "{e}");
    }

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
        let d = Distribution::Ies(Box::new(IesData {
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
        let data = IesData::parse(text).unwrap();
        assert_eq!(data.kind, PhotometricType::B);
        let l = Luminaire::new(
            "b",
            DVec3::ZERO,
            DVec3::X,
            Some(DVec3::Y),
            Distribution::Ies(Box::new(data)),
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

    #[test]
    fn blackbody_colours_have_unit_luminance_and_warm_to_cool_order() {
        let warm = cct_to_rgb(2700.0);
        let d65 = cct_to_rgb(6504.0);
        assert!(warm[0] > warm[2]);
        assert!((luminance_of(warm) - 1.0).abs() < 1e-5);
        // 6504 K is close to the sRGB white point: near-equal channels.
        assert!((d65[0] / d65[2] - 1.0).abs() < 0.12, "{d65:?}");
    }

    fn luminance_of(c: Rgb) -> f32 {
        0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
    }
}
