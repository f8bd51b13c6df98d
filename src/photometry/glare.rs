//! Discomfort glare: the CIE Unified Glare Rating (CIE 117:1995).
//!
//! `UGR = 8 log₁₀( 0.25 / L_b · Σ L² ω / p² )`, over the luminaires in view:
//! - `L`, the luminance of a luminaire's luminous parts towards the eye (cd/m²): its
//!   intensity towards the eye over its luminous area projected towards the eye;
//! - `ω`, the solid angle of those parts at the eye (sr): projected area / distance²;
//! - `p`, the Guth position index of the luminaire's place in the field of view;
//! - `L_b`, the background luminance (cd/m²): the indirect illuminance at the eye, in the
//!   direction of view, over π.
//!
//! The position index comes from CIE 117's Table 4.1 (after Luckiesh and Guth), indexed by
//! `H/R` and `T/R`: with the line of sight along R, H is the luminaire's height above the
//! line of sight and T its lateral offset. Luminaires below the line of sight, behind the
//! eye, or beyond the table (`T/R > 3`, or where the table has no entry: outside the
//! field of view) do not count, as in the standard.

/// `T/R` rows of [`GUTH_TABLE`]: 0, 0.1, …, 3.0.
const TR_STEP: f64 = 0.1;
/// `H/R` columns of [`GUTH_TABLE`]: 0, 0.1, …, 1.9.
const HR_STEP: f64 = 0.1;
/// No entry: the position is outside the field of view.
const NONE: f64 = f64::NAN;

