//! Luminaires placed for one request: added, moved, re-aimed, swapped or removed without a
//! bake.
//!
//! The scene's light groups stay as baked. A request's `luminaires` become a list of
//! [`LuminaireChange`]s, each a luminaire with the RGB weight its light counts at: an added
//! one at its group's weight (1 without a group), a scene luminaire that is moved, swapped
//! or removed once at minus its group's weight (its baked light taken out) and, unless
//! removed, once more as rebuilt at the weight of its group. The changes' direct light is
//! traced per request, on patches as the bake does and exactly at points, and its
//! interreflection solved through the transfer ([`crate::model::Model::solve`]): light is
//! linear, so the answer is the groups' plus the changes'.

use glam::DVec3;
use rayon::prelude::*;

use super::lighting::Lighting;
use super::query::{IlluminanceAnswer, IlluminanceQuery, Maintained};
use super::{Cancel, Model};
use crate::transport::transfer::Solution;

use super::error::{known_list, shorten, QueryError};
use crate::color::{Rgb, Rgb64};
use crate::input_limits::{
    MAX_CCT, MAX_COLOR, MAX_INLINE_PHOTOMETRY_BYTES, MAX_LUMENS, MAX_PLACED_LUMINAIRE_PATCHES,
    MAX_REQUEST_LUMINAIRES, MAX_TEXT_BYTES, MAX_WATTS, MIN_CCT,
};
use crate::photometry::{
    cct_to_rgb, parse_ies_file, parse_ldt_file, Distribution, Luminaire, LuminaireSpec,
};
use crate::scene::Scene;

/// Where a placed luminaire's photometry comes from.
#[derive(Debug, Clone)]
pub enum Photometry {
    /// An IES or EULUMDAT (`.ldt`) file of the scene folder.
    File(String),
    /// IES LM-63 text.
    Ies(String),
    /// EULUMDAT text.
    Ldt(String),
}

/// One entry of a request's `luminaires`: a new luminaire (an id the scene does not have),
/// or changes to one of the scene's (its id). What an edit leaves out keeps the scene
/// luminaire's value; a new one needs a position, and lumens unless its photometry gives
/// absolute candela.
#[derive(Debug, Clone, Default)]
pub struct LuminairePlacement {
    pub id: String,
    /// Photometric centre, metres.
    pub position: Option<[f64; 3]>,
    /// Photometric axis (default straight down, −Y).
    pub aim: Option<[f64; 3]>,
    /// Direction of C = 0°.
    pub c0: Option<[f64; 3]>,
    pub photometry: Option<Photometry>,
    /// Total flux, lm.
    pub lumens: Option<f64>,
    /// Colour temperature, K (or `color`).
    pub cct: Option<f64>,
    /// Linear RGB colour.
    pub color: Option<[f64; 3]>,
    /// Light group whose setting scales it (a new luminaire without one counts at 1).
    pub group: Option<String>,
    /// Electrical power, W.
    pub watts: Option<f64>,
    /// Take the scene's luminaire out.
    pub remove: bool,
    /// The request gave more than one of `photometry`, `ies` and `ldt` (refused).
    pub several_photometries: bool,
}

/// A luminaire's light counted at an RGB weight (negative for light taken out).
#[derive(Debug, Clone)]
pub struct LuminaireChange {
    pub luminaire: Luminaire,
    pub weight: Rgb,
    /// The light group whose setting and maintenance factor it takes (none for a new
    /// luminaire given no group).
    pub group: Option<usize>,
    /// Whether it takes a scene luminaire's light out (moved, changed or removed), at
    /// minus its group's weight.
    pub taken_out: bool,
    /// The photometry it was given for the request: a file of the scene folder, or
    /// `inline IES` / `inline EULUMDAT` (None: the scene's own, unchanged).
    pub photometry: Option<String>,
}

/// A lighting state with luminaires placed for the request: the groups' weights and the
/// changes.
#[derive(Debug, Clone, Default)]
pub struct Placed {
    pub weights: Vec<Rgb>,
    pub changes: Vec<LuminaireChange>,
}

impl Placed {
    /// The luminaires of the changes, with their weights (for the direct light).
    pub fn luminaires(&self) -> impl Iterator<Item = (&Luminaire, Rgb)> + Clone + Sync {
        self.changes.iter().map(|c| (&c.luminaire, c.weight))
    }

