//! Luminaire placement: each `[[luminaires]]` entry of `scene.toml` becomes a
//! [`Luminaire`] (position in metres, flux in lm, spot angles in degrees, colour from RGB
//! or a colour temperature in K, power in W) in its light group, creating groups that
//! `[[lights]]` does not define. A luminaire's power is its `watts`, else its lumens over
//! its `efficacy`, else its photometric file's input watts (IES) or lamp-set wattage
//! (EULUMDAT), else unknown. Photometric files (IES LM-63, EULUMDAT) are resolved inside
//! the scene folder, read once per file and lamp set, and join the scene's files for the
//! cache key.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use glam::DVec3;

use super::files::SceneDir;
use super::lights::LightGroup;
use super::toml::LuminaireToml;
use super::{SceneError, SceneToml};
use crate::color::Rgb;
use crate::input_limits::{MAX_CCT, MAX_TEXT_BYTES, MIN_CCT};
use crate::photometry::{
    cct_to_rgb, parse_ies_file, parse_ldt_file, CandelaTable, Distribution, Luminaire,
    LuminaireSpec,
};

/// `scene.toml` as luminaires see it: to resolve `ies` references with their line.
pub(crate) struct TomlRef<'a> {
    pub(crate) dir: &'a SceneDir,
    pub(crate) path: &'a Path,
    /// Byte offsets of the text's newlines.
    newlines: Vec<usize>,
}

impl<'a> TomlRef<'a> {
    /// The file `path` (display name) of folder `dir`, with text `text`.
    pub(crate) fn new(dir: &'a SceneDir, path: &'a Path, text: &str) -> TomlRef<'a> {
        TomlRef {
            dir,
            path,
            newlines: text
                .bytes()
                .enumerate()
                .filter(|&(_, b)| b == b'\n')
                .map(|(i, _)| i)
                .collect(),
        }
    }

    /// 1-based line of byte `offset` of the text.
    fn line_of(&self, offset: usize) -> usize {
        1 + self.newlines.partition_point(|&n| n < offset)
    }
}

/// What luminaires share: the table of each photometric file (and lamp set), and the
/// integral of each table or spot shape.
#[derive(Default)]
struct Shared {
    tables: HashMap<(PathBuf, usize), Box<CandelaTable>>,
    integrals: HashMap<String, f64>,
}

/// Builds the `[[luminaires]]` and attaches each to its light group (creating groups that
/// `[[lights]]` does not define). IES files join `files` for the cache key.
pub(crate) fn add_luminaires(
    cfg: &SceneToml,
    toml: &TomlRef<'_>,
    scale: f64,
    lights: &mut Vec<LightGroup>,
    files: &mut Vec<PathBuf>,
) -> Result<(), SceneError> {
    let mut seen = HashSet::new();
    // Luminaires sharing an IES file or a spot shape share its table and its integral.
    let mut shared = Shared::default();
    for l in &cfg.luminaires {
        let bad = |m: String| luminaire_error(toml.path, &l.id, m);
        if l.id.is_empty() || !seen.insert(l.id.clone()) {
            return Err(bad("id is empty or used twice".into()));
        }
        let finite3 = |v: [f64; 3]| v.iter().all(|x| x.is_finite());
        if !finite3(l.position) || !finite3(l.aim) || l.c0.is_some_and(|c| !finite3(c)) {
            return Err(bad("position, aim and c0 must be finite".into()));
        }
        let lum = build_luminaire(l, toml, scale, files, &mut shared)?;
        let gid = l.group.clone().unwrap_or_else(|| l.id.clone());
        super::lights::add_luminaire(lights, &gid, lum, l.ra);
    }
    Ok(())
}

/// An error about luminaire `id` of `scene.toml`.
fn luminaire_error(toml_path: &Path, id: &str, m: String) -> SceneError {
    SceneError::Invalid {
        path: toml_path.into(),
        message: format!("luminaire '{id}': {m}"),
    }
}

/// The luminaire of one `[[luminaires]]` entry (positions scaled to metres).
fn build_luminaire(
    l: &LuminaireToml,
    toml: &TomlRef<'_>,
    scale: f64,
    files: &mut Vec<PathBuf>,
    shared: &mut Shared,
) -> Result<Luminaire, SceneError> {
    let bad = |m: String| luminaire_error(toml.path, &l.id, m);
    let (distribution, integral_key) = distribution(l, toml, files, shared)?;
    let color = color(l).map_err(bad)?;
    let v = |a: [f64; 3]| DVec3::from_array(a);
    let integral = match integral_key {
        Some(k) => *shared
            .integrals
            .entry(k)
            .or_insert_with(|| distribution.integral()),
        None => distribution.integral(),
    };
    let spec = LuminaireSpec {
        id: &l.id,
        position: v(l.position) * scale,
        aim: v(l.aim),
        c0: l.c0.map(v),
        distribution,
        lumens: l.lumens,
        color,
        watts: None,
    };
    let mut lum = Luminaire::with_integral(spec, integral).map_err(bad)?;
    // scene.toml's watts, else its efficacy, else the photometric file's input watts (which
    // `Luminaire` took already; None when the file gives none). Rescaling `lumens` keeps
    // the file's watts.
    lum.watts = match (l.watts, l.efficacy) {
        (Some(w), _) if w.is_finite() && w >= 0.0 => Some(w),
        // Efficacy is of the lumens before any tilt factor: tilting a lamp costs light, not
        // power.
        (None, Some(e)) if e.is_finite() && e > 0.0 => Some(l.lumens.unwrap_or(integral) / e),
        (None, None) => lum.watts,
        _ => return Err(bad("watts must be ≥ 0 and efficacy > 0".into())),
    };
    Ok(lum)
}

