//! A candela table, as photometric files give it: luminous intensity (cd) on a grid of
//! vertical and horizontal angles (degrees), with the file's symmetry unfolded on lookup.
//! Both readers, IES LM-63 ([`super::ies`]) and EULUMDAT ([`super::ldt`]), produce one, so
//! everything downstream (the distribution, its flux, direct light, glare) is shared.
//!
//! - **Type C**: vertical angle γ from the nadir (0°) to the zenith (180°), horizontal
//!   angle C about the axis from `c0` towards `c90 = aim × c0`. Tables whose last C is
//!   0°, 90° or 180° (or which span 90°..270°) are unfolded by symmetry.
//! - **Type B**: the polar axis is the luminaire's lateral axis `r = aim × c0`. The
//!   vertical angle V is the elevation of the plane through that axis, measured from the
//!   aim towards `c0`, and the horizontal angle H is the angle within that plane towards
//!   `r`. A table with H from 0° only is mirrored.

use super::LuminousOpening;
use crate::input_limits::{num, MAX_CANDELA};

/// A reader's rejection: the 1-based line when one applies, and the message.
pub(super) type ParseError = (Option<usize>, String);

/// `rows` rows of `cols` values, each taken from `next` (a value ≥ 0 and its line), times
/// `scale`: candela, each at most [`MAX_CANDELA`].
pub(super) fn scaled_rows(
    rows: usize,
    cols: usize,
    scale: f64,
    mut next: impl FnMut() -> Result<(usize, f64), ParseError>,
) -> Result<Vec<Vec<f64>>, ParseError> {
    let mut out = Vec::with_capacity(rows);
    for _ in 0..rows {
        let mut row = Vec::with_capacity(cols);
        for _ in 0..cols {
            let (line, v) = next()?;
            let cd = v * scale;
            if !(cd.is_finite() && cd <= MAX_CANDELA) {
                return Err((
                    Some(line),
                    format!(
                        "candela value {} (after scaling) exceeds {MAX_CANDELA:e} cd",
                        num(cd)
                    ),
                ));
            }
            row.push(cd);
        }
        out.push(row);
    }
    Ok(out)
}

/// Photometric type of a candela table (type A is not supported).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PhotometricType {
    C,
    B,
}

/// The file format a table was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PhotometricFormat {
    /// IES LM-63 (`.ies`).
    Ies,
    /// EULUMDAT (`.ldt`).
    Eulumdat,
}

/// A candela table in absolute candela: an IES file's values times its candela multiplier
/// and ballast factors, or an EULUMDAT file's cd/klm times its lamp flux / 1000.
#[derive(Debug, Clone)]
pub struct CandelaTable {
    pub format: PhotometricFormat,
    pub kind: PhotometricType,
    /// Vertical angles, degrees, ascending.
    pub vertical: Vec<f64>,
    /// Horizontal angles, degrees, ascending.
    pub horizontal: Vec<f64>,
    /// `candela[h][v]`.
    pub candela: Vec<Vec<f64>>,
    /// Rated lamp lumens (IES: lamps × lumens per lamp; EULUMDAT: the lamp set's total
    /// flux); None for absolute photometry.
    pub lamp_lumens: Option<f64>,
    /// The luminaire's electrical power as the file gives it, W: an IES file's input
    /// watts, an EULUMDAT lamp set's wattage including ballast. None when the file gives
    /// 0 (unknown).
    pub input_watts: Option<f64>,
    /// The luminous opening, metres, in the luminaire frame.
    pub opening: LuminousOpening,
    /// An IES file's `TILT=INCLUDE` data: how the lamp's output changes as the luminaire
    /// tilts. None for `TILT=NONE` and EULUMDAT files.
    pub tilt: Option<Tilt>,
}

/// How the lamp sits in the luminaire, as an IES file's tilt data names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LampGeometry {
    /// 1: the lamp is vertical (base up or base down) when the luminaire is aimed straight
    /// down, and tilts as the luminaire tilts.
    Vertical,
    /// 2: the lamp is horizontal and stays horizontal as the luminaire tilts (it turns
    /// about its own axis).
    HorizontalStays,
    /// 3: the lamp is horizontal and tilts with the luminaire.
    HorizontalTilts,
}

