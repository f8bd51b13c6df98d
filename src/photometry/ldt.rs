//! The EULUMDAT reader (`.ldt`, Stockmar 1990/1998) into a [`CandelaTable`] of type C.
//!
//! The file is line-oriented: a header of 26 fixed lines (numbers may use a decimal
//! comma), then per lamp set six lines (number of lamps, type, total flux in lm, colour,
//! colour rendering, watts with ballast), ten direct ratios, the `Mc` C-plane angles, the
//! `Ng` γ angles, and the intensities in cd per 1000 lm of lamp flux, one per line, for
//! the C planes the symmetry indicator `Isym` keeps:
//!
//! | Isym | meaning | planes stored |
//! |---|---|---|
//! | 0 | no symmetry | all `Mc`, C = 0° … |
//! | 1 | about the vertical axis | one |
//! | 2 | to the C0–C180 plane | C0 … C180 (`Mc/2 + 1`) |
//! | 3 | to the C90–C270 plane | C90 … C270 (`Mc/2 + 1`) |
//! | 4 | to both | C0 … C90 (`Mc/4 + 1`) |
//!
//! Absolute intensity is `I · Φ / 1000 · CFLI`: Φ the chosen lamp set's total flux (its
//! absolute value: some writers mark absolute photometry by a negative lamp count), CFLI
//! the file's conversion factor. C and γ are the same angles as an IES type C file's
//! horizontal and vertical angles, so an LDT and its IES twin give one table.
//!
//! Every count is bounded by [`crate::input_limits`] before anything is allocated, and
//! every rejection names the 1-based line.

use super::table::{scaled_rows, CandelaTable, ParseError, PhotometricFormat, PhotometricType};
use super::{LuminousOpening, PhotometryError};
use crate::input_limits::*;

/// Parses the text of an EULUMDAT file, scaled by lamp set `lamp_set` (1-based; the
/// first when None). `path` is the display name errors use.
pub fn parse_ldt(
    path: &str,
    text: &str,
    lamp_set: Option<usize>,
) -> Result<CandelaTable, PhotometryError> {
    parse_ldt_file(std::path::Path::new(path), text, lamp_set)
}

pub(crate) fn parse_ldt_file(
    path: &std::path::Path,
    text: &str,
    lamp_set: Option<usize>,
) -> Result<CandelaTable, PhotometryError> {
    parse(text, lamp_set).map_err(|e| PhotometryError::in_file(path, e))
}

/// The lines of the file, each with its 1-based number.
struct Lines<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    /// Number of the last line taken (0 before the first).
    last: usize,
}

impl<'a> Lines<'a> {
    /// The next line, whatever it holds.
    fn text(&mut self, what: &str) -> Result<(usize, &'a str), ParseError> {
        let (i, l) = self.lines.next().ok_or_else(|| {
            (
                (self.last > 0).then_some(self.last),
                format!("file ends before {what}"),
            )
        })?;
        self.last = i + 1;
        Ok((i + 1, l.trim()))
    }

    /// The next line as a finite number in `lo..=hi` (a decimal comma is accepted).
    fn number(&mut self, what: &str, lo: f64, hi: f64) -> Result<(usize, f64), ParseError> {
        let (line, s) = self.text(what)?;
        let v: f64 = s
            .replace(',', ".")
            .parse()
            .map_err(|_| (Some(line), format!("'{s}' is not a number ({what})")))?;
        if !v.is_finite() || !(lo..=hi).contains(&v) {
            return Err((
                Some(line),
                format!("{what} = {}: must be in {lo}..={hi:e}", num(v)),
            ));
        }
        Ok((line, v))
    }

    /// The next line as a whole number in `lo..=hi`.
    fn count(&mut self, what: &str, lo: usize, hi: usize) -> Result<(usize, usize), ParseError> {
        let (line, v) = self.number(what, lo as f64, hi as f64)?;
        if v.fract() != 0.0 {
            return Err((Some(line), format!("{what} = {v}: must be a whole number")));
        }
        Ok((line, v as usize))
    }
}

/// One lamp set: total flux (lm) and wattage with ballast (W).
#[derive(Clone, Copy)]
struct LampSet {
    flux: f64,
    watts: f64,
}

