//! The MTL reader: relight's only source of material data (tobj never reads MTL files).
//!
//! - `newmtl NAME` starts a material; a name may not be empty or defined twice.
//! - `Kd r g b` (diffuse reflectance, each in [0, 1)) and `Ke r g b` (luminous exitance,
//!   lm/m², each in [0, [`MAX_EXITANCE`]]) are parsed strictly: three numbers (or one,
//!   meaning grey, as the MTL specification allows), finite in `f32`, in range, at most
//!   once per material. A trailing `# comment` is allowed.
//! - Numeric statements relight does not use (`Ka`, `Ks`, `Tf`, `Ns`, `Ni`, `d`, `Tr`,
//!   `illum`, the PBR extensions `Pr`, `Pm`, …) must still read as numbers, so that a
//!   damaged line is an error naming the file and line, never silently skipped; their
//!   values are then ignored. Texture and other statements (`map_*`, `bump`, `refl`, …)
//!   are ignored by keyword.
//! - Misspelt `Kd`/`Ke` (`kd`, `KE`, …) are errors; any other unknown statement is ignored
//!   with a warning, so no data is dropped silently.

use std::path::Path;

use super::SceneError;
use crate::color::Rgb;
use crate::limits::{MAX_EXITANCE, MAX_MATERIALS};

/// One material as written in an MTL file.
#[derive(Debug, Clone, PartialEq)]
pub struct MtlMaterial {
    pub name: String,
    /// Diffuse reflectance per channel, in [0, 1) (default 0).
    pub kd: Rgb,
    /// Luminous exitance per channel, lm/m² (default 0).
    pub ke: Rgb,
    /// Line of the `newmtl` statement.
    pub line: usize,
}

/// The materials of one MTL file, and what was ignored in it.
#[derive(Debug, Clone, Default)]
pub struct MtlLibrary {
    pub materials: Vec<MtlMaterial>,
    pub warnings: Vec<String>,
}

/// Numeric statements that relight does not use: checked, then ignored.
const NUMERIC: &[&str] = &[
    "Ka",
    "Ks",
    "Tf",
    "Ns",
    "Ni",
    "d",
    "Tr",
    "illum",
    "sharpness",
    "Pr",
    "Pm",
    "Ps",
    "Pc",
    "Pcr",
    "aniso",
    "anisor",
];

/// A word cut to a length fit for a message.
fn shorten(w: &str) -> String {
    w.chars().take(40).collect()
}

/// Statements of the MTL format that relight does not use: ignored by keyword.
const IGNORED: &[&str] = &["bump", "disp", "decal", "refl", "norm"];

/// Parses the text of an MTL file; `path` is the display name errors use.
pub fn parse_mtl_str(path: &str, text: &str) -> Result<MtlLibrary, SceneError> {
    parse_mtl(Path::new(path), text)
}