    /// The state under maintenance factors: each group's weight × its factor `groups[g]`,
    /// each change's × its group's (or `other` for a luminaire without a group).
    pub fn maintained(&self, groups: &[f64], other: f64) -> Placed {
        let mf = |g: Option<usize>| g.and_then(|g| groups.get(g).copied()).unwrap_or(other);
        Placed {
            weights: super::compliance::maintained_weights(&self.weights, groups),
            changes: self
                .changes
                .iter()
                .map(|c| LuminaireChange {
                    weight: (c.weight.to_f64() * mf(c.group)).to_f32(),
                    ..c.clone()
                })
                .collect(),
        }
    }

    /// Every luminaire that shines in this state, its colour times its weight: the scene's
    /// (of `scene`, whose groups `weights` follows) less those taken out, and the changes
    /// put in. None at zero weight. What per-pixel direct light traces
    /// ([`crate::render::pipeline::final_state_image`]), where signed light would not do.
    pub fn lit(&self, scene: &Scene) -> Vec<Luminaire> {
        self.lit_in_groups(scene)
            .into_iter()
            .map(|(l, _)| l)
            .collect()
    }

    /// [`Placed::lit`], each luminaire with the light group it belongs to (none for a new
    /// luminaire given no group).
    pub fn lit_in_groups(&self, scene: &Scene) -> Vec<(Luminaire, Option<usize>)> {
        self.weighted(scene)
            .into_iter()
            .filter(|(_, _, _, w)| w.max_component() > 0.0)
            .map(|(l, group, _, w)| {
                let mut l = l.clone();
                l.color *= w;
                (l, group)
            })
            .collect()
    }

    /// Every luminaire installed in this state, lit or not: the scene's less those taken
    /// out, then those put in, each with its group and the photometry given for the
    /// request ([`LuminaireChange::photometry`]; None for the scene's own).
    pub fn installed<'a>(
        &'a self,
        scene: &'a Scene,
    ) -> Vec<(&'a Luminaire, Option<usize>, Option<&'a str>)> {
        self.weighted(scene)
            .into_iter()
            .map(|(l, group, file, _)| (l, group, file))
            .collect()
    }

    /// [`Placed::installed`], each with the weight its light counts at: its group's for
    /// the scene's own, the change's for one put in.
    fn weighted<'a>(
        &'a self,
        scene: &'a Scene,
    ) -> Vec<(&'a Luminaire, Option<usize>, Option<&'a str>, Rgb)> {
        let out: std::collections::HashSet<&str> = self
            .changes
            .iter()
            .filter(|c| c.taken_out)
            .map(|c| c.luminaire.id.as_str())
            .collect();
        let scene_ones = scene.lights.iter().enumerate().flat_map(|(k, g)| {
            let w = self.weights.get(k).copied().unwrap_or(Rgb::ZERO);
            g.luminaires
                .iter()
                .filter(|l| !out.contains(l.id.as_str()))
                .map(move |l| (l, Some(k), None, w))
        });
        let put_in = self.changes.iter().filter(|c| !c.taken_out);
        scene_ones
            .chain(put_in.map(|c| (&c.luminaire, c.group, c.photometry.as_deref(), c.weight)))
            .collect()
    }

    /// Flux (lm) and electrical power (W) of the luminaires that shine in this state
    /// (of `scene`): each one's lumens times its weight's luminous level, and its watts
    /// likewise (dimming assumed proportional); watts null when a lit one gives none.
    pub fn power(&self, scene: &Scene) -> super::query::LuminairePower {
        let (mut lumens, mut watts, mut known) = (0.0, 0.0, true);
        for (l, _) in self.lit_in_groups(scene) {
            // Its colour is its own (luminance 1) times its weight.
            let level = l.color.to_f64().luminance();
            lumens += l.lumens * level;
            match l.watts {
                Some(w) => watts += w * level,
                None => known = false,
            }
        }
        super::query::LuminairePower {
            luminaire_lumens: lumens,
            luminaire_watts: known.then_some(watts),
        }
    }

    /// The lowest colour rendering index Ra of what shines in this state: the lit groups'
    /// (of `scene`) and the groups of the luminaires put in; `Err` names the groups
    /// without an Ra, and the luminaires put in without a group (whose Ra is unknown).
    pub fn lit_ra(&self, scene: &Scene) -> Result<Option<f64>, Vec<String>> {
        let mut w = self.weights.clone();
        let mut unknown = Vec::new();
        for c in self.changes.iter().filter(|c| !c.taken_out) {
            match c.group {
                Some(g) => w[g] += c.weight.map(f32::abs),
                None => unknown.push(format!(
                    "{} (a luminaire placed without a group)",
                    c.luminaire.id
                )),
            }
        }
        match (super::compliance::lit_ra(scene, &w), unknown.is_empty()) {
            (Ok(ra), true) => Ok(ra),
            (Ok(_), false) => Err(unknown),
            (Err(mut groups), _) => {
                groups.extend(unknown);
                Err(groups)
            }
        }
    }

    /// The maintenance factor every light of this state takes, when they all take the
    /// same one ([`Placed::maintained`]'s factors: `groups[g]` for the lit groups and the
    /// changes in them, `other` for a change without a group); None when they differ.
    pub fn common_factor(&self, groups: &[f64], other: f64) -> Option<f64> {
        let lit_groups = self
            .weights
            .iter()
            .enumerate()
            .filter(|(_, w)| w.iter().any(|&c| c != 0.0))
            .map(|(g, _)| groups.get(g).copied().unwrap_or(other));
        let changes = self.changes.iter().map(|c| {
            c.group
                .and_then(|g| groups.get(g).copied())
                .unwrap_or(other)
        });
        let mut all = lit_groups.chain(changes);
        let first = all.next()?;
        all.all(|f| f == first).then_some(first)
    }

    /// Σ weight × lumens × colour over the changes, lm per channel.
    pub fn flux(&self) -> Rgb64 {
        self.luminaires()
            .map(|(l, w)| w.to_f64() * l.color.to_f64() * l.lumens)
            .sum()
    }
}