fn parse(text: &str, lamp_set: Option<usize>) -> Result<CandelaTable, ParseError> {
    let mut l = Lines {
        lines: text.lines().enumerate(),
        last: 0,
    };
    l.text("the company identification")?;
    l.count("type indicator Ityp", 0, 3)?;
    let (isym_line, isym) = l.count("symmetry indicator Isym", 0, 4)?;
    let (mc_line, mc) = l.count("number of C planes Mc", 1, MAX_LDT_PLANES)?;
    l.number("distance between C planes Dc", 0.0, 360.0)?;
    let (_, ng) = l.count("number of intensities per plane Ng", 1, MAX_LDT_ANGLES)?;
    l.number("distance between γ angles Dg", 0.0, 180.0)?;
    let opening = luminaire(&mut l)?;
    l.number("downward flux fraction DFF", 0.0, 100.0)?;
    l.number("light output ratio LORL", 0.0, 100.0)?;
    let (cfli_line, cfli) = l.number("conversion factor CFLI", 0.0, MAX_IES_MULTIPLIER)?;
    l.number("tilt during measurement", -180.0, 180.0)?;
    let sets = lamp_sets(&mut l)?;
    let chosen = lamp_set.unwrap_or(1);
    let set = *sets.get(chosen.wrapping_sub(1)).ok_or_else(|| {
        (
            None,
            format!("lamp set {chosen}: the file has {} lamp set(s)", sets.len()),
        )
    })?;
    for k in 0..10 {
        l.number(&format!("direct ratio {}", k + 1), 0.0, 1e6)?;
    }
    let planes = stored_planes(isym, mc).map_err(|m| (Some(mc_line), m))?;
    if planes * ng > MAX_IES_VALUES {
        return Err((
            Some(mc_line),
            format!("{planes} × {ng} intensities; the limit is {MAX_IES_VALUES}"),
        ));
    }
    let c_angles = angles(&mut l, mc, "C angles", 360.0)?;
    let gamma = angles(&mut l, ng, "γ angles", 180.0)?;
    let scale = set.flux / 1000.0 * cfli;
    if !(scale > 0.0 && scale.is_finite()) {
        return Err((
            Some(cfli_line),
            "lamp flux × conversion factor must be positive".into(),
        ));
    }
    let candela = scaled_rows(planes, ng, scale, || l.number("intensities", 0.0, f64::MAX))?;
    let horizontal = horizontal_angles(isym, &c_angles).map_err(|m| (Some(isym_line), m))?;
    Ok(CandelaTable {
        format: PhotometricFormat::Eulumdat,
        kind: PhotometricType::C,
        vertical: gamma,
        horizontal,
        candela,
        lamp_lumens: Some(set.flux),
        input_watts: (set.watts > 0.0).then_some(set.watts),
        opening,
        tilt: None,
    })
}

/// The luminaire's names and dimensions, and its luminous opening (mm in the file).
fn luminaire(l: &mut Lines) -> Result<LuminousOpening, ParseError> {
    for what in [
        "the measurement report number",
        "the luminaire name",
        "the luminaire number",
        "the file name",
        "the date and user",
    ] {
        l.text(what)?;
    }
    let mm = 1000.0 * MAX_OPENING;
    for what in ["luminaire length", "luminaire width", "luminaire height"] {
        l.number(what, 0.0, mm)?;
    }
    let (_, length) = l.number("luminous area length", 0.0, mm)?;
    let (_, width) = l.number("luminous area width", 0.0, mm)?;
    let mut heights = [0.0; 4];
    for (h, what) in heights.iter_mut().zip([
        "luminous height C0",
        "luminous height C90",
        "luminous height C180",
        "luminous height C270",
    ]) {
        *h = l.number(what, 0.0, mm)?.1 / 1000.0;
    }
    Ok(LuminousOpening::from_ldt(
        length / 1000.0,
        width / 1000.0,
        heights,
    ))
}

