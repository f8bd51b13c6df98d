//! Discomfort glare at observers: the CIE 117 Unified Glare Rating for a lighting state
//! ([`crate::photometry::glare`] holds the formula and the position index).
//!
//! For each observer (an eye and a direction of view) the glare sources are the scene's
//! luminaires with a luminous opening that the eye sees unobstructed, in front of it, at
//! or above its line of sight. The background luminance is `L_b = E_ind / π`, `E_ind`
//! the illuminance at the eye on a plane facing the view from everything but the
//! luminaires themselves: the gather of the solved radiosity (lit surfaces, and emissive
//! surfaces, which are background, not glare sources). Daylight is not part of it.
//!
//! What depends only on geometry (per group, the background at unit weight; per
//! luminaire, its distance, position index, projected area and intensity towards the eye)
//! is computed once per observer and cached ([`ViewCache`]), so a new lighting state costs
//! a few products per luminaire: glare is linear in the light groups, as everything else.
//!
//! Units: luminance cd/m², illuminance lux, solid angle sr, lengths metres.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use glam::{DVec3, Vec3A};
use serde::Serialize;

use super::placed::Placed;
use super::{Lighting, Model, QueryError};
use crate::color::{Rgb, Rgb64};
use crate::photometry::glare::{guth_position_index, ugr, GlareSource};

/// Eye height above where an observer is placed, metres, when a request gives none
/// (CIE 117 and EN 12464-1: 1.2 m seated, 1.6 m standing).
pub const SEATED_EYE_HEIGHT: f64 = 1.2;
/// Most observers in one request.
pub const MAX_OBSERVERS: usize = 1_000;
/// Observers whose geometry the cache keeps, per scene.
const CACHED_VIEWS: usize = 4_096;

/// One luminaire's part in an observer's rating.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct GlareTerm {
    pub luminaire: String,
    /// Its light group's id; empty for a luminaire placed per request without a group.
    pub group: String,
    /// Luminance of its luminous area towards the eye, cd/m².
    pub luminance: f64,
    /// Solid angle of its luminous area at the eye, sr.
    pub solid_angle: f64,
    /// Guth position index p.
    pub position_index: f64,
    /// Luminous area projected towards the eye, m².
    pub projected_area: f64,
    /// Distance from the eye, m.
    pub distance: f64,
    /// `L² ω / p²`, the luminaire's share of the sum.
    pub term: f64,
}

/// The rating at one observer.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct ObserverGlare {
    /// Eye position, metres.
    pub eye: [f64; 3],
    /// Unit direction of view.
    pub direction: [f64; 3],
    /// UGR; null when no luminaire is in view or the background is black.
    #[cfg_attr(feature = "server", schema(required = true))]
    pub ugr: Option<f64>,
    /// Background luminance L_b = E_ind / π, cd/m².
    pub background_luminance: f64,
    /// Indirect illuminance at the eye facing the view, lux.
    pub indirect_illuminance: f64,
    /// The luminaires in view, largest term first.
    pub luminaires: Vec<GlareTerm>,
    /// Luminaires lit in this state but left out, each with why (behind the eye, below the
    /// line of sight, outside the field of view, hidden, or without a luminous area).
    pub left_out: Vec<LeftOut>,
}

/// A luminaire that does not count, and why.
#[derive(Debug, Clone, Serialize)]
#[cfg_attr(feature = "server", derive(utoipa::ToSchema))]
pub struct LeftOut {
    pub luminaire: String,
    pub reason: String,
}

/// What an observer sees, independent of the lighting state.
#[derive(Debug)]
pub struct ObserverView {
    eye: DVec3,
    direction: DVec3,
    /// Per light group, the indirect illuminance at the eye at unit weight (lux, RGB).
    background: Vec<Rgb64>,
    /// Luminaires that can count, with their geometry at unit weight.
    sources: Vec<Viewed>,
    /// Luminaires that cannot: (group, luminaire id, reason).
    left_out: Vec<(usize, String, String)>,
}

