//! A relit scene as a glTF 2.0 binary (`.glb`) that any glTF viewer shows as lit, and
//! that a client can relight without the server.
//!
//! The file holds one mesh with one indexed triangle primitive over the shading vertices
//! ([`Shading`]), so its colours blend exactly as the server's images do:
//!
//! - `POSITION`: metres (float VEC3).
//! - `COLOR_0` (float VEC3, linear): the relit image's display values,
//!   `curve(2^exposure · L)` per channel, with `L = B/π` the radiance in cd/m² from the
//!   radiosity B (lm/m²) of the lighting state, and `curve` the tone map: `min(x, 1)`
//!   (clamp) or the ACES fit (filmic). A viewer's sRGB output encoding then shows what
//!   `render.png` shows, up to the rasterizer's interpolation.
//! - `_LIGHT_<GROUP>` (float VEC3, linear), one per light group: that group's radiance at
//!   intensity 1, white, in cd/m². So `Σ_g weight_g · _LIGHT_g` is `L` for any mix, and
//!   `COLOR_0` is reproduced by applying the exposure and curve.
//! - The material is unlit (`KHR_materials_unlit`) and one-sided, as surfaces are: only
//!   fronts are lit (two-sided surfaces have a patch per side).
//! - Cameras: each `scene.toml` camera preset as a perspective camera node.
//! - `_LIGHT_REQUEST` (float VEC3, linear), for a state the groups cannot sum to
//!   (luminaires placed per request, a per-patch emission): that part of the light, in
//!   cd/m² at the weights asked, so `Σ_g weight_g · _LIGHT_g + _LIGHT_REQUEST` is `L`.
//! - `asset.extras.relight`: the scene id, units, the exposure (stops) and tone map used,
//!   and per group its id, name, attribute name and weight (intensity × colour) at export;
//!   per surface its name and triangle range in the primitive; `request`, the request's
//!   own attribute and what it holds.

use glam::{DMat3, DQuat, DVec3};
use serde_json::{json, Value};

use super::shading::Shading;
use super::tonemap::{auto_exposure, tone_curve, ToneMap};
use crate::color::Rgb;
use crate::model::query::Quantity;
use crate::model::{Lighting, Model, QueryError};

/// Largest exported file, bytes (1 GiB).
pub const MAX_EXPORT_BYTES: u64 = 1 << 30;

/// How to export.
#[derive(Debug, Clone, Copy)]
pub struct ExportOptions {
    /// Stops; None: auto exposure over the vertices (log-average luminance to 0.18).
    pub exposure: Option<f32>,
    pub tonemap: ToneMap,
    /// Write the per-group `_LIGHT_*` attributes.
    pub relightable: bool,
}

/// An exported file.
pub struct Exported {
    pub bytes: Vec<u8>,
    /// The exposure used, stops.
    pub exposure: f32,
}

/// Size of the export of `model` with `nv` shading vertices, bytes (exact up to the JSON
/// chunk's length). Shading vertices are at most three per patch.
pub fn export_bytes(model: &Model, nv: usize, relightable: bool) -> u64 {
    let nv = nv as u64;
    let nt = model.baked.mesh.len() as u64;
    let groups = if relightable {
        model.groups.len() as u64
    } else {
        0
    };
    // One attribute more for a request's own light.
    12 * nv * (3 + groups) + 12 * nt + 64 * (groups + model.baked.scene.surfaces.len() as u64)
}

/// The glTF attribute name of each group: `_LIGHT_` and the id in upper case, other
/// characters than A–Z, 0–9 and `_` as `_`, made unique with `_2`, `_3`, ….
fn attribute_names(ids: &[&str]) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(ids.len());
    for id in ids {
        let base: String = std::iter::once("_LIGHT_".to_string())
            .chain(id.chars().map(|c| {
                if c.is_ascii_alphanumeric() {
                    c.to_ascii_uppercase().to_string()
                } else {
                    "_".into()
                }
            }))
            .collect();
        let mut name = base.clone();
        let mut k = 2;
        while out.contains(&name) {
            name = format!("{base}_{k}");
            k += 1;
        }
        out.push(name);
    }
    out
}

