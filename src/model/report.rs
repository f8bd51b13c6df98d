//! Per-surface answers from a solution: area-weighted averages, extremes and the power
//! balance, with units (radiosity lm/m², illuminance lux, power lm).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::color::{Rgb, Rgb64};
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
    pub radiosity: Rgb64,
    /// Mean incident illuminance, lux per channel.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub illuminance: Rgb64,
}

impl SurfaceAverage {
    /// Luminous radiosity, lm/m².
    pub fn radiosity_y(&self) -> f64 {
        self.radiosity.luminance()
    }
    /// Luminous illuminance, lux.
    pub fn illuminance_y(&self) -> f64 {
        self.illuminance.luminance()
    }
}

/// Area-weighted averages of every surface, by name.
pub fn surface_averages(
    scene: &Scene,
    mesh: &Mesh,
    s: &Solution,
) -> BTreeMap<String, SurfaceAverage> {
    let mut out = BTreeMap::new();
    let (sb, sh) = (Rgb::column(&s.b), Rgb::column(&s.h));
    for (k, range) in mesh.surface_patches.iter().enumerate() {
        let mut a = 0f64;
        let mut b = Rgb64::ZERO;
        let mut h = Rgb64::ZERO;
        for i in range.clone() {
            let i = i as usize;
            let ai = mesh.patches[i].area;
            a += ai;
            b += ai * sb[i].to_f64();
            h += ai * sh[i].to_f64();
        }
        if a > 0.0 {
            out.insert(
                scene.surfaces[k].name.clone(),
                SurfaceAverage {
                    area: a,
                    radiosity: b / a,
                    illuminance: h / a,
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
    pub emitted: Rgb64,
    /// Absorbed flux per channel, lm.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub absorbed: Rgb64,
    /// Flux that escapes the scene, per channel, lm.
    #[cfg_attr(feature = "server", schema(value_type = crate::schema::Rgb))]
    pub escaped: Rgb64,
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
            p.emitted.luminance(),
            p.absorbed.luminance(),
            p.escaped.luminance(),
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
    pub rgb: Rgb64,
}

impl Lux {
    pub fn new(rgb: Rgb64) -> Lux {
        Lux {
            lux: rgb.luminance(),
            rgb,
        }
    }

    /// The value × `k`.
    pub fn scaled(&self, k: f64) -> Lux {
        Lux {
            lux: self.lux * k,
            rgb: self.rgb * k,
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
    let h = Rgb::column(h);
    let mut area = 0f64;
    let mut acc = Rgb64::ZERO;
    let mut min: Option<Lux> = None;
    let mut max: Option<Lux> = None;
    for i in mesh.surface_patches[s].clone() {
        let i = i as usize;
        let a = mesh.patches[i].area;
        let rgb = h[i].to_f64();
        area += a;
        acc += a * rgb;
        let l = Lux::new(rgb);
        if min.is_none_or(|m| l.lux < m.lux) {
            min = Some(l);
        }
        if max.is_none_or(|m| l.lux > m.lux) {
            max = Some(l);
        }
    }
    let avg = Lux::new(acc.map(|x| if area > 0.0 { x / area } else { 0.0 }));
    let zero = Lux::new(Rgb64::ZERO);
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