/// The lamp sets (at most [`MAX_LDT_LAMP_SETS`]).
fn lamp_sets(l: &mut Lines) -> Result<Vec<LampSet>, ParseError> {
    let (_, n) = l.count("number of lamp sets", 1, MAX_LDT_LAMP_SETS)?;
    let mut sets = Vec::with_capacity(n);
    for k in 1..=n {
        l.number(
            &format!("lamp set {k}: number of lamps"),
            -MAX_IES_LAMPS,
            MAX_IES_LAMPS,
        )?;
        l.text(&format!("lamp set {k}: lamp type"))?;
        let (_, flux) = l.number(
            &format!("lamp set {k}: total flux"),
            -MAX_LUMENS,
            MAX_LUMENS,
        )?;
        l.text(&format!("lamp set {k}: colour"))?;
        l.text(&format!("lamp set {k}: colour rendering"))?;
        let (_, watts) = l.number(&format!("lamp set {k}: wattage"), 0.0, MAX_WATTS)?;
        sets.push(LampSet {
            flux: flux.abs(),
            watts,
        });
    }
    Ok(sets)
}

/// How many C planes the file stores for symmetry `isym` out of `mc`.
fn stored_planes(isym: usize, mc: usize) -> Result<usize, String> {
    match isym {
        0 => Ok(mc),
        1 => Ok(1),
        2 | 3 if mc.is_multiple_of(2) => Ok(mc / 2 + 1),
        4 if mc.is_multiple_of(4) => Ok(mc / 4 + 1),
        2 | 3 => Err(format!(
            "Isym {isym} needs an even number of C planes, not {mc}"
        )),
        _ => Err(format!("Isym 4 needs a multiple of 4 C planes, not {mc}")),
    }
}

/// `n` angles in `0..=hi` degrees, strictly increasing.
fn angles(l: &mut Lines, n: usize, what: &str, hi: f64) -> Result<Vec<f64>, ParseError> {
    let mut out: Vec<f64> = Vec::with_capacity(n);
    for _ in 0..n {
        let (line, a) = l.number(what, 0.0, hi)?;
        if out.last().is_some_and(|&p| a <= p) {
            return Err((Some(line), format!("{what} must increase")));
        }
        out.push(a);
    }
    Ok(out)
}

