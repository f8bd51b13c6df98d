//! The IES LM-63 reader (1986, 1991, 1995, 2002 and 2019 headers; TILT=NONE or INCLUDE),
//! photometric types C and B, into a [`CandelaTable`].
//!
//! The luminous opening (width, length, height; feet or metres by the units type) follows
//! LM-63-2002's sign conventions: length along the 0°–180° axis, width along 90°–270°,
//! negative values for round shapes ([`LuminousOpening::from_ies`]).
//!
//! Angles are in degrees, intensities in candela (cd), flux in lumens (lm), power in watts.

use super::table::{scaled_rows, CandelaTable, ParseError, PhotometricFormat, PhotometricType};
use super::{LuminousOpening, PhotometryError};
use crate::input_limits::*;

/// Parses the text of an IES LM-63 file; `path` is the display name errors use. Every
/// rejection is a [`PhotometryError::Syntax`] naming the line (or [`PhotometryError::Invalid`]
/// when no line applies). Counts and values are bounded by [`crate::input_limits`] before anything is
/// allocated for them.
pub fn parse_ies(path: &str, text: &str) -> Result<CandelaTable, PhotometryError> {
    parse_ies_file(std::path::Path::new(path), text)
}

pub(crate) fn parse_ies_file(
    path: &std::path::Path,
    text: &str,
) -> Result<CandelaTable, PhotometryError> {
    CandelaTable::parse_ies_lines(text).map_err(|e| PhotometryError::in_file(path, e))
}

/// The numbers after the `TILT=` line, in order, each with its 1-based line.
struct Numbers<I> {
    tokens: I,
    /// Line of the last number taken (0 before the first).
    last_line: usize,
}

impl<'a, I: Iterator<Item = (usize, &'a str)>> Numbers<I> {
    /// The next number (finite), and its line; `what` names it in errors.
    fn next(&mut self, what: &str) -> Result<(usize, f64), ParseError> {
        let (line, s) = self.tokens.next().ok_or_else(|| {
            (
                (self.last_line > 0).then_some(self.last_line),
                format!("file ends before {what}"),
            )
        })?;
        self.last_line = line;
        let v: f64 = s
            .parse()
            .map_err(|_| (Some(line), format!("'{s}' is not a number ({what})")))?;
        if !v.is_finite() {
            return Err((Some(line), format!("{what} is not finite")));
        }
        Ok((line, v))
    }

    /// The next number, which must lie in `lo..=hi`.
    fn field(&mut self, what: &str, lo: f64, hi: f64) -> Result<(usize, f64), ParseError> {
        let (line, v) = self.next(what)?;
        if !(lo..=hi).contains(&v) {
            return Err((
                Some(line),
                format!("{what} = {}: must be in {lo}..={hi:e}", num(v)),
            ));
        }
        Ok((line, v))
    }

    /// The next number in `lo..=hi`, which must be whole.
    fn count(&mut self, what: &str, lo: f64, hi: f64) -> Result<(usize, usize), ParseError> {
        let (line, v) = self.field(what, lo, hi)?;
        if v.fract() != 0.0 {
            return Err((Some(line), format!("{what} = {v}: must be a whole number")));
        }
        Ok((line, v as usize))
    }
}

/// The numeric header after the tilt data.
struct Header {
    lamps: f64,
    lumens_per_lamp: f64,
    /// Line of the candela multiplier.
    multiplier_line: usize,
    /// Candela multiplier × ballast factor × ballast-lamp photometric factor.
    scale: f64,
    nv: usize,
    nh: usize,
    kind: PhotometricType,
    input_watts: f64,
    opening: LuminousOpening,
}

impl CandelaTable {
    /// Parses the text of an LM-63 file. Errors name what is wrong, and the line.
    pub fn parse_ies(text: &str) -> Result<CandelaTable, String> {
        Self::parse_ies_lines(text).map_err(|(line, m)| match line {
            Some(l) => format!("line {l}: {m}"),
            None => m,
        })
    }

    fn parse_ies_lines(text: &str) -> Result<CandelaTable, ParseError> {
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
        let mut nums = Numbers {
            tokens: lines.flat_map(|(i, l)| {
                l.split(|c: char| c.is_whitespace() || c == ',')
                    .filter(|s| !s.is_empty())
                    .map(move |s| (i + 1, s))
            }),
            last_line: 0,
        };
        skip_tilt(&tilt, &mut nums)?;
        let h = read_header(&mut nums)?;
        let (vertical, horizontal) = read_angles(&mut nums, h.nv, h.nh)?;
        if !(h.scale > 0.0 && h.scale.is_finite()) {
            return Err((
                Some(h.multiplier_line),
                "candela multiplier × ballast factors must be positive".into(),
            ));
        }
        let candela = scaled_rows(h.nh, h.nv, h.scale, || {
            nums.field("candela values", 0.0, f64::MAX)
        })?;
        check_angle_ranges(h.kind, &vertical, &horizontal)?;
        Ok(CandelaTable {
            format: PhotometricFormat::Ies,
            kind: h.kind,
            vertical,
            horizontal,
            candela,
            lamp_lumens: (h.lumens_per_lamp > 0.0).then_some(h.lamps * h.lumens_per_lamp),
            input_watts: h.input_watts,
            opening: h.opening,
        })
    }
}

