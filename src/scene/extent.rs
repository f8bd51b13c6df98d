//! A hint at the model's length unit: a model whose size makes no sense as a room or a
//! building, read in metres, loads with a warning that suggests the `units` or `scale` to
//! set in `scene.toml`. Only a scene whose `scene.toml` gives neither is checked (one that
//! gives either chose its unit); the hint fixes nothing, so `strict = true` keeps it a
//! warning.
//!
//! The rule, on the model's extent E (the largest side of its bounding box, in metres):
//!
//! - E over [`LARGEST_M`] (1 km): far larger than a building. The suggestion is the first
//!   of `mm`, `cm`, `in`, `ft` that brings E within [`PLAUSIBLE_M`] (0.5 m..500 m);
//!   millimetres come first as the usual unit of CAD and BIM exports, so in practice the
//!   suggestion is `units = "mm"` up to 500 km.
//! - E under [`SMALLEST_M`] (0.1 m): a few centimetres, smaller than any room. No length
//!   unit relight knows is larger than the metre, so such a model was most likely
//!   converted to metres twice (a millimetre model divided by 1000 again, or a centimetre
//!   one by 100). The suggestion is `scale` = 10, 100 or 1000, the one that brings E
//!   closest to 10 m within [`PLAUSIBLE_M`].
//!
//! Where no choice lands in the plausible range, the warning still names the extent and
//! asks for `units` or `scale`.

use std::ops::RangeInclusive;
use std::path::Path;

/// A model's extent above this (m) suggests a smaller unit.
pub(crate) const LARGEST_M: f64 = 1000.0;
/// A model's extent below this (m) suggests a larger scale.
pub(crate) const SMALLEST_M: f64 = 0.1;
/// The extents a suggestion may lead to (m): a small room to a large building.
pub(crate) const PLAUSIBLE_M: RangeInclusive<f64> = 0.5..=500.0;

/// The units a too-large model may be in, in the order they are suggested, with their
/// size in metres.
const SMALLER_UNITS: [(&str, &str, f64); 4] = [
    ("mm", "millimetres", 0.001),
    ("cm", "centimetres", 0.01),
    ("in", "inches", 0.0254),
    ("ft", "feet", 0.3048),
];

/// The scale factors a too-small model may need.
const LARGER_SCALES: [f64; 3] = [10.0, 100.0, 1000.0];

/// `x` with three significant digits, without trailing zeros (`12000`, `12.3`, `0.0312`).
pub(crate) fn sig3(x: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let digits = (2 - x.abs().log10().floor() as i64).clamp(0, 12) as usize;
    let s = format!("{x:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The warning for a model `extent` metres across (read with neither `units` nor `scale`
/// set), or None when its size is plausible. `model` names the model file.
pub(crate) fn units_hint(model: &Path, extent: f64) -> Option<String> {
    if !extent.is_finite() || (SMALLEST_M..=LARGEST_M).contains(&extent) {
        return None;
    }
    let model = model.display();
    let e = sig3(extent);
    if extent > LARGEST_M {
        let fit = SMALLER_UNITS
            .iter()
            .find(|(_, _, m)| PLAUSIBLE_M.contains(&(extent * m)));
        return Some(match fit {
            Some((unit, long, m)) => format!(
                "{model}: the model is {e} m across read in metres (no units or scale in \
                 scene.toml), larger than any building: if it is in {long}, set \
                 units = \"{unit}\" in scene.toml (it is then {} m across)",
                sig3(extent * m)
            ),
            None => format!(
                "{model}: the model is {e} m across read in metres (no units or scale in \
                 scene.toml), larger than any building, and no unit (mm, cm, in, ft) makes \
                 it a building's size: set units or scale = <metres per unit> in scene.toml"
            ),
        });
    }
    let near_10m = |f: &f64| (extent * f / 10.0).log10().abs();
    let fit = LARGER_SCALES
        .iter()
        .filter(|f| PLAUSIBLE_M.contains(&(extent * *f)))
        .min_by(|a, b| near_10m(a).total_cmp(&near_10m(b)));
    Some(match fit {
        Some(f) => format!(
            "{model}: the model is only {e} m across read in metres (no units or scale in \
             scene.toml), smaller than any room: if its coordinates were converted to \
             metres twice, set scale = {f} in scene.toml (it is then {} m across)",
            sig3(extent * f)
        ),
        None => format!(
            "{model}: the model is only {e} m across read in metres (no units or scale in \
             scene.toml), smaller than any room: set units or scale = <metres per unit> in \
             scene.toml"
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hint(extent: f64) -> Option<String> {
        units_hint(Path::new("room/scene.obj"), extent)
    }

    #[test]
    fn plausible_sizes_give_no_hint() {
        for e in [0.1, 0.3, 1.0, 12.0, 480.0, 1000.0] {
            assert_eq!(hint(e), None, "{e}");
        }
        assert_eq!(hint(f64::NAN), None);
        assert_eq!(hint(f64::INFINITY), None);
    }

    #[test]
    fn a_room_in_millimetres_suggests_mm() {
        let h = hint(12_000.0).unwrap();
        assert!(
            h.starts_with("room/scene.obj: ")
                && h.contains("12000 m across")
                && h.contains("units = \"mm\"")
                && h.contains("then 12 m across"),
            "{h}"
        );
        // Up to 500 km millimetres still fit; beyond, nothing does.
        assert!(hint(400_000.0).unwrap().contains("units = \"mm\""));
        let h = hint(600_000.0).unwrap();
        assert!(h.contains("600000 m") && h.contains("no unit"), "{h}");
    }

    #[test]
    fn a_room_converted_twice_suggests_a_scale() {
        // 6 m divided by 100 again, and 15 m by 1000 again.
        let h = hint(0.06).unwrap();
        assert!(
            h.contains("only 0.06 m") && h.contains("scale = 100 ") && h.contains("6 m across"),
            "{h}"
        );
        let h = hint(0.015).unwrap();
        assert!(
            h.contains("scale = 1000 ") && h.contains("15 m across"),
            "{h}"
        );
        let h = hint(0.0001).unwrap();
        assert!(
            h.contains("only 0.0001 m") && !h.contains("scale = 1"),
            "{h}"
        );
    }

    #[test]
    fn three_significant_digits() {
        for (x, digits) in [
            (12_000.0, "12000"),
            (12.3456, "12.3"),
            (0.031_24, "0.0312"),
            (3.0, "3"),
            (0.5, "0.5"),
        ] {
            assert_eq!(sig3(x), digits);
        }
    }
}