/// One accessor's view into the binary chunk.
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn push(&mut self, bytes: impl Iterator<Item = [u8; 4]>, target: u32) -> (usize, usize) {
        let start = self.bin.len();
        for b in bytes {
            self.bin.extend_from_slice(&b);
        }
        self.views.push(json!({
            "buffer": 0, "byteOffset": start, "byteLength": self.bin.len() - start, "target": target
        }));
        (self.views.len() - 1, self.bin.len() - start)
    }

    /// A float VEC3 vertex attribute; with min and max (POSITION needs them).
    fn vec3(&mut self, v: &[[f32; 3]], bounds: bool) -> usize {
        let (view, _) = self.push(v.iter().flatten().map(|x| x.to_le_bytes()), 34962);
        let mut a =
            json!({"bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC3"});
        if bounds {
            let mut lo = [f32::MAX; 3];
            let mut hi = [f32::MIN; 3];
            for p in v {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }
}

/// The camera node of a preset: glTF cameras look down their −z with +y up.
fn camera_node(def: &crate::scene::CameraDef, index: usize) -> Option<Value> {
    let eye = DVec3::from(def.position);
    let f = (DVec3::from(def.target) - eye).normalize_or_zero();
    let z = -f;
    let x = DVec3::from(def.up).cross(z).normalize_or_zero();
    if f == DVec3::ZERO || x == DVec3::ZERO {
        return None;
    }
    let y = z.cross(x);
    let q = DQuat::from_mat3(&DMat3::from_cols(x, y, z)).normalize();
    Some(json!({
        "name": def.id,
        "camera": index,
        "translation": eye.to_array(),
        "rotation": [q.x, q.y, q.z, q.w],
    }))
}

/// The relit scene under group weights `weights` (one [`Rgb`] per light group, as
/// [`Model::weights`] gives) as a `.glb`.
pub fn export_glb(
    model: &Model,
    shading: &Shading,
    lighting: &Lighting,
    o: &ExportOptions,
) -> Result<Exported, QueryError> {
    let none = vec![Rgb::ZERO; model.baked.scene.lights.len()];
    let weights = match lighting {
        Lighting::Groups(w) => w.as_slice(),
        Lighting::Placed(p) => p.weights.as_slice(),
        Lighting::Emission(_) => none.as_slice(),
    };
    let ex = Export {
        model,
        shading,
        weights,
    };
    let mut per_patch = vec![0f32; 3 * model.baked.mesh.len()];
    // The state's radiance, and for a state the groups cannot sum to, its own part: the
    // placed luminaires' light (the state less the groups'), or the emission's.
    let (l, request) = match lighting {
        Lighting::Groups(w) => (ex.radiance(w, &mut per_patch), None),
        _ => {
            let b = model.per_patch(lighting, Quantity::Radiosity)?;
            let l = ex.vertex_radiance(&b);
            let groups = ex.radiance(weights, &mut per_patch);
            let own: Vec<Rgb> = l.iter().zip(&groups).map(|(a, g)| *a - *g).collect();
            (l, Some(own))
        }
    };
    let ev = o.exposure.unwrap_or_else(|| auto_exposure(&l));
    let k = ev.exp2();
    let color: Vec<Rgb> = l
        .iter()
        .map(|c| c.map(|x| tone_curve(x * k, o.tonemap)))
        .collect();

    let mut b = Builder {
        bin: Vec::new(),
        views: Vec::new(),
        accessors: Vec::new(),
    };
    let (iv, ilen) = b.push(
        shading.corners().iter().flatten().map(|i| i.to_le_bytes()),
        34963,
    );
    b.accessors.push(json!({
        "bufferView": iv, "componentType": 5125, "count": ilen / 4, "type": "SCALAR"
    }));
    let position = b.vec3(&ex.positions(), true);
    let color_0 = b.vec3(bytemuck::cast_slice(&color), false);
    let mut attributes = json!({"POSITION": position, "COLOR_0": color_0});
    let groups = ex.groups(o.relightable, &mut b, &mut attributes, &mut per_patch);
    let mut own_entry = None;
    if let Some(own) = request.filter(|_| o.relightable) {
        let mut ids: Vec<&str> = model
            .baked
            .scene
            .lights
            .iter()
            .map(|g| g.id.as_str())
            .collect();
        ids.push("request");
        let name = attribute_names(&ids).pop().unwrap_or_default();
        attributes[&name] = json!(b.vec3(bytemuck::cast_slice(&own), false));
        own_entry = Some(json!({
            "attribute": name,
            "what": match lighting {
                Lighting::Placed(_) => "the light of the luminaires placed, moved or removed for the request, at the weights asked",
                _ => "the light of the request's per-patch emission",
            },
        }));
    }
    let mut doc = ex.document(attributes, groups, (ev, o.tonemap), &b);
    if let Some(entry) = own_entry {
        doc["asset"]["extras"]["relight"]["request"] = entry;
    }
    Ok(Exported {
        bytes: glb(&doc, &b.bin),
        exposure: ev,
    })
}

/// What one export reads.
struct Export<'a> {
    model: &'a Model,
    shading: &'a Shading,
    weights: &'a [Rgb],
}