/// The scene luminaire `id`: its group and itself.
fn scene_luminaire<'a>(scene: &'a Scene, id: &str) -> Option<(usize, &'a Luminaire)> {
    scene
        .lights
        .iter()
        .enumerate()
        .find_map(|(g, group)| group.luminaires.iter().find(|l| l.id == id).map(|l| (g, l)))
}

/// Resolves a request's `luminaires` against `scene` (of `patches` patches) under group
/// weights `weights`. Every problem is a [`QueryError::Invalid`] naming the entry
/// (`luminaires[i]`) and field; nothing is traced before every entry has passed, and the
/// tracing is bounded by [`MAX_PLACED_LUMINAIRE_PATCHES`].
pub fn place(
    scene: &Scene,
    patches: usize,
    weights: Vec<Rgb>,
    edits: &[LuminairePlacement],
) -> Result<Placed, QueryError> {
    if edits.len() > MAX_REQUEST_LUMINAIRES {
        return Err(QueryError::Invalid(format!(
            "luminaires: {} entries; at most {MAX_REQUEST_LUMINAIRES} per request",
            edits.len()
        )));
    }
    let mut changes = Vec::with_capacity(2 * edits.len());
    let mut seen = std::collections::HashSet::new();
    for (i, e) in edits.iter().enumerate() {
        let at = format!("luminaires[{i}]");
        let bad = |m: String| QueryError::Invalid(format!("{at} ('{}'): {m}", shorten(&e.id)));
        if e.id.is_empty() || !seen.insert(e.id.as_str()) {
            return Err(bad("id is empty or used twice in this request".into()));
        }
        check_numbers(scene, e).map_err(bad)?;
        entry_changes(scene, &weights, e, &at, &mut changes).map_err(bad)?;
    }
    let work = changes.len() as u64 * patches as u64;
    if work > MAX_PLACED_LUMINAIRE_PATCHES {
        return Err(QueryError::Invalid(format!(
            "luminaires: {} luminaire changes × {patches} patches = {work} direct-light \
             traces; at most {MAX_PLACED_LUMINAIRE_PATCHES} per request",
            changes.len()
        )));
    }
    Ok(Placed { weights, changes })
}