/// An IES file's tilt data (`TILT=INCLUDE`): multiplying factors for all candela values
/// at tilt angles (degrees) of the luminaire, for the lamp geometry the file names.
///
/// The candela values are those of the lamp at the tilt of the measurement (the
/// luminaire aimed straight down; the factor there is usually 1). [`Tilt::factor`]
/// gives the factor for a luminaire as the scene mounts it:
///
/// - **Geometry 1** (lamp vertical) and **2** (lamp horizontal, staying horizontal): the
///   angle is the luminaire's tilt, the angle between its photometric axis (`aim`) and
///   straight down, 0°–180°. When the table stops at or below 90°, a tilt past 90° is
///   read as 180° minus it (a lamp base up and base down alike).
/// - **Geometry 3** (lamp horizontal, tilting with the luminaire): the lamp is taken to lie
///   along the C0–C180 axis (`c0`, the luminaire's length axis); the angle is that axis'
///   elevation above the horizontal, 0°–90°. Aiming the luminaire within its C0–C180
///   plane tilts the lamp by the whole aim tilt; turning it about the C0–C180 axis leaves
///   the lamp horizontal. The files do not say along which luminaire axis the lamp lies.
///
/// Between the tabulated angles the factor is interpolated linearly; beyond them it is
/// the factor at the nearest end.
#[derive(Debug, Clone, PartialEq)]
pub struct Tilt {
    pub geometry: LampGeometry,
    /// Tilt angles, degrees, strictly increasing, within 0..=180.
    pub angles: Vec<f64>,
    /// Multiplying factor at each angle (≥ 0).
    pub factors: Vec<f64>,
}

impl Tilt {
    /// The multiplying factor for a luminaire aimed along unit `aim` with unit `c0` (world
    /// frame, +Y up).
    pub fn factor(&self, aim: glam::DVec3, c0: glam::DVec3) -> f64 {
        self.factor_at(self.angle(aim, c0))
    }

    /// The tilt angle (degrees) the table is read at for a luminaire aimed along unit
    /// `aim` with unit `c0` (world frame, +Y up).
    pub fn angle(&self, aim: glam::DVec3, c0: glam::DVec3) -> f64 {
        match self.geometry {
            LampGeometry::Vertical | LampGeometry::HorizontalStays => {
                let t = (-aim.y).clamp(-1.0, 1.0).acos().to_degrees();
                let last = self.angles.last().copied().unwrap_or(0.0);
                if last <= 90.0 && t > 90.0 {
                    180.0 - t
                } else {
                    t
                }
            }
            // The elevation of the lamp axis (c0) above the horizontal.
            LampGeometry::HorizontalTilts => c0.y.abs().min(1.0).asin().to_degrees(),
        }
    }

    /// The factor at tilt angle `angle` (degrees): linear between the tabulated angles,
    /// the end factors beyond them.
    pub fn factor_at(&self, angle: f64) -> f64 {
        let (a, f) = (&self.angles, &self.factors);
        if a.is_empty() {
            return 1.0;
        }
        let (i, t) = bracket(a, angle);
        let next = (i + 1).min(f.len() - 1);
        f[i] + (f[next] - f[i]) * t
    }
}

impl CandelaTable {
    /// Horizontal angle `h` (degrees) mapped into the measured range by the file's
    /// symmetry: quadrant and bilateral type C files, mirrored type B files.
    fn unfold_horizontal(&self, h: f64) -> f64 {
        let hs = &self.horizontal;
        match self.kind {
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
        }
    }

    /// Candela at vertical angle `v` and horizontal angle `h` (degrees, in the file's own
    /// system), with the file's symmetry unfolded. Zero outside the measured vertical range.
    pub fn candela_at(&self, v: f64, h: f64) -> f64 {
        let (hs, vs) = (&self.horizontal, &self.vertical);
        let h = self.unfold_horizontal(h);
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
