//! Point luminaires seen by the camera: each one's luminous opening as a visible shape.
//!
//! A luminaire's photometry gives its intensity `I` (cd) in every direction, and its file
//! gives the luminous opening ([`LuminousOpening`]). Seen along a ray, the opening shows
//! its average luminance towards the camera, `L = I(ω) / A_proj(ω)` (cd/m²), where
//! `A_proj` is the opening's area projected on the view direction. Flat rectangles and
//! disks are seen from their front only; a luminaire without dimensions shows as a small
//! sphere of [`DEFAULT_DIAMETER`]. An opening flush with a ceiling wins over the ceiling
//! (within [`FLUSH`]).

use glam::DVec3;

use crate::color::Rgb;
use crate::photometry::{Luminaire, LuminousOpening};
use crate::scene::LightGroup;

/// Diameter of the sphere drawn for a luminaire whose file gives no luminous opening, m.
pub(super) const DEFAULT_DIAMETER: f64 = 0.05;

/// An opening this close behind the surface a ray meets (metres) still shows.
pub(super) const FLUSH: f64 = 2e-3;

/// A luminaire's opening as seen by camera rays.
struct Shape {
    group: usize,
    luminaire: Luminaire,
    opening: LuminousOpening,
    /// Bounding sphere radius around the photometric centre, m.
    radius: f64,
}

/// Every point luminaire's visible shape.
pub(super) struct Openings {
    shapes: Vec<Shape>,
}

impl Openings {
    pub(super) fn new(lights: &[LightGroup]) -> Openings {
        let shapes = lights
            .iter()
            .enumerate()
            .flat_map(|(group, g)| {
                g.luminaires.iter().map(move |l| {
                    let opening = match l.opening {
                        LuminousOpening::Point => LuminousOpening::Sphere {
                            along_c0: DEFAULT_DIAMETER,
                            along_c90: DEFAULT_DIAMETER,
                            along_aim: DEFAULT_DIAMETER,
                        },
                        o => o,
                    };
                    Shape {
                        group,
                        luminaire: l.clone(),
                        opening,
                        radius: 0.5 * std::f64::consts::SQRT_2 * opening.largest_dimension(),
                    }
                })
            })
            .collect();
        Openings { shapes }
    }

    /// Whether the ray `o + t·d` (unit `d`) meets an opening before `t_scene` (+
    /// [`FLUSH`]).
    pub(super) fn blocks(&self, o: DVec3, d: DVec3, t_scene: f64) -> bool {
        self.nearest(o, d, t_scene).is_some()
    }

    /// If the ray `o + t·d` (unit `d`) meets an opening before `t_scene` (+ [`FLUSH`]),
    /// adds that luminaire's luminance (cd/m², per group RGB at unit weight) to `out` and
    /// returns true.
    pub(super) fn seen(&self, o: DVec3, d: DVec3, t_scene: f64, out: &mut [f32]) -> bool {
        let Some(s) = self.nearest(o, d, t_scene) else {
            return false;
        };
        let l = &s.luminaire;
        let v = -d;
        let area = s
            .opening
            .projected_area(v.dot(l.aim), v.dot(l.c0), v.dot(l.c90()));
        if area <= 1e-12 {
            return false;
        }
        let lum = l.intensity(v) / area;
        Rgb::column_mut(out)[s.group] += (lum * l.color.to_f64()).to_f32();
        true
    }

    /// The opening the ray meets first, before `t_scene` (+ [`FLUSH`]).
    fn nearest(&self, o: DVec3, d: DVec3, t_scene: f64) -> Option<&Shape> {
        let mut best: Option<(f64, &Shape)> = None;
        for s in &self.shapes {
            let limit = best.map_or(t_scene + FLUSH, |b| b.0);
            // Bounding sphere first.
            let oc = o - s.luminaire.position;
            let b = oc.dot(d);
            let c = oc.length_squared() - s.radius * s.radius;
            if c > 0.0 && (b > 0.0 || b * b < c) {
                continue;
            }
            if let Some(t) = hit(s, o, d) {
                if t > 0.0 && t < limit {
                    best = Some((t, s));
                }
            }
        }
        best.map(|b| b.1)
    }
}

/// Where the ray meets the shape's luminous surface (flat faces from their front only).
fn hit(s: &Shape, o: DVec3, d: DVec3) -> Option<f64> {
    let l = &s.luminaire;
    let (a, c0, c90) = (l.aim, l.c0, l.c90());
    let local = |p: DVec3| (p.dot(c0), p.dot(c90), p.dot(a));
    let (ox, oy, oz) = local(o - l.position);
    let (dx, dy, dz) = local(d);
    match s.opening {
        LuminousOpening::Rectangle {
            along_c0,
            along_c90,
            ..
        }
        | LuminousOpening::Disk {
            along_c0,
            along_c90,
            ..
        } => {
            // The face lies in the plane through the centre across the aim, and shines
            // along the aim: the ray must come from that side.
            if dz >= 0.0 || oz <= 0.0 {
                return None;
            }
            let t = -oz / dz;
            let (x, y) = (ox + t * dx, oy + t * dy);
            let (hx, hy) = (0.5 * along_c0, 0.5 * along_c90);
            let inside = if matches!(s.opening, LuminousOpening::Disk { .. }) {
                (x / hx).powi(2) + (y / hy).powi(2) <= 1.0
            } else {
                x.abs() <= hx && y.abs() <= hy
            };
            inside.then_some(t)
        }
        LuminousOpening::Sphere {
            along_c0,
            along_c90,
            along_aim,
        } => {
            // The unit sphere after scaling each axis by its semi-diameter.
            let (sx, sy, sz) = (0.5 * along_c0, 0.5 * along_c90, 0.5 * along_aim);
            let p = DVec3::new(ox / sx, oy / sy, oz / sz);
            let q = DVec3::new(dx / sx, dy / sy, dz / sz);
            let (qa, qb, qc) = (q.dot(q), p.dot(q), p.dot(p) - 1.0);
            let disc = qb * qb - qa * qc;
            if disc < 0.0 || qa <= 0.0 {
                return None;
            }
            let t = (-qb - disc.sqrt()) / qa;
            (t > 0.0).then_some(t)
        }
        LuminousOpening::Point => None,
    }
}
