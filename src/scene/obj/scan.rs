//! The line-level pass over an OBJ file: every statement relight uses is validated (so
//! errors name a line), polygons are triangulated (convex ones as fans, others by ear
//! clipping within a work budget) and a normalized copy of the text is written for tobj.

use std::fmt::Write as _;
use std::path::Path;

use super::{ObjScan, Skipped};
use crate::input_limits::{
    MAX_COORD_M, MAX_EAR_CLIP_WORK, MAX_MTLLIBS, MAX_OBJ_TRIANGLES, MAX_OBJ_VERTICES,
};
use crate::scene::{polygon, SceneError};

fn syntax(path: &Path, line: usize, message: String) -> SceneError {
    SceneError::Syntax {
        path: path.to_path_buf(),
        line,
        message,
    }
}

/// Parses a number as `f32`, the type tobj stores positions in: it must be finite in f32.
fn coord(path: &Path, line: usize, w: &str, what: &str) -> Result<f32, SceneError> {
    let v: f32 = w
        .parse()
        .map_err(|_| syntax(path, line, format!("bad {what} '{w}': not a number")))?;
    if !v.is_finite() {
        return Err(syntax(
            path,
            line,
            format!("{what} '{w}' is not a finite 32-bit number"),
        ));
    }
    Ok(v)
}

/// Checks one face/line vertex reference `w` (`v`, `v/vt`, `v//vn` or `v/vt/vn`) against
/// the counts defined so far; returns the 0-based vertex index, and whether a texture
/// coordinate or normal index points past what is defined (relight uses neither, so that
/// is the caller's warning, not an error).
fn vertex_ref(
    path: &Path,
    line: usize,
    w: &str,
    counts: [usize; 3],
) -> Result<(usize, bool), SceneError> {
    let parts: Vec<&str> = w.split('/').collect();
    if parts.len() > 3 || parts[0].is_empty() {
        return Err(syntax(
            path,
            line,
            format!("bad face vertex '{w}': use v, v/vt, v//vn or v/vt/vn"),
        ));
    }
    let mut first = 0usize;
    let mut dangling = false;
    for (k, p) in parts.iter().enumerate() {
        if p.is_empty() {
            continue;
        }
        let idx: i64 = p
            .parse()
            .map_err(|_| syntax(path, line, format!("bad face index '{w}'")))?;
        let n = counts[k] as i64;
        let ok = (idx > 0 && idx <= n) || (idx < 0 && idx >= -n);
        if k > 0 {
            dangling |= !ok;
            continue;
        }
        if !ok {
            let why = if idx == 0 {
                "OBJ indices start at 1 (negative ones count back from the last vertex)".into()
            } else if n == 0 {
                "no vertex is defined before this line".into()
            } else {
                format!("{n} vertices are defined before this line")
            };
            return Err(syntax(
                path,
                line,
                format!("vertex index {idx} out of range: {why}"),
            ));
        }
        first = if idx > 0 { idx - 1 } else { n + idx } as usize;
    }
    Ok((first, dangling))
}

/// The rest of a statement after its keyword, trimmed.
fn rest<'a>(l: &'a str, keyword: &str) -> &'a str {
    l[keyword.len()..].trim()
}

/// Validates the OBJ text line by line. `path` is the display name for errors, `scale`
/// the factor to metres (coordinates must stay within [`MAX_COORD_M`] after it).
/// With `strict`, what a lenient read skips with a warning is an error.
pub(crate) fn scan_obj(
    path: &Path,
    text: &str,
    scale: f64,
    strict: bool,
) -> Result<ObjScan, SceneError> {
    let mut sc = Scanner {
        s: ObjScan {
            normalized: String::with_capacity(text.len() / 2 + 64),
            ..Default::default()
        },
        path,
        scale,
        strict,
        positions: Vec::new(),
        ntex: 0,
        nnorm: 0,
        colored: None,
        ignored: Skipped::default(),
        dangling: Tally::default(),
        short_faces: Tally::default(),
        clip_budget: MAX_EAR_CLIP_WORK,
        fanned: Tally::default(),
    };
    // One synthetic mtllib, first: its loader returns the whole material table.
    sc.s.normalized.push_str("mtllib relight\n");
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.trim();
        let mut words = l.split_whitespace();
        let Some(key) = words.next() else { continue };
        match key {
            "v" => sc.vertex(line, l, words.collect())?,
            "vt" | "vn" => sc.texture_or_normal(line, l, key, words.collect())?,
            "f" | "l" => sc.face_or_line(line, key, words.collect())?,
            "o" | "g" => {
                let name = rest(l, key);
                let _ = writeln!(sc.s.normalized, "{key} {name}");
            }
            "mtllib" => {
                let name = rest(l, key);
                if name.is_empty() {
                    return Err(syntax(path, line, "mtllib needs a file name".into()));
                }
                if sc.s.mtllibs.len() >= MAX_MTLLIBS {
                    return Err(syntax(
                        path,
                        line,
                        format!("more than {MAX_MTLLIBS} mtllib statements"),
                    ));
                }
                sc.s.mtllibs.push((name.to_string(), line));
            }
            "usemtl" => {
                let name = rest(l, key);
                if name.is_empty() {
                    return Err(syntax(path, line, "usemtl needs a material name".into()));
                }
                sc.s.usemtl.push((name.to_string(), line));
                let _ = writeln!(sc.s.normalized, "usemtl {name}");
            }
            "p" | "curv" | "curv2" | "surf" => sc.ignore(key, line),
            _ => {}
        }
    }
    Ok(sc.finish())
}