#[derive(Debug)]
struct Viewed {
    group: usize,
    id: String,
    /// Intensity towards the eye at unit weight, cd, and its colour (luminance 1).
    intensity: f64,
    color: Rgb,
    area: f64,
    distance: f64,
    p: f64,
}

/// Observer views by eye and direction (to the millimetre and the thousandth).
#[derive(Default)]
pub struct ViewCache(Mutex<HashMap<[i64; 6], Arc<ObserverView>>>);

impl ViewCache {
    fn key(eye: DVec3, dir: DVec3) -> [i64; 6] {
        let q = |x: f64, s: f64| (x * s).round() as i64;
        [
            q(eye.x, 1e3),
            q(eye.y, 1e3),
            q(eye.z, 1e3),
            q(dir.x, 1e3),
            q(dir.y, 1e3),
            q(dir.z, 1e3),
        ]
    }
}

impl Model {
    /// Peak bytes [`Model::glare`] takes for `observers` observers: an observer's view costs
    /// a gather once (its gather weights, a few bytes per patch); later states reuse it.
    pub fn glare_bytes(&self, observers: usize) -> u64 {
        16 * self.baked.mesh.len() as u64 * observers as u64
    }

    /// The UGR at each observer (eye, unit direction of view; metres) for a lighting state:
    /// group weights, or luminaires placed per request. A per-patch emission has no
    /// luminaires to rate (an error).
    pub fn glare(
        &self,
        observers: &[(DVec3, DVec3)],
        lighting: &Lighting,
        cancel: &super::Cancel,
    ) -> Result<Vec<ObserverGlare>, QueryError> {
        if observers.len() > MAX_OBSERVERS {
            return Err(QueryError::Invalid(format!(
                "{} observers; the limit is {MAX_OBSERVERS}",
                observers.len()
            )));
        }
        let placed = match lighting {
            Lighting::Groups(_) => None,
            Lighting::Placed(p) => Some(PlacedGlare::new(self, p)?),
            Lighting::Emission(_) => {
                return Err(QueryError::Invalid(
                    "glare rates luminaires: give light-group settings (lights) and \
                     luminaires, not a per-patch emission"
                        .into(),
                ))
            }
        };
        observers
            .iter()
            .map(|&(eye, dir)| {
                if cancel.is_cancelled() {
                    return Err(QueryError::Cancelled);
                }
                let v = self.view(eye, dir);
                Ok(match (&placed, lighting) {
                    (Some(p), _) => self.rate_placed(&v, p),
                    (None, Lighting::Groups(w)) => self.rate(&v, w),
                    (None, _) => unreachable!("placed and emission states are matched above"),
                })
            })
            .collect()
    }

    /// The observer's view, from the cache or computed (a gather and a shadow ray per
    /// luminaire).
    fn view(&self, eye: DVec3, dir: DVec3) -> Arc<ObserverView> {
        let key = ViewCache::key(eye, dir);
        if let Some(v) = lock(&self.glare_views.0).get(&key) {
            return v.clone();
        }
        let v = Arc::new(self.compute_view(eye, dir));
        let mut cache = lock(&self.glare_views.0);
        if cache.len() >= CACHED_VIEWS {
            cache.clear();
        }
        cache.insert(key, v.clone());
        v
    }

    fn compute_view(&self, eye: DVec3, dir: DVec3) -> ObserverView {
        let k = &self.baked;
        let groups = &k.transfer.groups;
        let mut importance = vec![0f32; 3 * k.mesh.len()];
        for g in groups {
            for (a, b) in importance.iter_mut().zip(&g.b) {
                *a += b;
            }
        }
        let weights =
            crate::transport::probe::gather_weights(&k.mesh, &k.bvh, &importance, eye, dir);
        let background = groups
            .iter()
            .map(|g| {
                let b = Rgb::column(&g.b);
                let mut e = Rgb64::ZERO;
                for &(j, wj) in &weights {
                    e += wj * b[j as usize].to_f64();
                }
                e
            })
            .collect();
        // The view frame: R along the view, H up, T across.
        let (up, right) = frame(dir);
        let (mut sources, mut left_out) = (Vec::new(), Vec::new());
        for (gi, g) in k.scene.lights.iter().enumerate() {
            for l in &g.luminaires {
                match viewed(&k.bvh, l, eye, dir, up, right) {
                    Ok((intensity, area, distance, p)) => sources.push(Viewed {
                        group: gi,
                        id: l.id.clone(),
                        intensity,
                        color: l.color,
                        area,
                        distance,
                        p,
                    }),
                    Err(reason) => left_out.push((gi, l.id.clone(), reason.to_string())),
                }
            }
        }
        ObserverView {
            eye,
            direction: dir,
            background,
            sources,
            left_out,
        }
    }

