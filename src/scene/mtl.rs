//! The MTL reader: relight's only source of material data (tobj never reads MTL files).
//!
//! - `newmtl NAME` starts a material; a name may not be empty or defined twice.
//! - `Kd r g b` (diffuse reflectance, each in [0, 1)) and `Ke r g b` (luminous exitance,
//!   lm/m², each in [0, [`MAX_EXITANCE`]]) are parsed strictly: three numbers (or one,
//!   meaning grey, as the MTL specification allows), finite in `f32`, in range. A trailing
//!   `# comment` is allowed. Two exceptions, as exporters write them: a `Kd` with a channel
//!   of 1 or more is scaled so its largest channel is [`MAX_KD`] (keeping its colour),
//!   with a warning; a key given twice in one material (`Kd`, `Ke` or `map_Kd`) is taken
//!   last, as tobj, Assimp and Blender take it, with a warning naming the file, line,
//!   material and key. With `strict` each is an error.
//! - `map_Kd [options] FILE` records the texture (the rest of the line) for the
//!   material table, which averages it into `Kd`.
//! - Numeric statements relight does not use (`Ka`, `Ks`, `Tf`, `Ns`, `Ni`, `d`, `Tr`,
//!   `illum`, the PBR extensions `Pr`, `Pm`, …) must still read as numbers, so that a
//!   damaged line is an error naming the file and line, never silently skipped; their
//!   values are then ignored. Other texture statements (`map_Ks`, `bump`, `refl`, …)
//!   are ignored by keyword.
//! - Misspelt `Kd`/`Ke` (`kd`, `KE`, …) are errors; any other unknown statement is ignored
//!   with a warning, so no data is dropped silently.

use std::collections::HashMap;
use std::path::Path;
use std::str::SplitWhitespace;

use super::obj::Skipped;
use super::SceneError;
use crate::color::Rgb;
use crate::input_limits::{MAX_EXITANCE, MAX_KD, MAX_MATERIALS};

/// One material as written in an MTL file.
#[derive(Debug, Clone, PartialEq)]
pub struct MtlMaterial {
    pub name: String,
    /// Diffuse reflectance per channel, in [0, 1) (default 0).
    pub kd: Rgb,
    /// Whether the file gave `Kd` (a texture alone means `Kd 1 1 1` times the texture).
    pub kd_given: bool,
    /// Luminous exitance per channel, lm/m² (default 0).
    pub ke: Rgb,
    /// Line of the `newmtl` statement.
    pub line: usize,
    /// `map_Kd`: the texture file as written, and its line.
    pub map_kd: Option<(String, usize)>,
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
    "Kt",
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

/// Parses the text of an MTL file leniently; `path` is the display name errors use.
pub fn parse_mtl_str(path: &str, text: &str) -> Result<MtlLibrary, SceneError> {
    parse_mtl(Path::new(path), text, false)
}

/// Parses an MTL file. With `strict`, what a lenient read fixes with a warning (a `Kd`
/// of 1 or more, a key given twice in one material) is an error.
pub(crate) fn parse_mtl(path: &Path, text: &str, strict: bool) -> Result<MtlLibrary, SceneError> {
    let mut p = MtlParser {
        path,
        strict,
        lib: MtlLibrary::default(),
        given: Vec::new(),
        lines_of: HashMap::new(),
        unknown: Skipped::default(),
    };
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.trim();
        let mut words = l.split_whitespace();
        let Some(key) = words.next() else { continue };
        if key.starts_with('#') {
            continue;
        }
        match key {
            "newmtl" => p.newmtl(line, l)?,
            "Kd" | "Ke" => p.color(line, key, words)?,
            k if k.eq_ignore_ascii_case("kd") || k.eq_ignore_ascii_case("ke") => {
                return Err(p.syntax(
                    line,
                    format!(
                        "unknown statement '{k}' (did you mean '{}'? keywords are \
                         case-sensitive)",
                        if k.eq_ignore_ascii_case("kd") {
                            "Kd"
                        } else {
                            "Ke"
                        }
                    ),
                ));
            }
            "map_Kd" => p.map_kd(line, words)?,
            k if NUMERIC.contains(&k) => check_numeric(k, words).map_err(|m| p.syntax(line, m))?,
            k if IGNORED.contains(&k) || k.starts_with("map_") => {}
            k => p.unknown.note(k, line),
        }
    }
    Ok(p.finish())
}

/// The statements a material gives at most once without a warning.
#[derive(Debug, Clone, Copy)]
enum Key {
    Kd = 0,
    Ke = 1,
    MapKd = 2,
}

impl Key {
    fn name(self) -> &'static str {
        match self {
            Key::Kd => "Kd",
            Key::Ke => "Ke",
            Key::MapKd => "map_Kd",
        }
    }
}