/// The state of the line-level pass.
struct Scanner<'a> {
    s: ObjScan,
    path: &'a Path,
    /// Factor from OBJ units to metres.
    scale: f64,
    /// Errors instead of lenient skips.
    strict: bool,
    /// Vertex positions so far (OBJ units), for triangulating polygons.
    positions: Vec<[f32; 3]>,
    /// Texture coordinates and normals defined so far.
    ntex: usize,
    nnorm: usize,
    /// Whether vertices carry colours (set by the first vertex).
    colored: Option<bool>,
    /// The point, line and free-form statements ignored.
    ignored: Skipped,
    /// Faces with corners whose texture coordinate or normal index is undefined.
    dangling: Tally,
    /// Faces of fewer than three vertices, skipped.
    short_faces: Tally,
    /// Ear-clipping work left (vertex tests), from [`MAX_EAR_CLIP_WORK`].
    clip_budget: u64,
    /// Non-convex polygons fanned because the ear-clipping budget was spent (or no ear
    /// was found: a self-intersecting polygon).
    fanned: Tally,
}

/// How often something happened, and the first line.
#[derive(Default)]
struct Tally {
    count: usize,
    first: usize,
}

impl Tally {
    fn add(&mut self, line: usize) {
        if self.count == 0 {
            self.first = line;
        }
        self.count += 1;
    }
}