    /// The rating of one view under weights `w`.
    fn rate(&self, v: &ObserverView, w: &[Rgb]) -> ObserverGlare {
        let lights = &self.baked.scene.lights;
        let mut e = Rgb64::ZERO;
        for (&bg, wg) in v.background.iter().zip(w) {
            e += bg * wg.to_f64();
        }
        let e_ind = e.luminance().max(0.0);
        let lit = |g: usize, color: &Rgb| {
            let wg = w.get(g).copied().unwrap_or(Rgb::ZERO);
            (wg * *color).to_f64().luminance()
        };
        let terms: Vec<GlareTerm> = v
            .sources
            .iter()
            .filter_map(|s| {
                let i = s.intensity * lit(s.group, &s.color);
                let group = lights[s.group].id.clone();
                (i > 0.0).then(|| term(s.id.clone(), group, i, s.area, s.distance, s.p))
            })
            .collect();
        let left_out = v
            .left_out
            .iter()
            .filter(|(g, _, _)| w.get(*g).is_some_and(|c| c.iter().any(|&x| x > 0.0)))
            .map(|(_, id, reason)| LeftOut {
                luminaire: id.clone(),
                reason: reason.clone(),
            })
            .collect();
        rated(v, e_ind, terms, left_out)
    }

    /// The rating of one view under a state with luminaires placed per request: the
    /// background is the groups' at their weights plus the changes' interreflected light
    /// gathered at the eye, and the sources are the luminaires that shine in the state
    /// (their geometry towards this eye computed now, as they may have moved).
    fn rate_placed(&self, v: &ObserverView, p: &PlacedGlare) -> ObserverGlare {
        let k = &self.baked;
        let mut e = Rgb64::ZERO;
        for (&bg, wg) in v.background.iter().zip(&p.weights) {
            e += bg * wg.to_f64();
        }
        if let Some(extra) = &p.extra_b {
            let b = Rgb::column(extra);
            let weights = crate::transport::probe::gather_weights(
                &k.mesh,
                &k.bvh,
                &p.importance,
                v.eye,
                v.direction,
            );
            for (j, wj) in weights {
                e += wj * b[j as usize].to_f64();
            }
        }
        let e_ind = e.luminance().max(0.0);
        let (up, right) = frame(v.direction);
        let (mut terms, mut left_out) = (Vec::new(), Vec::new());
        for (l, group) in &p.lit {
            match viewed(&k.bvh, l, v.eye, v.direction, up, right) {
                Ok((intensity, area, distance, pi)) => {
                    let i = intensity * l.color.to_f64().luminance();
                    if i > 0.0 {
                        let group = group.map_or(String::new(), |g| k.scene.lights[g].id.clone());
                        terms.push(term(l.id.clone(), group, i, area, distance, pi));
                    }
                }
                Err(reason) => left_out.push(LeftOut {
                    luminaire: l.id.clone(),
                    reason: reason.to_string(),
                }),
            }
        }
        rated(v, e_ind, terms, left_out)
    }
}

/// What a placed state's ratings share over its observers.
struct PlacedGlare {
    weights: Vec<Rgb>,
    /// The luminaires that shine, colour × weight, with their groups ([`Placed::lit`]).
    lit: Vec<(crate::photometry::Luminaire, Option<usize>)>,
    /// The changes' radiosity (lm/m², n × 3), when there are changes, and where a gather
    /// at an eye looks for it.
    extra_b: Option<Vec<f32>>,
    importance: Vec<f32>,
}