/// The state of one MTL file's reading.
struct MtlParser<'a> {
    /// Display name for errors.
    path: &'a Path,
    /// Errors instead of the lenient fixes.
    strict: bool,
    lib: MtlLibrary,
    /// Per material: the line of its `Kd`, `Ke` and `map_Kd` (in [`Key`] order), if given.
    given: Vec<[Option<usize>; 3]>,
    /// Line of each material's `newmtl`.
    lines_of: HashMap<String, usize>,
    /// The unknown statements.
    unknown: Skipped,
}

impl MtlParser<'_> {
    fn syntax(&self, line: usize, message: String) -> SceneError {
        SceneError::Syntax {
            path: self.path.to_path_buf(),
            line,
            message,
        }
    }

    /// `newmtl NAME`: starts a material.
    fn newmtl(&mut self, line: usize, l: &str) -> Result<(), SceneError> {
        let name = l["newmtl".len()..].trim();
        if name.is_empty() {
            return Err(self.syntax(line, "newmtl needs a material name".into()));
        }
        if let Some(prev) = self.lines_of.get(name) {
            return Err(self.syntax(
                line,
                format!("material '{name}' is defined twice (first on line {prev})"),
            ));
        }
        if self.lib.materials.len() >= MAX_MATERIALS {
            return Err(self.syntax(line, format!("more than {MAX_MATERIALS} materials")));
        }
        self.lines_of.insert(name.to_string(), line);
        self.lib.materials.push(MtlMaterial {
            name: name.to_string(),
            kd: Rgb::ZERO,
            kd_given: false,
            ke: Rgb::ZERO,
            line,
            map_kd: None,
        });
        self.given.push([None; 3]);
        Ok(())
    }

    /// Notes that the current material (index `at`) gives `key` on `line`. A key it gave
    /// before is taken last with a warning; with `strict` it is an error.
    fn once(&mut self, at: usize, key: Key, line: usize) -> Result<(), SceneError> {
        let (Some(slots), Some(cur)) = (self.given.get_mut(at), self.lib.materials.get(at)) else {
            return Ok(());
        };
        let slot = &mut slots[key as usize];
        let prev = slot.replace(line);
        let Some(prev) = prev else { return Ok(()) };
        let name = key.name();
        if self.strict {
            return Err(SceneError::BadMaterial {
                path: self.path.to_path_buf(),
                line,
                material: cur.name.clone(),
                message: format!(
                    "{name} is given twice (first on line {prev}; strict = true, a lenient \
                     load takes the last)"
                ),
            });
        }
        self.lib.warnings.push(format!(
            "{}:{line}: material '{}': {name} is given twice (first on line {prev}): the \
             last is used",
            self.path.display(),
            cur.name
        ));
        Ok(())
    }

    /// `Kd r g b` or `Ke r g b` (or one number for grey) of the current material.
    fn color(
        &mut self,
        line: usize,
        key: &str,
        words: SplitWhitespace<'_>,
    ) -> Result<(), SceneError> {
        let path = self.path;
        let Some(at) = self.lib.materials.len().checked_sub(1) else {
            return Err(SceneError::Syntax {
                path: path.to_path_buf(),
                line,
                message: format!("{key} before any newmtl"),
            });
        };
        self.once(at, if key == "Ke" { Key::Ke } else { Key::Kd }, line)?;
        let Some(cur) = self.lib.materials.get_mut(at) else {
            return Ok(());
        };
        let bad = |message: String| SceneError::BadMaterial {
            path: path.to_path_buf(),
            line,
            material: cur.name.clone(),
            message,
        };
        let v = color_values(key, words).map_err(bad)?;
        if key == "Kd" {
            let out_of_range = |strict: bool| {
                format!(
                    "Kd {} {} {}: diffuse reflectance must be in [0, 1) per channel \
                     (a surface cannot reflect all the light it receives){}",
                    v[0],
                    v[1],
                    v[2],
                    if strict { "; strict = true" } else { "" }
                )
            };
            if v.iter().any(|&x| x < 0.0) || (self.strict && v.iter().any(|&x| x >= 1.0)) {
                return Err(bad(out_of_range(self.strict)));
            }
            cur.kd_given = true;
            cur.kd = v;
            if let Some(k) = clamp_kd(v) {
                cur.kd = k;
                let name = cur.name.clone();
                self.lib.warnings.push(format!(
                    "{}:{line}: material '{name}': Kd {} {} {} has a channel of 1 or more \
                     (no surface reflects all the light it receives): scaled to {} {} {}",
                    path.display(),
                    v[0],
                    v[1],
                    v[2],
                    k[0],
                    k[1],
                    k[2]
                ));
            }
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
        Ok(())
    }

    /// `map_Kd [options] FILE` of the current material: the options are skipped with
    /// their arguments, and the rest of the line is the file name (it may hold spaces).
    fn map_kd(&mut self, line: usize, words: SplitWhitespace<'_>) -> Result<(), SceneError> {
        let words: Vec<&str> = words.take_while(|w| !w.starts_with('#')).collect();
        let Some(file) = map_file_name(&words) else {
            return Ok(());
        };
        let Some(at) = self.lib.materials.len().checked_sub(1) else {
            self.lib.warnings.push(format!(
                "{}:{line}: map_Kd before any newmtl ignored",
                self.path.display()
            ));
            return Ok(());
        };
        self.once(at, Key::MapKd, line)?;
        if let Some(cur) = self.lib.materials.get_mut(at) {
            cur.map_kd = Some((file, line));
        }
        Ok(())
    }

    /// The library, with one warning summing up the unknown statements.
    fn finish(mut self) -> MtlLibrary {
        if let Some(s) = self.unknown.summary("unknown statement(s) ignored") {
            self.lib
                .warnings
                .push(format!("{}: {s}", self.path.display()));
        }
        self.lib
    }
}