/// CIE 117:1995 Table 4.1, the Guth position index p: rows T/R = 0 … 3.0, columns
/// H/R = 0 … 1.9, both in steps of 0.1.
#[rustfmt::skip]
const GUTH_TABLE: [[f64; 20]; 31] = [
    [1.00, 1.26, 1.53, 1.90, 2.35, 2.86, 3.50, 4.20, 5.00, 6.00, 7.00, 8.10, 9.25, 10.35, 11.70, 13.15, 14.70, 16.20, NONE, NONE],
    [1.05, 1.22, 1.46, 1.80, 2.20, 2.75, 3.40, 4.10, 4.80, 5.80, 6.80, 8.00, 9.10, 10.30, 11.60, 13.00, 14.60, 16.10, NONE, NONE],
    [1.12, 1.30, 1.50, 1.80, 2.20, 2.66, 3.18, 3.88, 4.60, 5.50, 6.50, 7.60, 8.75, 9.85, 11.20, 12.70, 14.00, 15.70, NONE, NONE],
    [1.22, 1.38, 1.60, 1.97, 2.25, 2.70, 3.25, 3.90, 4.60, 5.45, 6.45, 7.40, 8.40, 9.50, 10.85, 12.10, 13.70, 15.00, NONE, NONE],
    [1.32, 1.47, 1.70, 1.96, 2.35, 2.80, 3.30, 3.90, 4.60, 5.40, 6.40, 7.30, 8.30, 9.40, 10.60, 11.90, 13.20, 14.60, 16.00, NONE],
    [1.43, 1.60, 1.82, 2.10, 2.48, 2.91, 3.40, 3.98, 4.70, 5.50, 6.40, 7.30, 8.30, 9.40, 10.50, 11.75, 13.00, 14.40, 15.70, NONE],
    [1.55, 1.72, 1.98, 2.30, 2.65, 3.10, 3.60, 4.10, 4.80, 5.50, 6.40, 7.35, 8.40, 9.40, 10.50, 11.70, 13.00, 14.10, 15.40, NONE],
    [1.70, 1.88, 2.12, 2.48, 2.87, 3.30, 3.78, 4.30, 4.88, 5.60, 6.50, 7.40, 8.50, 9.50, 10.50, 11.70, 12.85, 14.00, 15.20, NONE],
    [1.82, 2.00, 2.32, 2.70, 3.08, 3.50, 3.92, 4.50, 5.10, 5.75, 6.60, 7.50, 8.60, 9.50, 10.60, 11.75, 12.80, 14.00, 15.10, NONE],
    [1.96, 2.20, 2.54, 2.90, 3.30, 3.70, 4.20, 4.75, 5.30, 6.00, 6.75, 7.70, 8.70, 9.65, 10.75, 11.80, 12.90, 14.00, 15.00, 16.00],
    [2.11, 2.40, 2.75, 3.10, 3.50, 3.91, 4.40, 5.00, 5.60, 6.20, 7.00, 7.90, 8.80, 9.75, 10.80, 11.90, 12.95, 14.00, 15.00, 16.00],
    [2.30, 2.55, 2.92, 3.30, 3.72, 4.20, 4.70, 5.25, 5.80, 6.55, 7.20, 8.15, 9.00, 9.90, 10.95, 12.00, 13.00, 14.00, 15.00, 16.00],
    [2.40, 2.75, 3.12, 3.50, 3.90, 4.35, 4.85, 5.50, 6.05, 6.70, 7.50, 8.30, 9.20, 10.00, 11.02, 12.10, 13.10, 14.00, 15.00, 16.00],
    [2.55, 2.90, 3.30, 3.70, 4.20, 4.65, 5.20, 5.70, 6.30, 7.00, 7.70, 8.55, 9.35, 10.20, 11.20, 12.25, 13.20, 14.00, 15.00, 16.00],
    [2.70, 3.10, 3.50, 3.90, 4.35, 4.85, 5.35, 5.85, 6.50, 7.25, 8.00, 8.70, 9.50, 10.40, 11.40, 12.40, 13.25, 14.05, 15.00, 16.00],
    [2.85, 3.15, 3.65, 4.10, 4.55, 5.00, 5.50, 6.20, 6.80, 7.50, 8.20, 8.85, 9.70, 10.55, 11.50, 12.50, 13.30, 14.05, 15.02, 16.00],
    [2.95, 3.40, 3.80, 4.25, 4.75, 5.20, 5.75, 6.30, 7.00, 7.65, 8.40, 9.00, 9.80, 10.80, 11.75, 12.60, 13.40, 14.20, 15.10, 16.00],
    [3.10, 3.55, 4.00, 4.50, 4.90, 5.40, 5.95, 6.50, 7.20, 7.80, 8.50, 9.20, 10.00, 10.85, 11.85, 12.75, 13.45, 14.20, 15.10, 16.00],
    [3.25, 3.70, 4.20, 4.65, 5.10, 5.60, 6.10, 6.75, 7.40, 8.00, 8.65, 9.35, 10.10, 11.00, 11.90, 12.80, 13.50, 14.20, 15.10, 16.00],
    [3.43, 3.86, 4.30, 4.75, 5.20, 5.70, 6.30, 6.90, 7.50, 8.17, 8.80, 9.50, 10.20, 11.00, 12.00, 12.82, 13.55, 14.20, 15.10, 16.00],
    [3.50, 4.00, 4.50, 4.90, 5.35, 5.80, 6.40, 7.10, 7.70, 8.30, 8.90, 9.60, 10.40, 11.10, 12.00, 12.85, 13.60, 14.30, 15.10, 16.00],
    [3.60, 4.17, 4.65, 5.05, 5.50, 6.00, 6.60, 7.20, 7.82, 8.45, 9.00, 9.75, 10.50, 11.20, 12.10, 12.90, 13.70, 14.35, 15.10, 16.00],
    [3.75, 4.25, 4.72, 5.20, 5.60, 6.10, 6.70, 7.35, 8.00, 8.55, 9.15, 9.85, 10.60, 11.30, 12.10, 12.90, 13.70, 14.40, 15.15, 16.00],
    [3.85, 4.35, 4.80, 5.25, 5.70, 6.22, 6.80, 7.40, 8.10, 8.65, 9.30, 9.90, 10.70, 11.40, 12.20, 12.95, 13.70, 14.40, 15.20, 16.00],
    [3.95, 4.40, 4.90, 5.35, 5.80, 6.30, 6.90, 7.50, 8.20, 8.80, 9.40, 10.00, 10.80, 11.50, 12.25, 13.00, 13.75, 14.45, 15.20, 16.00],
    [4.00, 4.50, 4.96, 5.40, 5.85, 6.40, 6.95, 7.55, 8.25, 8.85, 9.50, 10.05, 10.85, 11.55, 12.30, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.07, 4.55, 5.05, 5.47, 5.95, 6.46, 7.00, 7.65, 8.35, 8.95, 9.55, 10.10, 10.90, 11.60, 12.32, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.10, 4.60, 5.10, 5.53, 6.00, 6.50, 7.05, 7.70, 8.40, 9.00, 9.60, 10.16, 10.92, 11.63, 12.35, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.15, 4.62, 5.15, 5.56, 6.05, 6.55, 7.08, 7.73, 8.45, 9.05, 9.65, 10.20, 10.95, 11.65, 12.35, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.20, 4.65, 5.17, 5.60, 6.07, 6.57, 7.12, 7.75, 8.50, 9.10, 9.70, 10.23, 10.95, 11.65, 12.35, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.22, 4.67, 5.20, 5.65, 6.12, 6.60, 7.15, 7.80, 8.55, 9.12, 9.70, 10.23, 10.95, 11.65, 12.35, 13.00, 13.80, 14.50, 15.25, 16.00],
];