impl Scanner<'_> {
    /// A `v x y z [w | r g b]` statement.
    fn vertex(&mut self, line: usize, l: &str, vals: Vec<&str>) -> Result<(), SceneError> {
        let path = self.path;
        if !matches!(vals.len(), 3 | 4 | 6) {
            return Err(syntax(
                path,
                line,
                format!(
                    "vertex needs 3 coordinates (optionally w, or r g b): '{}'",
                    short(l)
                ),
            ));
        }
        let mut p = [0f32; 3];
        for (k, w) in vals[..3].iter().enumerate() {
            p[k] = coord(path, line, w, "vertex coordinate")?;
        }
        if vals.len() == 4 {
            // The weight of rational curves and surfaces, not a homogeneous divisor: checked,
            // then dropped (as Blender and tinyobjloader read it).
            coord(path, line, vals[3], "vertex weight w")?;
        }
        if vals.len() == 6 {
            for w in &vals[3..] {
                coord(path, line, w, "vertex colour")?;
            }
        }
        let has_color = vals.len() == 6;
        match self.colored {
            None => self.colored = Some(has_color),
            Some(c) if c != has_color => {
                return Err(syntax(
                    path,
                    line,
                    "vertex colours must be given for every vertex or for none".into(),
                ))
            }
            _ => {}
        }
        for c in p {
            let m = c as f64 * self.scale;
            if !(m.is_finite() && m.abs() <= MAX_COORD_M) {
                return Err(syntax(
                    path,
                    line,
                    format!(
                        "vertex coordinate {c} is {m:e} m after scaling; \
                         coordinates must lie within ±{MAX_COORD_M:e} m"
                    ),
                ));
            }
        }
        self.s.vertices += 1;
        if self.s.vertices > MAX_OBJ_VERTICES {
            return Err(syntax(
                path,
                line,
                format!("more than {MAX_OBJ_VERTICES} vertices"),
            ));
        }
        // f32 Display is the shortest text that parses back to the same value.
        let _ = writeln!(self.s.normalized, "v {} {} {}", p[0], p[1], p[2]);
        self.positions.push(p);
        Ok(())
    }

    /// A `vt u v` or `vn x y z` statement: checked and counted, not passed on.
    fn texture_or_normal(
        &mut self,
        line: usize,
        l: &str,
        key: &str,
        vals: Vec<&str>,
    ) -> Result<(), SceneError> {
        let path = self.path;
        let need = if key == "vt" { 2 } else { 3 };
        if vals.len() < need {
            return Err(syntax(
                path,
                line,
                format!("{key} needs {need} numbers: '{}'", short(l)),
            ));
        }
        for w in &vals[..need] {
            w.parse::<f32>()
                .map_err(|_| syntax(path, line, format!("bad {key} value '{w}': not a number")))?;
        }
        if key == "vt" {
            self.ntex += 1;
        } else {
            self.nnorm += 1;
        }
        Ok(())
    }

    /// An `f` statement (passed on as triangles) or an `l` statement (checked, then
    /// ignored).
    fn face_or_line(&mut self, line: usize, key: &str, refs: Vec<&str>) -> Result<(), SceneError> {
        let path = self.path;
        let counts = [self.s.vertices, self.ntex, self.nnorm];
        let mut idx = Vec::with_capacity(refs.len());
        let mut dangling = false;
        for w in &refs {
            let (k, d) = vertex_ref(path, line, w, counts)?;
            idx.push(k);
            dangling |= d;
        }
        if key == "l" {
            self.ignore("l", line);
            return Ok(());
        }
        if dangling {
            if self.strict {
                return Err(syntax(
                    path,
                    line,
                    "a texture coordinate or normal index refers to a 'vt'/'vn' the file \
                     does not define (strict = true)"
                        .into(),
                ));
            }
            self.dangling.add(line);
        }
        if refs.len() < 3 {
            if self.strict {
                return Err(syntax(
                    path,
                    line,
                    "face needs at least 3 vertices (strict = true)".into(),
                ));
            }
            self.short_faces.add(line);
            return Ok(());
        }
        self.s.triangles += refs.len() - 2;
        if self.s.triangles > MAX_OBJ_TRIANGLES {
            return Err(syntax(
                path,
                line,
                format!("more than {MAX_OBJ_TRIANGLES} triangles"),
            ));
        }
        let tris = self.triangulate(&idx, line);
        for t in tris {
            let _ = writeln!(
                self.s.normalized,
                "f {} {} {}",
                t[0] + 1,
                t[1] + 1,
                t[2] + 1
            );
        }
        Ok(())
    }

    /// The triangles of a polygon (0-based vertex indices, in the polygon's winding): a fan
    /// when it is convex in its plane, else ear clipping within the work budget.
    fn triangulate(&mut self, idx: &[usize], line: usize) -> Vec<[usize; 3]> {
        let n = idx.len();
        let fan = || (1..n - 1).map(|i| [idx[0], idx[i], idx[i + 1]]).collect();
        if n == 3 {
            return fan();
        }
        let pts: Vec<[f32; 3]> = idx.iter().map(|&k| self.positions[k]).collect();
        let Some(flat) = polygon::project(&pts) else {
            return fan();
        };
        if polygon::is_convex(&flat) {
            return fan();
        }
        match polygon::ear_clip(&flat, &mut self.clip_budget) {
            Some(tris) => tris
                .into_iter()
                .map(|[a, b, c]| [idx[a], idx[b], idx[c]])
                .collect(),
            None => {
                self.fanned.add(line);
                fan()
            }
        }
    }

    /// Notes an ignored point, line or free-form statement.
    fn ignore(&mut self, key: &str, line: usize) {
        self.ignored.note(key, line);
    }

    /// The scan, with one warning for each kind of thing skipped or ignored.
    fn finish(mut self) -> ObjScan {
        let shown = self.path.display().to_string();
        let tallies = [
            (
                &self.dangling,
                "face(s) refer to texture coordinates or normals the file does not define \
                 (relight uses neither; the faces are kept)",
            ),
            (
                &self.short_faces,
                "face(s) of fewer than 3 vertices skipped",
            ),
            (
                &self.fanned,
                "non-convex face(s) triangulated as fans (self-intersecting, or past the \
                 ear-clipping budget): their area may be wrong",
            ),
        ];
        for (t, what) in tallies {
            if t.count > 0 {
                self.s.warnings.push(format!(
                    "{shown}: {} {what} (first on line {})",
                    t.count, t.first
                ));
            }
        }
        if let Some(s) = self
            .ignored
            .summary("point, line or free-form statement(s) ignored")
        {
            self.s.warnings.push(format!("{shown}: {s}"));
        }
        self.s
    }
}

/// A line shortened for an error message.
fn short(l: &str) -> String {
    if l.chars().count() > 60 {
        format!("{}…", l.chars().take(60).collect::<String>())
    } else {
        l.to_string()
    }
}