/// The file name of a texture statement's words (`map_Kd -s 1 1 1 -clamp on my file.png`):
/// each option is skipped with its arguments as the MTL format defines them (`-o`, `-s`,
/// `-t` take up to three numbers, `-mm` two, `-cc`, `-clamp`, `-blendu`, `-blendv`,
/// `-bm`, `-boost`, `-texres`, `-imfchan`, `-type` one), and the remaining words, joined by
/// single spaces, are the name. None when nothing is left.
fn map_file_name(words: &[&str]) -> Option<String> {
    let mut i = 0;
    while i < words.len() && words[i].starts_with('-') && words[i].len() > 1 {
        let (min, max) = match words[i] {
            "-o" | "-s" | "-t" => (1, 3),
            "-mm" => (2, 2),
            _ => (1, 1),
        };
        i += 1;
        let mut taken = 0;
        while taken < max && i < words.len() {
            let numeric = words[i].parse::<f64>().is_ok();
            if taken >= min && !numeric {
                break;
            }
            // A non-numeric word still counts as the argument of one-word options
            // (`-clamp on`, `-imfchan r`, `-type sphere`).
            if !numeric && max > 1 {
                break;
            }
            i += 1;
            taken += 1;
        }
    }
    let rest = &words[i.min(words.len())..];
    (!rest.is_empty()).then(|| rest.join(" "))
}

/// A reflectance with a channel of 1 or more, scaled so its largest channel is
/// [`MAX_KD`]; None when it is in range.
pub(crate) fn clamp_kd(v: Rgb) -> Option<Rgb> {
    let top = v.max_component();
    (top >= 1.0).then(|| v.map(|x| (x / top * MAX_KD).min(MAX_KD)))
}

/// The three channels of a `Kd`/`Ke` statement (one number means grey): finite `f32`s,
/// not yet range-checked.
fn color_values(key: &str, words: SplitWhitespace<'_>) -> Result<Rgb, String> {
    let vals: Vec<&str> = words.take_while(|w| !w.starts_with('#')).collect();
    if matches!(vals.first(), Some(&"spectral") | Some(&"xyz")) {
        return Err(format!("{key}: only RGB values are supported"));
    }
    if !matches!(vals.len(), 1 | 3) {
        return Err(format!(
            "{key} needs 3 numbers (r g b), or 1 for grey; found {}",
            vals.len()
        ));
    }
    let mut v = [0f32; 3];
    for (k, w) in vals.iter().enumerate() {
        let x: f32 = w
            .parse()
            .map_err(|_| format!("{key}: '{w}' is not a number"))?;
        if !x.is_finite() {
            return Err(format!("{key}: '{w}' is not a finite 32-bit number"));
        }
        v[k] = x;
    }
    if vals.len() == 1 {
        v = [v[0]; 3];
    }
    Ok(Rgb(v))
}

/// A numeric statement relight does not use (`k`, one of [`NUMERIC`]): its values must
/// read as numbers (or name a spectral file).
fn check_numeric(k: &str, words: SplitWhitespace<'_>) -> Result<(), String> {
    let vals: Vec<&str> = words.take_while(|w| !w.starts_with('#')).collect();
    // `Ka spectral file.rfl f` and `Ka xyz x y z` name other forms; `d -halo f`
    // has a flag.
    let vals: Vec<&str> = vals
        .into_iter()
        .filter(|w| !matches!(*w, "spectral" | "xyz" | "-halo"))
        .collect();
    if vals.is_empty() {
        return Err(format!("{k} needs a number"));
    }
    let spectral_file = |w: &str| w.contains('.') && w.parse::<f64>().is_err();
    for w in vals {
        if !spectral_file(w) && !w.parse::<f64>().is_ok_and(f64::is_finite) {
            return Err(format!("{k}: '{}' is not a number", shorten(w)));
        }
    }
    Ok(())
}