/// The Guth position index p for a luminaire at `h_r = H/R` (height above the line of
/// sight over the distance along it) and `t_r = |T|/R` (lateral offset over distance), by
/// bilinear interpolation in CIE 117's table; None outside the table or next to a missing
/// entry (outside the field of view).
pub fn guth_position_index(h_r: f64, t_r: f64) -> Option<f64> {
    let t_r = t_r.abs();
    if !(h_r >= 0.0 && t_r.is_finite() && h_r.is_finite()) {
        return None;
    }
    // Table nodes stay nodes despite rounding (1.9 / 0.1 = 18.999…).
    let snap = |x: f64| {
        if (x - x.round()).abs() < 1e-9 {
            x.round()
        } else {
            x
        }
    };
    let (fi, fj) = (snap(t_r / TR_STEP), snap(h_r / HR_STEP));
    let (rows, cols) = (GUTH_TABLE.len() - 1, GUTH_TABLE[0].len() - 1);
    if fi > rows as f64 || fj > cols as f64 {
        return None;
    }
    let (i, j) = ((fi as usize).min(rows - 1), (fj as usize).min(cols - 1));
    let (u, v) = (
        (fi - i as f64).clamp(0.0, 1.0),
        (fj - j as f64).clamp(0.0, 1.0),
    );
    let g = |a: usize, b: usize| GUTH_TABLE[a][b];
    let corners = [
        (i, j, (1.0 - u) * (1.0 - v)),
        (i, j + 1, (1.0 - u) * v),
        (i + 1, j, u * (1.0 - v)),
        (i + 1, j + 1, u * v),
    ];
    // A missing entry with any weight puts the position outside the field of view.
    let mut p = 0.0;
    for (a, b, w) in corners {
        if w > 0.0 {
            if g(a, b).is_nan() {
                return None;
            }
            p += w * g(a, b);
        }
    }
    Some(p)
}

/// One luminaire's part in a glare rating: its luminance towards the eye (cd/m²), its
/// solid angle (sr) and its position index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlareSource {
    pub luminance: f64,
    pub solid_angle: f64,
    pub position_index: f64,
}

impl GlareSource {
    /// `L² ω / p²`.
    pub fn term(&self) -> f64 {
        self.luminance * self.luminance * self.solid_angle
            / (self.position_index * self.position_index)
    }
}

/// The UGR of `sources` against background luminance `lb` (cd/m²); None when no source
/// counts or the background is black (the rating is then undefined).
pub fn ugr(lb: f64, sources: impl IntoIterator<Item = GlareSource>) -> Option<f64> {
    let sum: f64 = sources.into_iter().map(|s| s.term()).sum();
    (sum > 0.0 && lb > 0.0 && sum.is_finite()).then(|| 8.0 * (0.25 / lb * sum).log10())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_position_index_reads_the_cie_117_table() {
        // Nodes.
        assert_eq!(guth_position_index(0.0, 0.0), Some(1.0));
        assert_eq!(guth_position_index(0.5, 0.0), Some(2.86));
        assert_eq!(guth_position_index(1.0, 1.0), Some(7.0));
        assert_eq!(guth_position_index(1.9, 3.0), Some(16.0));
        // Between nodes: bilinear.
        let p = guth_position_index(0.55, 0.0).unwrap();
        assert!((p - (2.86 + 3.50) / 2.0).abs() < 1e-12, "{p}");
        // Symmetric in T.
        assert_eq!(
            guth_position_index(0.3, -0.4),
            guth_position_index(0.3, 0.4)
        );
        // Outside the field of view, below the line of sight, beyond T/R = 3.
        assert_eq!(guth_position_index(1.85, 0.0), None);
        assert_eq!(guth_position_index(-0.1, 0.0), None);
        assert_eq!(guth_position_index(0.5, 3.2), None);
    }

    #[test]
    fn ugr_by_hand() {
        // One source: L = 10,000 cd/m², ω = 0.01 sr, p = 2; L_b = 25 cd/m².
        // 0.25/25 · 1e8 · 0.01 / 4 = 2,500 → 8 log₁₀ 2500 = 27.18.
        let s = GlareSource {
            luminance: 1e4,
            solid_angle: 0.01,
            position_index: 2.0,
        };
        let u = ugr(25.0, [s]).unwrap();
        assert!((u - 8.0 * 2500f64.log10()).abs() < 1e-12, "{u}");
        assert_eq!(ugr(0.0, [s]), None);
        assert_eq!(ugr(25.0, []), None);
    }
}