/// The changes of one checked entry (`at` names it), pushed onto `changes`: a scene
/// luminaire's light taken out and, unless removed, put back rebuilt; or a new luminaire.
fn entry_changes(
    scene: &Scene,
    weights: &[Rgb],
    e: &LuminairePlacement,
    at: &str,
    changes: &mut Vec<LuminaireChange>,
) -> Result<(), String> {
    let group_weight = |id: &str| {
        scene
            .light_index(id)
            .map(|g| (weights[g], Some(g)))
            .ok_or_else(|| {
                format!(
                    "group '{}' is not a light group of the scene (known: {})",
                    shorten(id),
                    known_list(scene.lights.iter().map(|l| l.id.as_str()))
                )
            })
    };
    let (luminaire, (weight, group)) = match scene_luminaire(scene, &e.id) {
        Some((g, old)) => {
            changes.push(LuminaireChange {
                luminaire: old.clone(),
                weight: weights[g] * -1.0,
                group: Some(g),
                taken_out: true,
                photometry: None,
            });
            if e.remove {
                return Ok(());
            }
            let weight = match &e.group {
                Some(id) => group_weight(id)?,
                None => (weights[g], Some(g)),
            };
            (rebuild(scene, old, e, at)?, weight)
        }
        None if e.remove => {
            return Err(format!(
                "is not a luminaire of the scene, so it cannot be removed (known: {})",
                known_list(
                    scene
                        .lights
                        .iter()
                        .flat_map(|g| g.luminaires.iter().map(|l| l.id.as_str()))
                )
            ))
        }
        None => {
            let weight = match &e.group {
                Some(id) => group_weight(id)?,
                None => (Rgb::ONE, None),
            };
            (build(scene, e, at)?, weight)
        }
    };
    let photometry = e.photometry.as_ref().map(|p| match p {
        Photometry::File(name) => name.clone(),
        Photometry::Ies(_) => "inline IES".to_string(),
        Photometry::Ldt(_) => "inline EULUMDAT".to_string(),
    });
    changes.push(LuminaireChange {
        luminaire,
        weight,
        group,
        taken_out: false,
        photometry,
    });
    Ok(())
}

/// Ranges of an entry's numbers, and its position inside the scene's bounds.
fn check_numbers(scene: &Scene, e: &LuminairePlacement) -> Result<(), String> {
    let finite3 = |v: &Option<[f64; 3]>| v.is_none_or(|v| v.iter().all(|x| x.is_finite()));
    if !finite3(&e.position) || !finite3(&e.aim) || !finite3(&e.c0) {
        return Err("position, aim and c0 must be finite numbers".into());
    }
    if let Some(p) = e.position {
        let (lo, hi) = scene.bounds();
        let margin = 1e-3 * (hi - lo).length();
        let p = DVec3::from_array(p);
        if p.cmplt(lo - margin).any() || p.cmpgt(hi + margin).any() {
            return Err(format!(
                "position {:?} m is outside the scene's bounds {:?} .. {:?} m",
                p.to_array(),
                lo.to_array(),
                hi.to_array()
            ));
        }
    }
    let in_range = |name: &str, v: Option<f64>, lo: f64, hi: f64| match v {
        Some(x) if !(x.is_finite() && (lo..=hi).contains(&x)) => {
            Err(format!("{name} = {x}: must be in [{lo}, {hi}]"))
        }
        _ => Ok(()),
    };
    in_range("lumens", e.lumens, 0.0, MAX_LUMENS)?;
    in_range("watts", e.watts, 0.0, MAX_WATTS)?;
    in_range("cct", e.cct, MIN_CCT, MAX_CCT)?;
    if let Some(c) = e.color {
        if c.iter()
            .any(|x| !(x.is_finite() && (0.0..=MAX_COLOR).contains(x)))
        {
            return Err(format!(
                "color {c:?}: each channel must be in [0, {MAX_COLOR}]"
            ));
        }
    }
    if e.several_photometries {
        return Err("give one of photometry, ies and ldt".into());
    }
    if e.color.is_some() && e.cct.is_some() {
        return Err("give color or cct, not both".into());
    }
    Ok(())
}

/// The entry's colour, if it gives one.
fn color_of(e: &LuminairePlacement) -> Option<Rgb> {
    match (e.color, e.cct) {
        (Some(c), _) => Some(Rgb64(c).to_f32()),
        (None, Some(k)) => Some(cct_to_rgb(k)),
        (None, None) => None,
    }
}