/// The C angles of the stored planes, in the form [`CandelaTable`] unfolds: one plane, or
/// 0°…90°, 0°…180°, 90°…270°, or a full circle from 0°.
fn horizontal_angles(isym: usize, c: &[f64]) -> Result<Vec<f64>, String> {
    let mc = c.len();
    let (range, first, last) = match isym {
        0 => (0..mc, 0.0, None),
        1 => return Ok(vec![0.0]),
        2 => (0..mc / 2 + 1, 0.0, Some(180.0)),
        3 => (mc / 4..mc / 4 + mc / 2 + 1, 90.0, Some(270.0)),
        _ => (0..mc / 4 + 1, 0.0, Some(90.0)),
    };
    let h = c
        .get(range)
        .ok_or("the C angles do not fit the symmetry")?
        .to_vec();
    let ok_first = h.first().is_some_and(|&a| (a - first).abs() < 1e-6);
    let ok_last = last.is_none_or(|want| h.last().is_some_and(|&a| (a - want).abs() < 1e-6));
    if !(ok_first && ok_last) {
        let want = match last {
            Some(l) => format!("C {first}° … {l}°"),
            None => format!("C from {first}°"),
        };
        return Err(format!("Isym {isym} needs its stored planes at {want}"));
    }
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal LDT: `isym`, `mc` planes every `360/mc` degrees, γ 0/45/90, and the
    /// stored intensities in cd/klm, flux 2000 lm.
    fn ldt(isym: usize, mc: usize, rows: &[[f64; 3]]) -> String {
        let mut s = format!(
            "ACME\n1\n{isym}\n{mc}\n{}\n3\n45\nR1\nPanel\nP-1\np.ldt\n2026\n\
             1200\n300\n50\n1190\n290\n0\n0\n0\n0\n100\n85,5\n1\n0\n\
             1\n1\nLED\n2000\n4000K\n80\n24\n",
            360.0 / mc as f64
        );
        for _ in 0..10 {
            s.push_str("0.5\n");
        }
        for k in 0..mc {
            s.push_str(&format!("{}\n", k as f64 * 360.0 / mc as f64));
        }
        s.push_str("0\n45\n90\n");
        for r in rows {
            for v in r {
                s.push_str(&format!("{v}\n"));
            }
        }
        s
    }

    #[test]
    fn symmetry_types_unfold_to_the_same_table() {
        // A distribution with I(C, γ) = 100 + 10·|cos C| at γ = 45°, stored four ways.
        let at = |c: f64| 100.0 + 10.0 * c.to_radians().cos().abs();
        let row = |c: f64| [500.0, at(c), 0.0];
        let full: Vec<[f64; 3]> = (0..8).map(|k| row(k as f64 * 45.0)).collect();
        let cases = [
            (0, full.clone()),
            (2, full[0..5].to_vec()),
            (3, full[2..7].to_vec()),
            (4, full[0..3].to_vec()),
        ];
        for (isym, rows) in cases {
            let t = parse(&ldt(isym, 8, &rows), None).unwrap();
            for k in 0..16 {
                let c = k as f64 * 22.5;
                let want = 2.0
                    * (at(c.div_euclid(45.0) * 45.0) + at((c.div_euclid(45.0) + 1.0) * 45.0))
                    / 2.0;
                let want = if (c / 45.0).fract() == 0.0 {
                    2.0 * at(c)
                } else {
                    want
                };
                let got = t.candela_at(45.0, c);
                assert!(
                    (got - want).abs() < 1e-9,
                    "Isym {isym} C {c}: {got} vs {want}"
                );
            }
            assert_eq!(t.candela_at(0.0, 77.0), 1000.0, "Isym {isym}");
        }
        let t = parse(&ldt(1, 1, &[[400.0, 300.0, 0.0]]), None).unwrap();
        assert_eq!(t.candela_at(45.0, 123.0), 600.0);
        assert_eq!(
            t.opening,
            LuminousOpening::Rectangle {
                along_c0: 0.29,
                along_c90: 1.19,
                sides: 0.0
            }
        );
        assert_eq!(t.lamp_lumens, Some(2000.0));
        assert_eq!(t.input_watts, Some(24.0));
    }

    #[test]
    fn bad_files_name_the_line() {
        let good = ldt(1, 1, &[[400.0, 300.0, 0.0]]);
        let e = parse(&good.replacen("\n1\n1\n", "\n1\n7\n", 1), None).unwrap_err();
        assert_eq!(e.0, Some(3), "{e:?}");
        let e = parse(&good.replace("4000K\n80\n24\n", "4000K\n80\nx\n"), None).unwrap_err();
        assert!(e.1.contains("'x'"), "{e:?}");
        let cut: String = good.lines().take(40).map(|l| format!("{l}\n")).collect();
        assert!(parse(&cut, None).unwrap_err().1.contains("ends"));
        let e = parse(&good, Some(2)).unwrap_err();
        assert!(e.1.contains("lamp set 2"), "{e:?}");
        let e = parse(&ldt(2, 3, &[[1.0; 3], [1.0; 3]]), None).unwrap_err();
        assert!(e.1.contains("even"), "{e:?}");
    }

    /// Lamp sets are alternatives (say two drive currents): the chosen set's total flux
    /// scales the table and its wattage with ballast is the luminaire's; a wattage of 0 is
    /// unknown.
    #[test]
    fn the_chosen_lamp_set_gives_the_watts() {
        let one = ldt(1, 1, &[[400.0, 300.0, 0.0]]);
        let two = one.replace(
            "1\n1\nLED\n2000\n4000K\n80\n24\n",
            "2\n1\nLED 110\n2000\n4000K\n80\n24\n1\nLED 120\n3000\n4000K\n80\n37,5\n",
        );
        let first = parse(&two, None).unwrap();
        assert_eq!(
            (first.lamp_lumens, first.input_watts),
            (Some(2000.0), Some(24.0))
        );
        let second = parse(&two, Some(2)).unwrap();
        assert_eq!(
            (second.lamp_lumens, second.input_watts),
            (Some(3000.0), Some(37.5))
        );
        assert_eq!(second.candela_at(0.0, 0.0), 1200.0);
        let unknown = parse(&one.replace("80\n24\n", "80\n0\n"), None).unwrap();
        assert_eq!(unknown.input_watts, None);
    }
}
