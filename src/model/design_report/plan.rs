//! A grid's false-colour plan as inline SVG: the top view (x to the right, z down), each
//! point a cell coloured by its maintained illuminance on a banded lux scale, with the
//! value printed in cells large enough to read (every k-th cell on fine grids), and a
//! legend of the bands.

use std::fmt::Write;

use super::{fmt_lux, GridReport, MAX_PLAN_POINTS};

/// Bands of the scale, low to high (a "turbo"-like ramp).
const BANDS: [&str; 10] = [
    "#3b3fa8", "#2f7ef5", "#1bb9e8", "#25e0a9", "#7cf25d", "#c6e93a", "#f5c33a", "#fb8c26",
    "#e4501b", "#a51d0a",
];

/// Width of the drawing, user units (≈ pixels at 96 dpi on a 170 mm column).
const WIDTH: f64 = 640.0;
/// Tallest drawing, user units.
const MAX_HEIGHT: f64 = 560.0;
/// Least distance between printed values, user units.
const LABEL_PITCH: f64 = 30.0;

/// The top of the scale: a round number (1, 2, 2.5, 5 × 10ⁿ) at or above `max`.
pub(super) fn scale_top(max: f64) -> f64 {
    if !(max.is_finite() && max > 0.0) {
        return 1.0;
    }
    let p = 10f64.powf(max.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&t| t >= max * (1.0 - 1e-9))
        .unwrap_or(10.0 * p)
}

/// The band of `v` on a scale from 0 to `top`.
fn band(v: f64, top: f64) -> usize {
    ((v / top * BANDS.len() as f64).floor().max(0.0) as usize).min(BANDS.len() - 1)
}

/// Where a plan's cells go: the points' extent (x, z), the cell side `s` (m), the scale `k`
/// (user units per m), the drawing's size, and which values to print at what size.
struct Frame {
    lo: [f64; 2],
    hi: [f64; 2],
    s: f64,
    k: f64,
    w: f64,
    h: f64,
    cell: f64,
    step: i64,
    font: f64,
}

impl Frame {
    fn of(g: &GridReport) -> Frame {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &g.points {
            for (k, v) in [p[0], p[2]].into_iter().enumerate() {
                lo[k] = lo[k].min(v);
                hi[k] = hi[k].max(v);
            }
        }
        // The cell: the spacing, else a square of the points' mean share of the extent.
        let extent = ((hi[0] - lo[0]).max(1e-3) * (hi[1] - lo[1]).max(1e-3)).sqrt();
        let s = g
            .spacing
            .filter(|s| *s > 0.0)
            .unwrap_or(extent / (g.points.len() as f64).sqrt())
            .max(1e-3);
        let (wm, hm) = (hi[0] - lo[0] + s, hi[1] - lo[1] + s);
        let k = (WIDTH / wm).min(MAX_HEIGHT / hm);
        let cell = s * k;
        let step = (LABEL_PITCH / cell).ceil().max(1.0) as i64;
        Frame {
            lo,
            hi,
            s,
            k,
            w: wm * k,
            h: hm * k,
            cell,
            step,
            font: (cell * step as f64 * 0.32).min(11.0),
        }
    }

    /// The cells (into `out`) and the printed values (into `labels`).
    fn cells(&self, g: &GridReport, top: f64, out: &mut String, labels: &mut String) {
        let (lo, k, cell) = (self.lo, self.k, self.cell);
        for (p, v) in g.points.iter().zip(&g.maintained.values) {
            let (x, y) = ((p[0] - lo[0]) * k, (p[2] - lo[1]) * k);
            let rect = |fill: &str| {
                format!(
                    "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{cell:.2}\" height=\"{cell:.2}\" \
                     fill=\"{fill}\"/>"
                )
            };
            let Some(v) = v.map(f64::from) else {
                out.push_str(&rect("#ccc"));
                continue;
            };
            let b = band(v, top);
            out.push_str(&rect(BANDS[b]));
            let col = ((p[0] - lo[0]) / self.s).round() as i64;
            let row = ((p[2] - lo[1]) / self.s).round() as i64;
            if col % self.step == 0 && row % self.step == 0 && self.font >= 4.0 {
                let ink = if (1..=6).contains(&b) { "#000" } else { "#fff" };
                let _ = write!(
                    labels,
                    "<text x=\"{:.1}\" y=\"{:.1}\" fill=\"{ink}\">{}</text>",
                    x + cell / 2.0,
                    y + cell / 2.0,
                    fmt_lux(v)
                );
            }
        }
    }
}

/// The plan of grid `g` (or a note where it has too many points or none).
pub(super) fn svg(g: &GridReport) -> String {
    if g.points.is_empty() || g.points.len() > MAX_PLAN_POINTS {
        return format!(
            "<p class=\"muted\">No plan: {} points (a plan draws 1 to {MAX_PLAN_POINTS}).</p>",
            g.points.len()
        );
    }
    let f = Frame::of(g);
    let top = scale_top(g.maintained.max);
    let mut out = String::with_capacity(g.points.len() * 120 + 2048);
    let _ = write!(
        out,
        "<figure class=\"plan\"><svg class=\"plan\" viewBox=\"0 0 {:.1} {:.1}\" role=\"img\" \
         aria-label=\"maintained illuminance plan\"><g font-family=\"sans-serif\" \
         font-size=\"{:.1}\" text-anchor=\"middle\" dominant-baseline=\"central\">",
        f.w,
        f.h + 62.0,
        f.font
    );
    let mut labels = String::new();
    f.cells(g, top, &mut out, &mut labels);
    out.push_str(&labels);
    out.push_str("</g>");
    legend(&mut out, f.w, f.h + 10.0, top);
    let every = if f.step > 1 {
        format!(", values printed on every {}th", f.step)
    } else {
        String::new()
    };
    let _ = write!(
        out,
        "</svg><figcaption>Maintained illuminance, lx. Top view: x → {:.2}–{:.2} m, \
         z ↓ {:.2}–{:.2} m; one cell per point{every}.</figcaption></figure>",
        f.lo[0], f.hi[0], f.lo[1], f.hi[1],
    );
    out
}

/// The bands' swatches with their limits, below the plan.
fn legend(out: &mut String, w: f64, y: f64, top: f64) {
    let n = BANDS.len() as f64;
    let sw = (w / n).min(60.0);
    let _ = write!(
        out,
        "<g class=\"legend\" font-family=\"sans-serif\" font-size=\"10\" text-anchor=\"middle\">"
    );
    for (i, c) in BANDS.iter().enumerate() {
        let x = i as f64 * sw;
        let _ = write!(
            out,
            "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{sw:.1}\" height=\"14\" fill=\"{c}\"/>\
             <text x=\"{x:.1}\" y=\"{:.1}\">{}</text>",
            y + 28.0,
            fmt_lux(top * i as f64 / n)
        );
    }
    let _ = write!(
        out,
        "<text x=\"{:.1}\" y=\"{:.1}\">{} lx</text></g>",
        (n * sw).min(w - 20.0),
        y + 28.0,
        fmt_lux(top)
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scale_tops_at_a_round_number() {
        assert_eq!(scale_top(523.0), 1000.0);
        assert_eq!(scale_top(480.0), 500.0);
        assert_eq!(scale_top(180.0), 200.0);
        assert_eq!(scale_top(0.0), 1.0);
        assert_eq!(band(999.0, 1000.0), 9);
        assert_eq!(band(0.0, 1000.0), 0);
    }
}
