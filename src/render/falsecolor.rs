//! False colour: illuminance (lux) on a log colour scale, with a labelled legend bar.

use rayon::prelude::*;

use super::font::glyph;
use crate::color::Rgb;

/// False colour: a perceptual blue→green→yellow→red scale of luminance over
/// `[lo, hi]` on a log10 axis, with a legend bar on the right edge labelled in lux.
pub fn false_color(img: &[Rgb], width: u32, height: u32, lo: f32, hi: f32) -> Vec<u8> {
    let (lo, hi) = false_color_range(lo, hi);
    let (l0, l1) = (lo.log10(), hi.log10());
    let mut out: Vec<u8> = img
        .par_iter()
        .flat_map_iter(|p| {
            let y = p.luminance();
            let t = if y <= 0.0 {
                0.0
            } else {
                ((y.log10() - l0) / (l1 - l0)).clamp(0.0, 1.0)
            };
            scale_color(t).into_iter()
        })
        .collect();
    legend(&mut out, width, height, lo, hi);
    out
}

/// Smallest and largest lux values the false-colour scale shows.
const FALSE_COLOR_MIN_LUX: f32 = 1e-6;
const FALSE_COLOR_MAX_LUX: f32 = 1e12;

/// A usable false-colour range: both ends clamped to 1e-6..1e12 lux (NaN counts as the low
/// end), and the high end above the low one.
pub fn false_color_range(lo: f32, hi: f32) -> (f32, f32) {
    let clamp = |v: f32| {
        if v.is_nan() {
            FALSE_COLOR_MIN_LUX
        } else {
            v.clamp(FALSE_COLOR_MIN_LUX, FALSE_COLOR_MAX_LUX)
        }
    };
    let lo = clamp(lo).min(FALSE_COLOR_MAX_LUX / 1.01);
    let hi = clamp(hi).max(lo * 1.01);
    (lo, hi)
}

/// The false-colour legend: a bar 1/24 of the width at the right edge (high values at the
/// top), with lux labels at round values (1, 2, 5 × 10^k) drawn on dark plates.
fn legend(out: &mut [u8], width: u32, height: u32, lo: f32, hi: f32) {
    let bar = (width / 24).max(4);
    let log = |v: f32| v.max(1e-9).log10();
    // Within the clamped range the tick loop runs over at most 19 decades.
    let (lo, hi) = false_color_range(lo, hi);
    let (l0, l1) = (log(lo), log(hi));
    for y in 0..height {
        let t = 1.0 - y as f32 / (height.max(2) - 1) as f32;
        let c = scale_color(t);
        for x in width.saturating_sub(bar)..width {
            let i = 3 * (y * width + x) as usize;
            out[i..i + 3].copy_from_slice(&c);
        }
    }
    let px = ((height + 150) / 300).clamp(1, 4);
    let glyph_h = 7 * px;
    if height < 4 * glyph_h || width < 16 * bar {
        return; // too small for labels
    }
    // Round values within the range, thinned so labels never overlap.
    let mut ticks = vec![];
    for e in (l0.floor() as i32)..=(l1.ceil() as i32) {
        for m in [1.0f32, 2.0, 5.0] {
            let v = m * 10f32.powi(e);
            if log(v) >= l0 - 1e-6 && log(v) <= l1 + 1e-6 {
                ticks.push(v);
            }
        }
    }
    let row = |v: f32| ((1.0 - (log(v) - l0) / (l1 - l0)) * (height - 1) as f32) as i64;
    let mut last: Option<i64> = None;
    let spacing = 2 * glyph_h as i64;
    let mut chosen = vec![];
    for &v in ticks.iter().rev() {
        let r = row(v);
        if last.is_none_or(|l| r - l >= spacing) {
            chosen.push(v);
            last = Some(r);
        }
    }
    let mut canvas = Canvas {
        out,
        w: width,
        h: height,
    };
    for v in chosen {
        let text = format!("{} lx", lux_label(v));
        let tw = text.len() as u32 * 6 * px;
        let x0 = width.saturating_sub(bar + tw + 3 * px) as i64;
        let y0 = (row(v) - glyph_h as i64 / 2).clamp(0, (height - glyph_h) as i64);
        // Dark plate, then the text; a tick mark into the bar.
        let plate = (x0 - px as i64, y0 - px as i64);
        canvas.fill(plate, tw + 2 * px, glyph_h + 2 * px, [20, 20, 20]);
        canvas.text((x0, y0), px, &text, [255, 255, 255]);
        let ty = row(v).clamp(0, height as i64 - 1);
        canvas.fill(((width - bar) as i64, ty), bar / 3, px, [20, 20, 20]);
    }
}