pub(crate) fn parse_mtl(path: &Path, text: &str) -> Result<MtlLibrary, SceneError> {
    let mut lib = MtlLibrary::default();
    // Per material: whether Kd / Ke were given.
    let mut given: Vec<[bool; 2]> = Vec::new();
    let mut lines_of: std::collections::HashMap<String, usize> = Default::default();
    let mut unknown: Vec<(String, usize)> = Vec::new();
    let mut unknown_count = 0usize;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.trim();
        let mut words = l.split_whitespace();
        let Some(key) = words.next() else { continue };
        if key.starts_with('#') {
            continue;
        }
        let syntax = |message: String| SceneError::Syntax {
            path: path.to_path_buf(),
            line,
            message,
        };
        match key {
            "newmtl" => {
                let name = l["newmtl".len()..].trim();
                if name.is_empty() {
                    return Err(syntax("newmtl needs a material name".into()));
                }
                if let Some(prev) = lines_of.get(name) {
                    return Err(syntax(format!(
                        "material '{name}' is defined twice (first on line {prev})"
                    )));
                }
                if lib.materials.len() >= MAX_MATERIALS {
                    return Err(syntax(format!("more than {MAX_MATERIALS} materials")));
                }
                lines_of.insert(name.to_string(), line);
                lib.materials.push(MtlMaterial {
                    name: name.to_string(),
                    kd: [0.0; 3],
                    ke: [0.0; 3],
                    line,
                });
                given.push([false; 2]);
            }
            "Kd" | "Ke" => {
                let (Some(cur), Some(seen)) = (lib.materials.last_mut(), given.last_mut()) else {
                    return Err(syntax(format!("{key} before any newmtl")));
                };
                let bad = |message: String| SceneError::BadMaterial {
                    path: path.to_path_buf(),
                    line,
                    material: cur.name.clone(),
                    message,
                };
                let slot = usize::from(key == "Ke");
                if seen[slot] {
                    return Err(bad(format!("{key} is given twice")));
                }
                seen[slot] = true;
                let vals: Vec<&str> = words.take_while(|w| !w.starts_with('#')).collect();
                if matches!(vals.first(), Some(&"spectral") | Some(&"xyz")) {
                    return Err(bad(format!("{key}: only RGB values are supported")));
                }
                if !matches!(vals.len(), 1 | 3) {
                    return Err(bad(format!(
                        "{key} needs 3 numbers (r g b), or 1 for grey; found {}",
                        vals.len()
                    )));
                }
                let mut v = [0f32; 3];
                for (k, w) in vals.iter().enumerate() {
                    let x: f32 = w
                        .parse()
                        .map_err(|_| bad(format!("{key}: '{w}' is not a number")))?;
                    if !x.is_finite() {
                        return Err(bad(format!("{key}: '{w}' is not a finite 32-bit number")));
                    }
                    v[k] = x;
                }
                if vals.len() == 1 {
                    v = [v[0]; 3];
                }
                if key == "Kd" {
                    if v.iter().any(|&x| !(0.0..1.0).contains(&x)) {
                        return Err(bad(format!(
                            "Kd {} {} {}: diffuse reflectance must be in [0, 1) per channel \
                             (a surface cannot reflect all the light it receives)",
                            v[0], v[1], v[2]
                        )));
                    }
                    cur.kd = v;
                } else {
                    if v.iter().any(|&x| !(0.0..=MAX_EXITANCE).contains(&x)) {
                        return Err(bad(format!(
                            "Ke {} {} {}: exitance must be in [0, {MAX_EXITANCE:e}] lm/m² \
                             per channel",
                            v[0], v[1], v[2]
                        )));
                    }
                    cur.ke = v;
                }
            }
            k if k.eq_ignore_ascii_case("kd") || k.eq_ignore_ascii_case("ke") => {
                return Err(syntax(format!(
                    "unknown statement '{k}' (did you mean '{}'? keywords are case-sensitive)",
                    if k.eq_ignore_ascii_case("kd") {
                        "Kd"
                    } else {
                        "Ke"
                    }
                )));
            }
            k if NUMERIC.contains(&k) => {
                let vals: Vec<&str> = words.take_while(|w| !w.starts_with('#')).collect();
                // `Ka spectral file.rfl f` and `Ka xyz x y z` name other forms; `d -halo f`
                // has a flag.
                let vals: Vec<&str> = vals
                    .into_iter()
                    .filter(|w| !matches!(*w, "spectral" | "xyz" | "-halo"))
                    .collect();
                if vals.is_empty() {
                    return Err(syntax(format!("{k} needs a number")));
                }
                let spectral_file = |w: &str| w.contains('.') && w.parse::<f64>().is_err();
                for w in vals {
                    if !spectral_file(w) && !w.parse::<f64>().is_ok_and(f64::is_finite) {
                        return Err(syntax(format!("{k}: '{}' is not a number", shorten(w))));
                    }
                }
            }
            k if IGNORED.contains(&k) || k.starts_with("map_") => {}
            k => {
                unknown_count += 1;
                if unknown.len() < 3 {
                    unknown.push((k.chars().take(40).collect(), line));
                }
            }
        }
    }
    if unknown_count > 0 {
        let at: Vec<String> = unknown
            .iter()
            .map(|(k, l)| format!("'{k}' on line {l}"))
            .collect();
        lib.warnings.push(format!(
            "{}: {unknown_count} unknown statement(s) ignored ({}{})",
            path.display(),
            at.join(", "),
            if unknown_count > unknown.len() {
                ", …"
            } else {
                ""
            }
        ));
    }
    Ok(lib)
}