/// Reads past the tilt data of `TILT=INCLUDE` (relight does not tilt lamps); refuses
/// separate tilt files.
fn skip_tilt<'a, I: Iterator<Item = (usize, &'a str)>>(
    tilt: &str,
    nums: &mut Numbers<I>,
) -> Result<(), ParseError> {
    match tilt {
        "NONE" => Ok(()),
        "INCLUDE" => {
            // Lamp-to-luminaire geometry, then angle/factor pairs: read and ignore.
            nums.field("TILT geometry", 1.0, 3.0)?;
            let (_, n) = nums.count("TILT pair count", 0.0, MAX_IES_TILT_PAIRS as f64)?;
            for _ in 0..2 * n {
                nums.field("TILT values", -1e6, 1e6)?;
            }
            Ok(())
        }
        other => Err((
            None,
            format!("TILT={other}: separate tilt files are not supported (use NONE or INCLUDE)"),
        )),
    }
}

/// The ten numbers of the lamp line and the three of the ballast line, each range-checked
/// (the table size against [`MAX_IES_VALUES`]).
fn read_header<'a, I: Iterator<Item = (usize, &'a str)>>(
    nums: &mut Numbers<I>,
) -> Result<Header, ParseError> {
    let (_, lamps) = nums.field("number of lamps", 0.0, MAX_IES_LAMPS)?;
    let (_, lumens_per_lamp) = nums.field("lumens per lamp", -1.0, MAX_LUMENS)?;
    let (multiplier_line, multiplier) =
        nums.field("candela multiplier", 0.0, MAX_IES_MULTIPLIER)?;
    let (nv_line, nv) = nums.count("number of vertical angles", 1.0, MAX_IES_ANGLES as f64)?;
    let (_, nh) = nums.count("number of horizontal angles", 1.0, MAX_IES_ANGLES as f64)?;
    if nv * nh > MAX_IES_VALUES {
        return Err((
            Some(nv_line),
            format!("{nv} × {nh} candela values; the limit is {MAX_IES_VALUES}"),
        ));
    }
    let (ptype_line, ptype) = nums.count("photometric type", 1.0, 3.0)?;
    let (_, units) = nums.count("units type", 1.0, 2.0)?;
    let feet = if units == 1 { 0.3048 } else { 1.0 };
    let (_, width) = nums.field("width", -MAX_OPENING, MAX_OPENING)?;
    let (_, length) = nums.field("length", -MAX_OPENING, MAX_OPENING)?;
    let (height_line, height) = nums.field("height", -MAX_OPENING, MAX_OPENING)?;
    let opening = LuminousOpening::from_ies(width * feet, length * feet, height * feet)
        .map_err(|m| (Some(height_line), m))?;
    let (_, ballast) = nums.field("ballast factor", 0.0, MAX_IES_BALLAST)?;
    let (_, ballast_lamp) = nums.field("ballast-lamp photometric factor", 0.0, MAX_IES_BALLAST)?;
    let (_, input_watts) = nums.field("input watts", 0.0, MAX_WATTS)?;
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
    Ok(Header {
        lamps,
        lumens_per_lamp,
        multiplier_line,
        scale: multiplier * ballast * ballast_lamp,
        nv,
        nh,
        kind,
        input_watts,
        opening,
    })
}

/// The vertical and horizontal angles (degrees), each list strictly increasing.
fn read_angles<'a, I: Iterator<Item = (usize, &'a str)>>(
    nums: &mut Numbers<I>,
    nv: usize,
    nh: usize,
) -> Result<(Vec<f64>, Vec<f64>), ParseError> {
    let vertical = (0..nv)
        .map(|_| nums.field("vertical angles", -360.0, 360.0))
        .collect::<Result<Vec<_>, _>>()?;
    let horizontal = (0..nh)
        .map(|_| nums.field("horizontal angles", -360.0, 360.0))
        .collect::<Result<Vec<_>, _>>()?;
    for (name, a) in [("vertical", &vertical), ("horizontal", &horizontal)] {
        if let Some(w) = a.windows(2).find(|w| w[1].1 <= w[0].1) {
            return Err((Some(w[1].0), format!("{name} angles must increase")));
        }
    }
    let vertical: Vec<f64> = vertical.into_iter().map(|x| x.1).collect();
    let horizontal: Vec<f64> = horizontal.into_iter().map(|x| x.1).collect();
    Ok((vertical, horizontal))
}

/// The angles must lie in the ranges of the photometric type (degrees).
fn check_angle_ranges(
    kind: PhotometricType,
    vertical: &[f64],
    horizontal: &[f64],
) -> Result<(), ParseError> {
    let (lo, hi) = match kind {
        PhotometricType::C => ((0.0, 180.0), (0.0, 360.0)),
        PhotometricType::B => ((-90.0, 90.0), (-90.0, 90.0)),
    };
    let t = if kind == PhotometricType::C { "C" } else { "B" };
    let (nv, nh) = (vertical.len(), horizontal.len());
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
    Ok(())
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
        let d = CandelaTable::parse_ies(TYPE_C).unwrap();
        assert_eq!(d.kind, PhotometricType::C);
        assert_eq!(d.lamp_lumens, Some(1000.0));
        assert!((d.candela_at(0.0, 123.0) - 1000.0).abs() < 1e-9);
        assert!((d.candela_at(22.5, 0.0) - 853.55).abs() < 1e-9);
        assert_eq!(d.candela_at(120.0, 0.0), 0.0);
    }

    #[test]
    fn bad_files_get_clear_errors() {
        assert!(CandelaTable::parse_ies("hello")
            .unwrap_err()
            .contains("TILT"));
        let e = CandelaTable::parse_ies(&TYPE_C.replace("1000 707.1 0", "1000 x 0")).unwrap_err();
        assert!(e.contains("'x'"), "{e}");
        let e = CandelaTable::parse_ies(&TYPE_C.replace("1000 707.1 0\n", "1000\n")).unwrap_err();
        assert!(e.contains("ends"), "{e}");
        let e = CandelaTable::parse_ies(&TYPE_C.replace("1 1 2 0.1", "1 3 2 0.1")).unwrap_err();
        assert!(e.contains("type A"), "{e}");
    }
}