/// The distribution of a request's photometry (`at` names the entry in messages).
fn distribution(scene: &Scene, p: &Photometry, at: &str) -> Result<Distribution, String> {
    let too_long = |what: &str, len: usize| {
        format!("{what}: {len} bytes of photometry; at most {MAX_INLINE_PHOTOMETRY_BYTES}")
    };
    let table = match p {
        Photometry::Ies(text) => {
            if text.len() > MAX_INLINE_PHOTOMETRY_BYTES {
                return Err(too_long("ies", text.len()));
            }
            parse_ies_file(std::path::Path::new(&format!("{at}.ies")), text)
        }
        Photometry::Ldt(text) => {
            if text.len() > MAX_INLINE_PHOTOMETRY_BYTES {
                return Err(too_long("ldt", text.len()));
            }
            parse_ldt_file(std::path::Path::new(&format!("{at}.ldt")), text, None)
        }
        Photometry::File(name) => {
            let dir = crate::scene::files::SceneDir::open(&scene.dir).map_err(|e| e.to_string())?;
            let path = dir
                .resolve(name, std::path::Path::new("request"), 0, "photometry")
                .map_err(|e| match e {
                    // Not a line of a file: the caller names the entry.
                    crate::scene::SceneError::Reference { name, problem, .. } => {
                        format!("photometry '{}' {problem}", shorten(&name))
                    }
                    other => other.to_string(),
                })?;
            let bytes = dir.read(&path, MAX_TEXT_BYTES).map_err(|e| e.to_string())?;
            let text = String::from_utf8_lossy(&bytes);
            let shown = dir.display(&path);
            let ldt = path
                .extension()
                .is_some_and(|x| x.eq_ignore_ascii_case("ldt"));
            if ldt {
                parse_ldt_file(&shown, &text, None)
            } else {
                parse_ies_file(&shown, &text)
            }
        }
    };
    Ok(Distribution::Table(Box::new(
        table.map_err(|e| e.to_string())?,
    )))
}

/// A new luminaire from its entry.
fn build(scene: &Scene, e: &LuminairePlacement, at: &str) -> Result<Luminaire, String> {
    let position = e
        .position
        .ok_or("a new luminaire needs a position (or name one of the scene's by id)")?;
    let distribution = match &e.photometry {
        Some(p) => distribution(scene, p, at)?,
        None => Distribution::Isotropic,
    };
    let v = |a: [f64; 3]| DVec3::from_array(a);
    let mut l = Luminaire::new(LuminaireSpec {
        id: &e.id,
        position: v(position),
        aim: v(e.aim.unwrap_or([0.0, -1.0, 0.0])),
        c0: e.c0.map(v),
        distribution,
        lumens: e.lumens,
        color: color_of(e).unwrap_or(Rgb::ONE),
        watts: None,
    })?;
    if e.watts.is_some() {
        l.watts = e.watts;
    }
    Ok(l)
}

/// Scene luminaire `old` with the entry's changes.
fn rebuild(
    scene: &Scene,
    old: &Luminaire,
    e: &LuminairePlacement,
    at: &str,
) -> Result<Luminaire, String> {
    let distribution = match &e.photometry {
        Some(p) => distribution(scene, p, at)?,
        None => old.distribution.clone(),
    };
    // A swapped photometry brings its own flux unless lumens are given; a kept one keeps
    // the scene's (before the tilt factor of the old aim).
    let lumens = match (e.lumens, &e.photometry) {
        (Some(l), _) => Some(l),
        (None, Some(_)) => None,
        (None, None) => Some(old.lumens / old.tilt_factor),
    };
    let v = |a: [f64; 3]| DVec3::from_array(a);
    let aim = e.aim.map_or(old.aim, v);
    // A new aim keeps the old C = 0° where it still stands apart from the aim.
    let c0 = match e.c0 {
        Some(c) => Some(v(c)),
        None if old.c0.dot(aim.normalize_or_zero()).abs() < 0.99 => Some(old.c0),
        None => None,
    };
    let mut l = Luminaire::new(LuminaireSpec {
        id: &old.id,
        position: e.position.map_or(old.position, v),
        aim,
        c0,
        distribution,
        lumens,
        color: color_of(e).unwrap_or(old.color),
        watts: None,
    })?;
    l.watts = e.watts.or(if e.photometry.is_some() {
        l.watts
    } else {
        old.watts
    });
    Ok(l)
}