/// A lux value as a short label: 0.5, 2, 50, 1k, 20k.
fn lux_label(v: f32) -> String {
    if v >= 1000.0 {
        format!("{}k", trim_number(v / 1000.0))
    } else {
        trim_number(v)
    }
}

fn trim_number(v: f32) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// An RGB8 image to draw on, `w` × `h`.
struct Canvas<'a> {
    out: &'a mut [u8],
    w: u32,
    h: u32,
}

impl Canvas<'_> {
    /// Fills the rectangle `fw` × `fh` at (x0, y0) with `c`, clipped to the image.
    fn fill(&mut self, (x0, y0): (i64, i64), fw: u32, fh: u32, c: [u8; 3]) {
        let (w, h) = (self.w, self.h);
        for y in y0.max(0)..(y0 + fh as i64).min(h as i64) {
            for x in x0.max(0)..(x0 + fw as i64).min(w as i64) {
                let i = 3 * (y as usize * w as usize + x as usize);
                self.out[i..i + 3].copy_from_slice(&c);
            }
        }
    }

    /// Draws `text` with its top-left corner at (x0, y0), each font pixel `px` × `px`.
    fn text(&mut self, (x0, y0): (i64, i64), px: u32, text: &str, c: [u8; 3]) {
        for (k, ch) in text.chars().enumerate() {
            let g = glyph(ch);
            for (r, bits) in g.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        let x = x0 + ((k * 6 + col) as u32 * px) as i64;
                        let y = y0 + (r as u32 * px) as i64;
                        self.fill((x, y), px, px, c);
                    }
                }
            }
        }
    }
}

/// The false-colour scale at t in [0, 1] (0 = `lo`, 1 = `hi`).
pub fn scale_color(t: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 6] = [
        [0.05, 0.05, 0.35],
        [0.0, 0.35, 0.9],
        [0.0, 0.75, 0.55],
        [0.55, 0.85, 0.1],
        [1.0, 0.8, 0.0],
        [0.85, 0.1, 0.05],
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    let c = [0, 1, 2].map(|k| STOPS[i][k] + (STOPS[i + 1][k] - STOPS[i][k]) * f);
    c.map(|v| (v * 255.0 + 0.5) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lux_labels_are_short_and_round() {
        for (lux, label) in [
            (0.5, "0.5"),
            (2.0, "2"),
            (500.0, "500"),
            (1000.0, "1k"),
            (20000.0, "20k"),
        ] {
            assert_eq!(lux_label(lux), label);
        }
    }

    #[test]
    fn legend_labels_are_drawn_in_white_beside_the_bar() {
        let (w, h) = (400u32, 300u32);
        let img = vec![Rgb::ZERO; (w * h) as usize];
        let out = false_color(&img, w, h, 1.0, 100.0);
        let bar = w / 24;
        let white = |x: u32, y: u32| {
            let i = 3 * (y * w + x) as usize;
            out[i..i + 3] == [255, 255, 255]
        };
        // Labels at 1, 2, 5, 10, 20, 50 and 100 lx fit at this height: white text left of
        // the bar near the top (100 lx) and the bottom (1 lx), none elsewhere in the image.
        let band =
            |y0: u32, y1: u32| (y0..y1).any(|y| (w - bar - 60..w - bar).any(|x| white(x, y)));
        assert!(band(0, 12), "no label at the top");
        assert!(band(h - 12, h), "no label at the bottom");
        assert!(!(0..h).any(|y| (0..w / 2).any(|x| white(x, y))));
    }

    #[test]
    fn false_color_range_to_1e39_allocated_until_abort() {
        // 1e39 lux is +inf as f32: the legend's tick loop ran over 2^31 decades.
        let img = vec![Rgb::ONE; 64 * 48];
        for (lo, hi) in [
            (1.0, f32::INFINITY),
            (f32::NAN, f32::NAN),
            (0.0, 0.0),
            (f32::MAX, f32::MAX),
            (-5.0, -1.0),
            (1e-30, 1e30),
        ] {
            let out = false_color(&img, 64, 48, lo, hi);
            assert_eq!(out.len(), 3 * 64 * 48);
            let (a, b) = false_color_range(lo, hi);
            assert!(
                a.is_finite() && b.is_finite() && b > a && a > 0.0,
                "{lo} {hi}"
            );
        }
    }
}
