//! Per-surface answers from a solution: area-weighted averages, extremes and the power
//! balance, with units (radiosity lm/m², illuminance lux, power lm).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::color::luminance64;
use crate::geometry::mesh::Mesh;
use crate::scene::Scene;
use crate::transport::transfer::{Power, Solution, Transfer};

/// Area-weighted averages over one surface.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct SurfaceAverage {
    /// Area, m² (both sides for two-sided surfaces).
    pub area: f64,
    /// Mean radiosity, lm/m² per channel.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub radiosity: [f64; 3],
    /// Mean incident illuminance, lux per channel.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub illuminance: [f64; 3],
}

impl SurfaceAverage {
    /// Luminous radiosity, lm/m².
    pub fn radiosity_y(&self) -> f64 {
        luminance64(self.radiosity)
    }
    /// Luminous illuminance, lux.
    pub fn illuminance_y(&self) -> f64 {
        luminance64(self.illuminance)
    }
}

/// Area-weighted averages of every surface, by name.
pub fn surface_averages(
    scene: &Scene,
    mesh: &Mesh,
    s: &Solution,
) -> BTreeMap<String, SurfaceAverage> {
    let mut out = BTreeMap::new();
    for (k, range) in mesh.surface_patches.iter().enumerate() {
        let mut a = 0f64;
        let mut b = [0f64; 3];
        let mut h = [0f64; 3];
        for i in range.clone() {
            let i = i as usize;
            let ai = mesh.patches[i].area;
            a += ai;
            for c in 0..3 {
                b[c] += ai * s.b[3 * i + c] as f64;
                h[c] += ai * s.h[3 * i + c] as f64;
            }
        }
        if a > 0.0 {
            out.insert(
                scene.surfaces[k].name.clone(),
                SurfaceAverage {
                    area: a,
                    radiosity: b.map(|x| x / a),
                    illuminance: h.map(|x| x / a),
                },
            );
        }
    }
    out
}

/// The power balance, lm: per channel and luminous totals.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema), schema(as = Power))]
pub struct PowerReport {
    /// Emitted flux per channel, lm.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub emitted: [f64; 3],
    /// Absorbed flux per channel, lm.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub absorbed: [f64; 3],
    /// Flux that escapes the scene, per channel, lm.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub escaped: [f64; 3],
    /// Luminous emitted flux, lm.
    pub emitted_lm: f64,
    /// Luminous absorbed flux, lm.
    pub absorbed_lm: f64,
    /// Luminous escaped flux, lm.
    pub escaped_lm: f64,
    /// (emitted − absorbed − escaped) / emitted, luminous.
    pub imbalance: f64,
}

impl PowerReport {
    pub fn new(p: Power) -> PowerReport {
        let (e, a, x) = (
            luminance64(p.emitted),
            luminance64(p.absorbed),
            luminance64(p.escaped),
        );
        PowerReport {
            emitted: p.emitted,
            absorbed: p.absorbed,
            escaped: p.escaped,
            emitted_lm: e,
            absorbed_lm: a,
            escaped_lm: x,
            imbalance: if e > 0.0 { (e - a - x) / e } else { 0.0 },
        }
    }
}

/// What `relight radiosity --json` prints.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub surfaces: BTreeMap<String, SurfaceAverage>,
    pub power: PowerReport,
}

impl Report {
    pub fn new(scene: &Scene, mesh: &Mesh, t: &Transfer, s: &Solution) -> Report {
        Report {
            surfaces: surface_averages(scene, mesh, s),
            power: PowerReport::new(t.power(s)),
        }
    }
}

/// An illuminance value: luminous (lux) and per channel.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct Lux {
    /// Luminous illuminance, lx.
    pub lux: f64,
    /// Per channel, lx.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub rgb: [f64; 3],
}

impl Lux {
    pub fn new(rgb: [f64; 3]) -> Lux {
        Lux {
            lux: luminance64(rgb),
            rgb,
        }
    }

    /// The value × `k`.
    pub fn scaled(&self, k: f64) -> Lux {
        Lux {
            lux: self.lux * k,
            rgb: self.rgb.map(|c| c * k),
        }
    }
}

/// Illuminance statistics of one surface: area-weighted mean, the darkest and brightest
/// patch (by luminous value), and the uniformity Emin / Eavg.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct SurfaceIlluminance {
    /// m².
    pub area: f64,
    pub avg: Lux,
    pub min: Lux,
    pub max: Lux,
    /// Emin / Eavg (luminous); 0 when the surface is unlit.
    pub uniformity: f64,
}

impl SurfaceIlluminance {
    /// Every value × `k` (k ≥ 0): the uniformity stays.
    pub fn scaled(&self, k: f64) -> SurfaceIlluminance {
        SurfaceIlluminance {
            area: self.area,
            avg: self.avg.scaled(k),
            min: self.min.scaled(k),
            max: self.max.scaled(k),
            uniformity: self.uniformity,
        }
    }
}

/// Statistics of per-patch illuminance `h` (n × 3, lux) over surface `s`.
pub fn surface_illuminance(mesh: &Mesh, s: usize, h: &[f32]) -> SurfaceIlluminance {
    let mut area = 0f64;
    let mut acc = [0f64; 3];
    let mut min: Option<Lux> = None;
    let mut max: Option<Lux> = None;
    for i in mesh.surface_patches[s].clone() {
        let i = i as usize;
        let a = mesh.patches[i].area;
        let rgb = [h[3 * i] as f64, h[3 * i + 1] as f64, h[3 * i + 2] as f64];
        area += a;
        for c in 0..3 {
            acc[c] += a * rgb[c];
        }
        let l = Lux::new(rgb);
        if min.is_none_or(|m| l.lux < m.lux) {
            min = Some(l);
        }
        if max.is_none_or(|m| l.lux > m.lux) {
            max = Some(l);
        }
    }
    let avg = Lux::new(acc.map(|x| if area > 0.0 { x / area } else { 0.0 }));
    let zero = Lux::new([0.0; 3]);
    let min = min.unwrap_or(zero);
    SurfaceIlluminance {
        area,
        avg,
        min,
        max: max.unwrap_or(zero),
        uniformity: if avg.lux > 0.0 {
            min.lux / avg.lux
        } else {
            0.0
        },
    }
}