impl Model {
    /// The solution of a state with luminaires placed for the request, and the radiosity
    /// (n × 3) of the changes' light alone: the changes' direct light D, its first
    /// reflection ρD as a source, and the interreflection of that, added to the groups':
    /// B = base + solve(ρD), H = base + D + solve's H.
    pub(super) fn placed_parts(&self, p: &Placed) -> Result<(Solution, Vec<f32>), QueryError> {
        self.require_factored()?;
        let t = &self.baked.transfer;
        let base = t.relight(&p.weights);
        if p.changes.is_empty() {
            let none = vec![0f32; base.b.len()];
            return Ok((base, none));
        }
        let k = &self.baked;
        let d = crate::transport::direct::weighted_direct(&k.mesh, &k.bvh, p.luminaires());
        let mut source = d.clone();
        for (s, rho) in Rgb::column_mut(&mut source).iter_mut().zip(&t.rho) {
            *s *= *rho;
        }
        let extra = t.solve(&source).ok_or_else(|| {
            QueryError::Invalid("this scene's transfer cannot solve an emission".into())
        })?;
        let mut sol = base;
        for (b, x) in sol.b.iter_mut().zip(&extra.b) {
            *b += x;
        }
        for ((h, x), dd) in sol.h.iter_mut().zip(&extra.h).zip(&d) {
            *h += x + dd;
        }
        let mut landed = Rgb64::ZERO;
        for (&a, dd) in t.area.iter().zip(Rgb::column(&d)) {
            landed += a as f64 * dd.to_f64();
        }
        let flux = p.flux();
        sol.luminaire_flux += flux;
        // Sampled direct light may land a hair more than the flux: never below zero, as
        // for the groups.
        sol.direct_escaped = (sol.direct_escaped + flux - landed).map(|v| v.max(0.0));
        Ok((sol, extra.b))
    }

    /// Grid `gi`'s luminous illuminance (lx) at every point under a placed state: the
    /// groups' stored responses at their weights, the changes' direct light traced per
    /// point, and their interreflected light `extra_b` through the grid's baked gather
    /// weights ([`crate::transport::probe::GridGather`]).
    pub(super) fn placed_grid_values(
        &self,
        gi: usize,
        p: &Placed,
        extra_b: &[f32],
        cancel: &Cancel,
    ) -> Vec<f32> {
        let k = &self.baked;
        let g = &self.grids[gi];
        let mut base = vec![0f32; 3 * g.len()];
        crate::transport::transfer::weighted_sum(
            g.per_group.iter().map(|c| c.as_slice()),
            &p.weights,
            &mut base,
        );
        let n = DVec3::from_array(g.grid.normal);
        g.grid
            .points
            .par_iter()
            .zip(Rgb::column(&base).par_iter())
            .enumerate()
            .map(|(i, (x, b))| {
                if cancel.is_cancelled() {
                    return 0.0;
                }
                let x = DVec3::from_array(*x);
                let mut e = b.to_f64();
                e += crate::transport::direct::weighted_point_illuminance(
                    &k.bvh,
                    p.luminaires(),
                    x,
                    n,
                );
                e += g.gather.indirect(i, extra_b, &k.mesh, &k.bvh, x, n);
                e.luminance() as f32
            })
            .collect()
    }

    /// [`Model::illuminance`] with luminaires placed for the request: the state solved as
    /// it is and again under the maintenance factors (each group's weight and each change
    /// by its group's factor, a luminaire without a group by the scene's), which the
    /// maintained answers and the compliance read.
    pub(super) fn placed_illuminance(
        &self,
        p: &Placed,
        q: &IlluminanceQuery,
        cancel: &Cancel,
    ) -> Result<IlluminanceAnswer, QueryError> {
        let factors = self.factors(q);
        let mut a = self.solved_illuminance(&Lighting::Placed(p.clone()), q, cancel)?;
        a.maintained = match p.common_factor(&factors.groups, factors.emission) {
            // Every light of the state takes the same factor: the answer scaled, as a
            // second solve would give it (light is linear), at no cost.
            Some(mf) => Maintained {
                points: a.points.iter().map(|x| x.scaled(mf)).collect(),
                surfaces: a
                    .surfaces
                    .iter()
                    .map(|(k, s)| (k.clone(), s.scaled(mf)))
                    .collect(),
                grids: a
                    .grids
                    .iter()
                    .map(|(k, g)| (k.clone(), g.scaled(mf)))
                    .collect(),
            },
            None => {
                let pm = p.maintained(&factors.groups, factors.emission);
                let m = self.solved_illuminance(&Lighting::Placed(pm), q, cancel)?;
                Maintained {
                    points: m.points,
                    surfaces: m.surfaces,
                    grids: m.grids,
                }
            }
        };
        a.compliance = self.compliance(
            q,
            Some(&Lighting::Placed(p.clone())),
            &a.maintained.grids,
            cancel,
        )?;
        a.power = Some(p.power(&self.baked.scene));
        let groups = self.baked.scene.lights.iter().map(|g| g.id.clone());
        a.maintenance_factors = groups
            .zip(factors.groups)
            .chain([("placed".to_string(), factors.emission)])
            .collect();
        Ok(a)
    }
}