impl PlacedGlare {
    fn new(m: &Model, p: &Placed) -> Result<PlacedGlare, QueryError> {
        let extra_b = if p.changes.is_empty() {
            None
        } else {
            Some(m.placed_parts(p)?.1)
        };
        let importance = extra_b
            .as_ref()
            .map(|b| b.iter().map(|v| v.abs()).collect())
            .unwrap_or_default();
        Ok(PlacedGlare {
            weights: p.weights.clone(),
            lit: p.lit_in_groups(&m.baked.scene),
            extra_b,
            importance,
        })
    }
}

/// A luminaire's glare term: its intensity towards the eye `i` (cd, at its weight) over
/// its projected luminous area (m²) at `distance` (m) with position index `p`.
fn term(luminaire: String, group: String, i: f64, area: f64, distance: f64, p: f64) -> GlareTerm {
    let src = GlareSource {
        luminance: i / area,
        solid_angle: area / (distance * distance),
        position_index: p,
    };
    GlareTerm {
        luminaire,
        group,
        luminance: src.luminance,
        solid_angle: src.solid_angle,
        position_index: p,
        projected_area: area,
        distance,
        term: src.term(),
    }
}

/// The rating of view `v` from its indirect illuminance at the eye (lux) and its terms.
fn rated(
    v: &ObserverView,
    e_ind: f64,
    mut terms: Vec<GlareTerm>,
    left_out: Vec<LeftOut>,
) -> ObserverGlare {
    let lb = e_ind / std::f64::consts::PI;
    terms.sort_by(|a, b| b.term.total_cmp(&a.term));
    let rating = ugr(
        lb,
        terms.iter().map(|t| GlareSource {
            luminance: t.luminance,
            solid_angle: t.solid_angle,
            position_index: t.position_index,
        }),
    );
    ObserverGlare {
        eye: v.eye.to_array(),
        direction: v.direction.to_array(),
        ugr: rating,
        background_luminance: lb,
        indirect_illuminance: e_ind,
        luminaires: terms,
        left_out,
    }
}

/// The view frame of a direction of view: H up (world +y, made perpendicular to it) and
/// T across.
fn frame(dir: DVec3) -> (DVec3, DVec3) {
    let up = (DVec3::Y - dir * DVec3::Y.dot(dir))
        .try_normalize()
        .unwrap_or(DVec3::Z);
    (up, dir.cross(up))
}

/// A luminaire's intensity towards the eye at unit weight (cd), projected luminous area
/// (m²), distance (m) and position index, or why it does not count.
fn viewed(
    bvh: &crate::geometry::bvh::Bvh,
    l: &crate::photometry::Luminaire,
    eye: DVec3,
    dir: DVec3,
    up: DVec3,
    right: DVec3,
) -> Result<(f64, f64, f64, f64), &'static str> {
    let v = l.position - eye;
    let distance = v.length();
    let (r, h, t) = (v.dot(dir), v.dot(up), v.dot(right));
    if r <= 1e-9 {
        return Err("behind the eye");
    }
    if h < 0.0 {
        return Err("below the line of sight");
    }
    let p = guth_position_index(h / r, t / r).ok_or("outside the field of view")?;
    let to_eye = -v / distance;
    let area = l
        .opening
        .projected_area(to_eye.dot(l.aim), to_eye.dot(l.c0), to_eye.dot(l.c90()));
    if area <= 0.0 {
        return Err("no luminous area towards the eye (a point source, or seen from behind)");
    }
    // Stop a millimetre short: the luminaire often sits on the ceiling's surface.
    let end = l.position - v / distance * 1e-3;
    if bvh.occluded(
        Vec3A::from(eye.as_vec3()),
        Vec3A::from(end.as_vec3()),
        [u32::MAX; 2],
    ) {
        return Err("hidden from the eye");
    }
    Ok((l.intensity(to_eye), area, distance, p))
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