/// The entry's distribution, and the key under which its integral is shared (None for
/// isotropic ones, whose integral costs nothing).
fn distribution(
    l: &LuminaireToml,
    toml: &TomlRef<'_>,
    files: &mut Vec<PathBuf>,
    shared: &mut Shared,
) -> Result<(Distribution, Option<String>), SceneError> {
    let bad = |m: String| luminaire_error(toml.path, &l.id, m);
    let kind = l.distribution.clone().unwrap_or_else(|| {
        if l.ies.is_some() || l.photometry.is_some() {
            "photometry"
        } else {
            "isotropic"
        }
        .into()
    });
    match kind.as_str() {
        "isotropic" => Ok((Distribution::Isotropic, None)),
        "spot" => {
            let beam = l.beam_deg.unwrap_or(30.0);
            let field = l.field_deg.unwrap_or(2.0 * beam);
            if !(beam > 0.0 && beam < 180.0 && field >= beam && field <= 180.0) {
                return Err(bad(format!(
                    "spot needs 0 < beam_deg ({beam}) < 180 and beam_deg ≤ field_deg ({field}) ≤ 180"
                )));
            }
            let spot = Distribution::Spot {
                beam_deg: beam,
                field_deg: field,
            };
            Ok((spot, Some(format!("spot:{beam:?}:{field:?}"))))
        }
        "photometry" | "ies" => {
            let (key, name) = match (&l.photometry, &l.ies) {
                (Some(n), None) => ("photometry", n),
                (None, Some(n)) => ("ies", n),
                (Some(_), Some(_)) => return Err(bad("give photometry or ies, not both".into())),
                (None, None) => {
                    return Err(bad(format!(
                        "distribution \"{kind}\" needs photometry = \"file.ies\" or \"file.ldt\""
                    )))
                }
            };
            let line = toml.line_of(name.span().start);
            let path = toml.dir.resolve(
                name.get_ref(),
                toml.path,
                line,
                &format!("luminaire '{}': {key}", l.id),
            )?;
            let lamp_set = l.lamp_set.unwrap_or(1);
            let data = table(toml.dir, &path, lamp_set, shared)?;
            if !files.contains(&path) {
                files.push(path.clone());
            }
            let key = format!("table:{}:{lamp_set}", path.display());
            Ok((Distribution::Table(data), Some(key)))
        }
        other => Err(bad(format!(
            "distribution '{other}': use isotropic, spot or photometry"
        ))),
    }
}

/// The candela table of the photometric file at canonical `path` (EULUMDAT when its name
/// ends in `.ldt`, scaled by `lamp_set`; else IES), read on first use.
fn table(
    dir: &SceneDir,
    path: &Path,
    lamp_set: usize,
    shared: &mut Shared,
) -> Result<Box<CandelaTable>, SceneError> {
    let key = (path.to_path_buf(), lamp_set);
    if let Some(d) = shared.tables.get(&key) {
        return Ok(d.clone());
    }
    let shown = dir.display(path);
    // Headers are often Latin-1: only the numbers matter.
    let bytes = dir.read(path, MAX_TEXT_BYTES)?;
    let text = String::from_utf8_lossy(&bytes);
    let is_ldt = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ldt"));
    let d = Box::new(if is_ldt {
        parse_ldt_file(&shown, &text, Some(lamp_set))?
    } else {
        parse_ies_file(&shown, &text)?
    });
    shared.tables.insert(key, d.clone());
    Ok(d)
}

/// The entry's colour: linear RGB, or a blackbody at `cct` kelvin; white by default.
fn color(l: &LuminaireToml) -> Result<Rgb, String> {
    match (l.color, l.cct) {
        (Some(_), Some(_)) => Err("give color or cct, not both".into()),
        (Some(c), None) => Ok(c),
        (None, Some(k)) if (MIN_CCT..=MAX_CCT).contains(&k) => Ok(cct_to_rgb(k)),
        (None, Some(k)) => Err(format!("cct = {k}: must be 1000..40000 K")),
        (None, None) => Ok(Rgb::ONE),
    }
}
