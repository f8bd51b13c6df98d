//! The OBJ reader: one line-level pass that validates every statement relight uses (so
//! errors name a line) and writes a normalized copy, then tobj on that copy for objects,
//! materials and triangulation.
//!
//! tobj only ever sees the normalized text: `v x y z` (the rational weight `w` and colours
//! dropped), `f a b c` triangles (absolute vertex indices, each checked against the
//! vertices defined so far; polygons are triangulated here, convex ones as fans, others by
//! ear clipping), `o`/`g` names, `usemtl` names that exist, and one synthetic `mtllib` line whose
//! loader hands tobj relight's own material table. tobj therefore never reads an MTL file
//! and never sees a token it could fail (or panic) on. Texture coordinates and normals are
//! validated but not passed on: relight does not use them, and in tobj's multi-index mode
//! they do not affect positions or indices.
//!
//! Lenient like the tools models come from (each a warning; `strict = true` makes the
//! first an error): face corners that refer to texture coordinates or normals the file
//! never defines keep their vertex; faces of fewer than three vertices are skipped;
//! `l` polylines, points and free-form statements are ignored.
//!
//! The line pass is [`scan`]; this file holds what it learns ([`ObjScan`]) and the tobj
//! side ([`read_obj`]).

use std::collections::HashSet;
use std::path::Path;

use super::SceneError;

mod scan;

pub(crate) use scan::scan_obj;

/// What the line-level pass learns.
#[derive(Debug, Clone, Default)]
pub struct ObjScan {
    /// `mtllib` statements: (file name as written, line).
    pub(crate) mtllibs: Vec<(String, usize)>,
    /// `usemtl` statements: (material name, line).
    pub(crate) usemtl: Vec<(String, usize)>,
    /// Number of `v` statements.
    pub(crate) vertices: usize,
    /// Number of triangles the faces give (n − 2 per face of n vertices).
    pub(crate) triangles: usize,
    /// Non-fatal notes (ignored statements).
    pub(crate) warnings: Vec<String>,
    /// The normalized text handed to tobj.
    normalized: String,
}

/// One OBJ object/group with one material, as tobj splits them.
#[derive(Debug, Clone)]
pub struct ObjPart {
    /// Object/group name ("unnamed_object" when the OBJ gives none).
    pub name: String,
    /// Index into the material table given to [`read_obj`], None before any `usemtl`.
    pub material: Option<usize>,
    /// Positions in OBJ units, xyz per vertex.
    pub positions: Vec<f32>,
    /// Triangle corner indices into `positions` (3 per triangle).
    pub indices: Vec<u32>,
}

/// Checks that every `usemtl` names a material in `materials`.
fn check_usemtl(path: &Path, scan: &ObjScan, materials: &[String]) -> Result<(), SceneError> {
    let known: HashSet<&str> = materials.iter().map(String::as_str).collect();
    for (name, line) in &scan.usemtl {
        if !known.contains(name.as_str()) {
            return Err(SceneError::UnknownMaterial {
                path: path.to_path_buf(),
                line: *line,
                name: name.clone(),
            });
        }
    }
    Ok(())
}

/// Builds the objects of a scanned OBJ with tobj. `materials` are the material names in
/// relight's order; every `usemtl` must name one of them (see [`check_usemtl`]).
pub(crate) fn read_obj(
    path: &Path,
    scan: &ObjScan,
    materials: &[String],
) -> Result<Vec<ObjPart>, SceneError> {
    check_usemtl(path, scan, materials)?;
    let table: Vec<tobj::Material> = materials
        .iter()
        .map(|n| tobj::Material {
            name: n.clone(),
            ..Default::default()
        })
        .collect();
    let (models, _) = tobj::load_obj_buf(
        &mut scan.normalized.as_bytes(),
        &tobj::LoadOptions {
            triangulate: true,
            single_index: false,
            ignore_points: true,
            ignore_lines: true,
        },
        |_| {
            // Called once, for the synthetic mtllib: relight's table, indexed as relight's.
            Ok((
                table.clone(),
                materials
                    .iter()
                    .enumerate()
                    .map(|(i, n)| (n.clone(), i))
                    .collect(),
            ))
        },
    )
    .map_err(|e| SceneError::Invalid {
        path: path.to_path_buf(),
        message: format!("OBJ parse error: {e}"),
    })?;
    let mut parts = Vec::with_capacity(models.len());
    for m in models {
        let mesh = m.mesh;
        let nv = mesh.positions.len() / 3;
        if mesh.positions.iter().any(|c| !c.is_finite())
            || mesh.indices.iter().any(|&k| k as usize >= nv)
            || mesh.indices.len() % 3 != 0
            || mesh.material_id.is_some_and(|i| i >= materials.len())
        {
            return Err(SceneError::Invalid {
                path: path.to_path_buf(),
                message: format!("object '{}': inconsistent geometry after parsing", m.name),
            });
        }
        parts.push(ObjPart {
            name: m.name,
            material: mesh.material_id,
            positions: mesh.positions,
            indices: mesh.indices,
        });
    }
    Ok(parts)
}

/// Parses OBJ text completely (line pass, then tobj), without reading any file: the entry
/// point for tests. `materials` stands in for the material libraries.
pub fn parse_obj_str(
    path: &str,
    text: &str,
    scale: f64,
    materials: &[String],
) -> Result<(ObjScan, Vec<ObjPart>), SceneError> {
    let p = Path::new(path);
    let scan = scan_obj(p, text, scale, false)?;
    let parts = read_obj(p, &scan, materials)?;
    Ok((scan, parts))
}

/// Statements passed over: the first few (keyword, at most 40 characters, and line) and
/// how many there were.
#[derive(Default)]
pub(super) struct Skipped {
    first: Vec<(String, usize)>,
    count: usize,
}

impl Skipped {
    /// Notes statement `key` on `line`.
    pub(super) fn note(&mut self, key: &str, line: usize) {
        self.count += 1;
        if self.first.len() < 3 {
            self.first.push((key.chars().take(40).collect(), line));
        }
    }

    /// `<count> <what> ('key' on line l, …)`, for a warning; None when nothing was
    /// passed over.
    pub(super) fn summary(&self, what: &str) -> Option<String> {
        if self.count == 0 {
            return None;
        }
        let at: Vec<String> = self
            .first
            .iter()
            .map(|(k, l)| format!("'{k}' on line {l}"))
            .collect();
        let more = if self.count > self.first.len() {
            ", …"
        } else {
            ""
        };
        Some(format!("{} {what} ({}{more})", self.count, at.join(", ")))
    }
}