impl Export<'_> {
    /// Radiance (cd/m²) at the shading vertices under group weights `weights`;
    /// `per_patch` is scratch space of 3 floats a patch.
    fn radiance(&self, weights: &[Rgb], per_patch: &mut [f32]) -> Vec<Rgb> {
        self.model
            .per_patch_groups(weights, Quantity::Radiosity, per_patch);
        self.vertex_radiance(per_patch)
    }

    /// Radiance (cd/m²) at the shading vertices from per-patch radiosity `b` (lm/m²).
    fn vertex_radiance(&self, b: &[f32]) -> Vec<Rgb> {
        let inv_pi = std::f32::consts::FRAC_1_PI;
        self.shading
            .vertex_values(b)
            .into_iter()
            .map(|c| c * inv_pi)
            .collect()
    }

    /// The shading vertices' positions, metres.
    fn positions(&self) -> Vec<[f32; 3]> {
        let mesh = &self.model.baked.mesh;
        let mut pos = vec![[0f32; 3]; self.shading.len()];
        for (e, c) in mesh.elements.iter().zip(self.shading.corners()) {
            for k in 0..3 {
                pos[c[k] as usize] = mesh.vertices[e.v[k] as usize].as_vec3().to_array();
            }
        }
        pos
    }

    /// The light groups' entries of `asset.extras.relight`; when `relightable`, each
    /// group's `_LIGHT_*` attribute too, written to `b` and named in `attributes`.
    fn groups(
        &self,
        relightable: bool,
        b: &mut Builder,
        attributes: &mut Value,
        per_patch: &mut [f32],
    ) -> Vec<Value> {
        let lights = &self.model.baked.scene.lights;
        let ids: Vec<&str> = lights.iter().map(|g| g.id.as_str()).collect();
        let names = attribute_names(&ids);
        let mut groups = Vec::new();
        for (g, light) in lights.iter().enumerate() {
            let mut entry = json!({
                "id": light.id,
                "name": light.name,
                "weight": self.weights.get(g).copied().unwrap_or(Rgb::ZERO),
            });
            if relightable {
                let mut one = vec![Rgb::ZERO; self.weights.len()];
                one[g] = Rgb::ONE;
                let lg = self.radiance(&one, per_patch);
                attributes[&names[g]] = json!(b.vec3(bytemuck::cast_slice(&lg), false));
                entry["attribute"] = json!(names[g]);
            }
            groups.push(entry);
        }
        groups
    }

    /// The glTF JSON document over the binary chunk of `b`: one mesh of `attributes`, the
    /// camera presets, and `groups`, the surfaces and the exposure (stops) and tone map
    /// in `asset.extras.relight`.
    fn document(
        &self,
        attributes: Value,
        groups: Vec<Value>,
        (ev, tonemap): (f32, ToneMap),
        b: &Builder,
    ) -> Value {
        let scene = &self.model.baked.scene;
        let surfaces: Vec<Value> = scene
            .surfaces
            .iter()
            .zip(&self.model.baked.mesh.surface_patches)
            .map(|(s, r)| json!({"name": s.name, "first_triangle": r.start, "triangles": r.end - r.start}))
            .collect();
        let (nodes, cameras) = nodes_and_cameras(scene);
        let units = self.model.units();
        let mut doc = json!({
            "asset": {
                "version": "2.0",
                "generator": concat!("relight ", env!("CARGO_PKG_VERSION")),
                "extras": {"relight": {
                    "scene": scene.id,
                    "units": {
                        "length": units.length,
                        "COLOR_0": "display value after exposure and tone map, linear",
                        "_LIGHT_": "radiance at intensity 1, white, cd/m2, linear RGB",
                    },
                    "exposure": ev,
                    "tonemap": match tonemap { ToneMap::Clamp => "clamp", ToneMap::Filmic => "filmic" },
                    "groups": groups,
                    "surfaces": surfaces,
                }},
            },
            "extensionsUsed": ["KHR_materials_unlit"],
            "scene": 0,
            "scenes": [{"name": scene.name, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
            "nodes": nodes,
            "meshes": [{"name": scene.id, "primitives": [{
                "attributes": attributes, "indices": 0, "material": 0, "mode": 4
            }]}],
            "materials": [{
                "name": "relit",
                "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
                "extensions": {"KHR_materials_unlit": {}},
            }],
            "buffers": [{"byteLength": b.bin.len()}],
            "bufferViews": b.views,
            "accessors": b.accessors,
        });
        if !cameras.is_empty() {
            doc["cameras"] = json!(cameras);
        }
        doc
    }
}

/// The scene's nodes (the mesh, then a node per camera preset) and its glTF cameras.
fn nodes_and_cameras(scene: &crate::scene::Scene) -> (Vec<Value>, Vec<Value>) {
    let mut nodes = vec![json!({"name": scene.id, "mesh": 0})];
    let mut cameras = Vec::new();
    for def in &scene.cameras {
        if let Some(node) = camera_node(def, cameras.len()) {
            cameras.push(json!({
                "name": def.id,
                "type": "perspective",
                "perspective": {"yfov": def.fov_deg.to_radians(), "znear": 0.01}
            }));
            nodes.push(node);
        }
    }
    (nodes, cameras)
}

/// The GLB container: a 12-byte header, the JSON chunk (padded with spaces) and the
/// binary chunk (padded with zeros), each chunk 4-byte aligned.
fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut js = serde_json::to_vec(doc).unwrap_or_default();
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let pad = (4 - bin.len() % 4) % 4;
    let total = 12 + 8 + js.len() + 8 + bin.len() + pad;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&js);
    out.extend_from_slice(&((bin.len() + pad) as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out.extend(std::iter::repeat_n(0u8, pad));
    out
}

#[cfg(test)]
mod tests {
    use super::attribute_names;

    #[test]
    fn attribute_names_are_upper_case_and_unique() {
        assert_eq!(
            attribute_names(&["ceiling", "desk-lamp", "desk_lamp", "desk-lamp"]),
            [
                "_LIGHT_CEILING",
                "_LIGHT_DESK_LAMP",
                "_LIGHT_DESK_LAMP_2",
                "_LIGHT_DESK_LAMP_3"
            ]
        );
    }
}
