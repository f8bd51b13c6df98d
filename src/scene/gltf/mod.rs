//! glTF 2.0 scenes: a `.gltf` file with its buffers, or one `.glb`.
//!
//! What is read, and how it maps onto relight's scene:
//! - **Geometry**: the default scene's node tree (the first scene if none is marked, every
//!   root node if the file has no scene), each node's transform composed with its
//!   parents'. Meshes referenced by several nodes are instanced once per node; the nodes
//!   themselves must form disjoint strict trees (checked first, in [`tree`]).
//!   `TRIANGLES`, `TRIANGLE_STRIP` and `TRIANGLE_FAN` primitives are read; points and lines
//!   are skipped with a warning. Units are metres (`units`/`scale` in `scene.toml` still
//!   apply). A node with a negative-determinant transform has its triangles' winding
//!   flipped, so fronts stay fronts.
//! - **Surfaces**: one per node, named after the node (else its mesh, else `node<i>`),
//!   made unique with `-2`, `-3`, … suffixes.
//! - **Reflectance** (diffuse, per channel): `(1 − metallicFactor) × baseColorFactor.rgb ×`
//!   the mean linear colour of `baseColorTexture` (alpha-weighted). glTF's metallic
//!   surfaces reflect specularly, which radiosity does not model, so a metal reflects no
//!   diffuse light. Alpha and transmission are not modelled (surfaces are opaque). A
//!   channel of 1 or more is scaled to [`MAX_KD`] with a warning (`strict`: an error).
//! - **Emission**: `emissiveFactor × KHR_materials_emissive_strength ×` the mean of
//!   `emissiveTexture` is read as luminance in cd/m²; the exitance of a Lambertian emitter
//!   is π times that, in lm/m².
//! - **Lights** (`KHR_lights_punctual`): point and spot lights become luminaires, with
//!   `intensity` as the luminous intensity in candela (the `color` sets the chromaticity
//!   only) and the spot's cone angles shaping it as the extension specifies
//!   ([`Distribution::Cone`]). `range` is ignored (light falls off with the inverse square).
//!   Nodes that use the same light definition form one light group, named after the light.
//!   Directional lights are skipped with a warning.
//! - Primitives without a material get the grey default (ρ 0.5), as in OBJ scenes.
//!
//! Safety: buffers and images are files inside the scene folder (or data URIs, or the
//! `.glb`'s binary chunk); every accessor is bounds-checked against its buffer before it is
//! read, so a hostile file is an error, never a panic. Counts are bounded by the OBJ limits
//! ([`MAX_OBJ_VERTICES`], [`MAX_OBJ_TRIANGLES`]) over all instances, node trees by
//! [`MAX_GLTF_DEPTH`](crate::input_limits::MAX_GLTF_DEPTH) and
//! [`MAX_GLTF_NODE_INSTANCES`](crate::input_limits::MAX_GLTF_NODE_INSTANCES). A primitive's
//! accessors are decoded once, at its mesh's first instance.

use std::collections::hash_map::Entry;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use base64::Engine as _;
use glam::{DMat4, DVec3};

use super::files::{self, SceneDir};
use super::lights::LightGroup;
use super::materials::{Material, MaterialTable};
use super::obj::ObjPart;
use super::{mtl, texture, SceneError, SceneToml};
use crate::color::Rgb;
use crate::input_limits::{
    MAX_COORD_M, MAX_EXITANCE, MAX_GLTF_BYTES, MAX_KD, MAX_LIGHT_GROUPS, MAX_OBJ_TRIANGLES,
    MAX_OBJ_VERTICES, MAX_TEXTURES, MAX_TEXTURE_BYTES,
};
use crate::photometry::{Distribution, Luminaire, LuminaireSpec};

mod buffers;
mod lights;
mod tree;

use buffers::{accessor_bytes, percent_decode, view_bytes};
pub(crate) use lights::add_gltf_luminaires;

/// Extensions a file may require. Others (Draco or meshopt compression, quantized
/// attributes, KTX2 textures, …) are refused by name. Unrequired extensions are ignored.
const READ_EXTENSIONS: [&str; 4] = [
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_unlit",
    "KHR_texture_transform",
];

/// What a glTF file gives the scene loader.
pub(crate) struct GltfModel {
    pub(crate) table: MaterialTable,
    /// One part per (node, primitive), named after the node's surface.
    pub(crate) parts: Vec<ObjPart>,
    /// Luminaires (metres) with the id of their light group.
    pub(crate) luminaires: Vec<(String, Luminaire)>,
}

/// Reads the glTF/GLB file at canonical `path` in `sd`. `scale` converts file units to
/// metres (for luminaire positions; parts stay in file units like OBJ parts).
pub(crate) fn read_gltf(
    sd: &SceneDir,
    path: &Path,
    cfg: &SceneToml,
    scale: f64,
    files: &mut Vec<PathBuf>,
    warnings: &mut Vec<String>,
) -> Result<GltfModel, SceneError> {
    let shown = sd.display(path);
    let bytes = sd.read(path, MAX_GLTF_BYTES)?;
    // The crate's accessors index arrays it has validated; anything it could still trip
    // on is caught here rather than taking the process down.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        Reader::new(sd, &shown, cfg, scale, warnings).read(&bytes, files)
    }));
    match result {
        Ok(r) => r,
        Err(_) => Err(invalid(
            &shown,
            "the file could not be read (malformed glTF)".into(),
        )),
    }
}

fn invalid(path: &Path, message: String) -> SceneError {
    SceneError::Invalid {
        path: path.to_path_buf(),
        message,
    }
}

struct Reader<'a> {
    sd: &'a SceneDir,
    shown: &'a Path,
    cfg: &'a SceneToml,
    scale: f64,
    warnings: &'a mut Vec<String>,
}

/// Raw buffer contents, one per glTF buffer, each exactly its declared length.
type Buffers = Vec<Vec<u8>>;

/// Where material textures come from: the buffers, and the files read (a texture file is
/// added); `count` textures read so far.
struct Textures<'b> {
    buffers: &'b Buffers,
    count: usize,
    files: &'b mut Vec<PathBuf>,
}

/// A primitive's positions (file units, untransformed) and triangles.
type Triangles = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// What the walk keeps for the mesh instances: the buffers and the relight material of
/// each glTF material, unique surface names, the vertex and triangle counts so far, the
/// primitives skipped, and each primitive's triangles, decoded at its first instance.
struct Instances<'b> {
    buffers: &'b Buffers,
    mats: &'b [u32],
    surfaces: Unique,
    counts: (usize, usize),
    skipped_modes: usize,
    decoded: HashMap<(usize, usize), Option<Triangles>>,
}

/// What the walk keeps for the lights: unique luminaire ids, the light group of each
/// light definition (by index) with unique group names, and the lights skipped.
#[derive(Default)]
struct LightNames {
    ids: Unique,
    groups: HashMap<usize, String>,
    group_names: Unique,
    skipped_directional: usize,
}

impl<'a> Reader<'a> {
    fn new(
        sd: &'a SceneDir,
        shown: &'a Path,
        cfg: &'a SceneToml,
        scale: f64,
        warnings: &'a mut Vec<String>,
    ) -> Reader<'a> {
        Reader {
            sd,
            shown,
            cfg,
            scale,
            warnings,
        }
    }

    fn err(&self, message: String) -> SceneError {
        invalid(self.shown, message)
    }

    fn read(mut self, bytes: &[u8], files: &mut Vec<PathBuf>) -> Result<GltfModel, SceneError> {
        let bad = |e: gltf::Error| self.err(format!("not a valid glTF 2.0 file: {e}"));
        let unchecked = gltf::Gltf::from_slice_without_validation(bytes).map_err(bad)?;
        // gltf-json's validation indexes `accessors` with a primitive's POSITION before it
        // checks the index: check it here first.
        let root = unchecked.document.into_json();
        if let Some(ext) = root
            .extensions_required
            .iter()
            .find(|e| !READ_EXTENSIONS.contains(&e.as_str()))
        {
            return Err(self.err(format!(
                "the file requires the extension {ext}, which relight does not read (it reads \
                 {}); export without it (e.g. without mesh compression)",
                READ_EXTENSIONS.join(", ")
            )));
        }
        for (m, mesh) in root.meshes.iter().enumerate() {
            for (k, prim) in mesh.primitives.iter().enumerate() {
                if let Some((_, a)) = prim
                    .attributes
                    .iter()
                    .find(|(_, a)| root.accessors.get(a.value()).is_none())
                {
                    return Err(self.err(format!(
                        "meshes[{m}].primitives[{k}]: accessor {} does not exist",
                        a.value()
                    )));
                }
            }
        }
        let gltf = gltf::Gltf {
            document: gltf::Document::from_json(root).map_err(bad)?,
            blob: unchecked.blob,
        };
        let version = gltf.document.as_json().asset.version.clone();
        if version.split('.').next() != Some("2") {
            return Err(self.err(format!("glTF version {version} is not read (glTF 2.x is)")));
        }
        let buffers = self.buffers(&gltf, files)?;
        let mut table = MaterialTable::default();
        let mut textures = Textures {
            buffers: &buffers,
            count: 0,
            files,
        };
        let mats = self.materials(&gltf.document, &mut textures, &mut table)?;
        let mut out = GltfModel {
            table,
            parts: Vec::new(),
            luminaires: Vec::new(),
        };
        self.walk(&gltf.document, &buffers, &mats, &mut out)?;
        Ok(out)
    }

    /// The relight material of every glTF material (by index).
    fn materials(
        &mut self,
        doc: &gltf::Document,
        textures: &mut Textures<'_>,
        table: &mut MaterialTable,
    ) -> Result<Vec<u32>, SceneError> {
        let mut names = Unique::default();
        let mut out = Vec::new();
        for m in doc.materials() {
            let i = m.index().unwrap_or(0);
            let name = names.take(m.name(), || format!("material{i}"));
            let kd = self.reflectance(&m, &name, textures)?;
            let ke = self.emission(&m, &name, textures)?;
            let two_sided =
                m.double_sided() || self.cfg.material.get(&name).is_some_and(|o| o.two_sided);
            out.push(table.push(
                Material {
                    name,
                    kd,
                    ke,
                    two_sided,
                },
                self.shown,
            )?);
        }
        Ok(out)
    }

    /// The diffuse reflectance of material `m` (named `name`): `(1 − metallic) × base
    /// colour ×` its texture's mean, scaled below 1 (or refused, strict).
    fn reflectance(
        &mut self,
        m: &gltf::Material<'_>,
        name: &str,
        textures: &mut Textures<'_>,
    ) -> Result<Rgb, SceneError> {
        let pbr = m.pbr_metallic_roughness();
        let base = pbr.base_color_factor();
        let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
        let mut kd: Rgb = std::array::from_fn(|c| (1.0 - metallic) * base[c]);
        kd = self.tinted(kd, pbr.base_color_texture(), name, textures)?;
        if kd.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(self.err(format!(
                "material '{name}': base colour {kd:?} must be finite and ≥ 0"
            )));
        }
        if metallic >= 1.0 && base[..3].iter().any(|&b| b > 0.0) {
            self.warnings.push(format!(
                "{}: material '{name}' is fully metallic (metallicFactor 1, the glTF \
                 default): it reflects no diffuse light",
                self.shown.display()
            ));
        }
        if let Some(k) = mtl::clamp_kd(kd) {
            if self.cfg.strict {
                return Err(self.err(format!(
                    "material '{name}': diffuse reflectance {kd:?} must be below 1 per \
                     channel (strict = true; a lenient load would use {k:?})"
                )));
            }
            self.warnings.push(format!(
                "{}: material '{name}': diffuse reflectance reaches 1: scaled to {} {} {} \
                 (at most {MAX_KD})",
                self.shown.display(),
                k[0],
                k[1],
                k[2]
            ));
            kd = k;
        }
        Ok(kd)
    }

    /// The exitance of material `m` (named `name`), lm/m²: `π × emissiveFactor ×
    /// strength ×` its emissive texture's mean.
    fn emission(
        &mut self,
        m: &gltf::Material<'_>,
        name: &str,
        textures: &mut Textures<'_>,
    ) -> Result<Rgb, SceneError> {
        let strength = m.emissive_strength().unwrap_or(1.0);
        let ef = m.emissive_factor();
        let mut ke: Rgb = std::array::from_fn(|c| std::f32::consts::PI * ef[c] * strength);
        if ke.iter().any(|&x| x > 0.0) {
            ke = self.tinted(ke, m.emissive_texture(), name, textures)?;
        }
        if ke
            .iter()
            .any(|x| !x.is_finite() || *x < 0.0 || *x > MAX_EXITANCE)
        {
            return Err(self.err(format!(
                "material '{name}': emission (π × emissiveFactor × strength) {ke:?} lm/m² \
                 must be in [0, {MAX_EXITANCE}]"
            )));
        }
        Ok(ke)
    }

    /// `c` times the mean colour of the texture `info` of material `material`, when it
    /// has one that can be read.
    fn tinted(
        &mut self,
        c: Rgb,
        info: Option<gltf::texture::Info<'_>>,
        material: &str,
        textures: &mut Textures<'_>,
    ) -> Result<Rgb, SceneError> {
        let Some(info) = info else {
            return Ok(c);
        };
        Ok(
            match self.texture_mean(info.texture(), material, textures)? {
                Some(mean) => std::array::from_fn(|k| c[k] * mean[k]),
                None => c,
            },
        )
    }

    /// The mean linear colour of a texture's image, or None (with a warning) when it
    /// cannot be read and the load is lenient.
    fn texture_mean(
        &mut self,
        tex: gltf::Texture<'_>,
        material: &str,
        textures: &mut Textures<'_>,
    ) -> Result<Option<Rgb>, SceneError> {
        textures.count += 1;
        if textures.count > MAX_TEXTURES {
            return Err(self.err(format!("more than {MAX_TEXTURES} textures")));
        }
        let img = tex.source();
        let what = format!("images[{}]", img.index());
        let bytes = match img.source() {
            gltf::image::Source::View { view, .. } if view.length() as u64 > MAX_TEXTURE_BYTES => {
                Err(self.err(format!(
                    "{what}: larger than {}",
                    files::human_bytes(MAX_TEXTURE_BYTES)
                )))
            }
            gltf::image::Source::View { view, .. } => view_bytes(&view, textures.buffers)
                .map(<[u8]>::to_vec)
                .ok_or_else(|| self.err(format!("{what}: its bufferView lies outside its buffer"))),
            gltf::image::Source::Uri { uri, .. } => {
                let plain = !uri.starts_with("data:");
                match percent_decode(uri) {
                    Some(name) if plain && !self.cfg.strict => {
                        match self.sd.resolve_lenient(&name, self.shown, 0, &what)? {
                            Some(_) => {
                                self.uri_bytes(uri, &what, MAX_TEXTURE_BYTES, textures.files)
                            }
                            None => {
                                self.warnings.push(format!(
                                    "{}: texture '{name}' of material '{material}' is not in \
                                     the scene folder: its factor is used alone",
                                    self.shown.display()
                                ));
                                return Ok(None);
                            }
                        }
                    }
                    _ => self.uri_bytes(uri, &what, MAX_TEXTURE_BYTES, textures.files),
                }
            }
        }?;
        match texture::mean_linear_rgb(&bytes) {
            Ok(m) => Ok(Some(m)),
            Err(e) if self.cfg.strict => Err(self.err(format!(
                "{what} (material '{material}') cannot be read: {e} (strict = true)"
            ))),
            Err(e) => {
                self.warnings.push(format!(
                    "{}: {what} of material '{material}' cannot be read ({e}): its factor is \
                     used alone",
                    self.shown.display()
                ));
                Ok(None)
            }
        }
    }

    /// Walks the node tree: meshes become parts, lights luminaires.
    fn walk(
        &mut self,
        doc: &gltf::Document,
        buffers: &Buffers,
        mats: &[u32],
        out: &mut GltfModel,
    ) -> Result<(), SceneError> {
        // The hierarchy is a forest of strict trees within the limits (checked in one
        // pass, before any mesh is decoded), so every node below is visited once.
        let roots = tree::roots(doc).map_err(|m| self.err(m))?;
        let all: Vec<gltf::Node<'_>> = doc.nodes().collect();
        let mut instances = Instances {
            buffers,
            mats,
            surfaces: Unique::default(),
            counts: (0, 0),
            skipped_modes: 0,
            decoded: HashMap::new(),
        };
        let mut lights = LightNames::default();
        let mut stack: Vec<(gltf::Node<'_>, DMat4)> = roots
            .into_iter()
            .rev()
            .map(|i| (all[i].clone(), DMat4::IDENTITY))
            .collect();
        while let Some((node, parent)) = stack.pop() {
            let local = node.transform().matrix().map(|c| c.map(f64::from));
            let world = parent * DMat4::from_cols_array_2d(&local);
            if !world.is_finite() {
                return Err(self.err(format!("nodes[{}]: transform is not finite", node.index())));
            }
            if let Some(mesh) = node.mesh() {
                self.mesh_parts(&node, &mesh, &world, &mut instances, out)?;
            }
            if let Some(light) = node.light() {
                self.light(&node, &light, &world, &mut lights, out)?;
            }
            for c in node.children().collect::<Vec<_>>().into_iter().rev() {
                stack.push((c, world));
            }
        }
        self.warn_skipped(instances.skipped_modes, lights.skipped_directional);
        Ok(())
    }

    /// The parts of `mesh` instanced by `node` at `world`.
    fn mesh_parts(
        &mut self,
        node: &gltf::Node<'_>,
        mesh: &gltf::Mesh<'_>,
        world: &DMat4,
        inst: &mut Instances<'_>,
        out: &mut GltfModel,
    ) -> Result<(), SceneError> {
        let name = inst.surfaces.take(node.name().or(mesh.name()), || {
            format!("node{}", node.index())
        });
        for prim in mesh.primitives() {
            let tris = match inst.decoded.entry((mesh.index(), prim.index())) {
                Entry::Occupied(e) => e.into_mut(),
                Entry::Vacant(e) => e.insert(self.primitive(&prim, mesh, inst.buffers)?),
            };
            let Some((positions, indices)) = tris else {
                inst.skipped_modes += 1;
                continue;
            };
            inst.counts.0 += positions.len();
            inst.counts.1 += indices.len();
            if inst.counts.0 > MAX_OBJ_VERTICES || inst.counts.1 > MAX_OBJ_TRIANGLES {
                return Err(self.err(format!(
                    "more than {MAX_OBJ_VERTICES} vertices or {MAX_OBJ_TRIANGLES} \
                     triangles over all mesh instances"
                )));
            }
            let part = self.part(&name, world, positions, indices, &prim, inst.mats)?;
            out.parts.push(part);
        }
        Ok(())
    }

    /// Warns of the primitives (points, lines) and lights (directional) the walk skipped.
    fn warn_skipped(&mut self, skipped_modes: usize, skipped_directional: usize) {
        if skipped_modes > 0 {
            self.warnings.push(format!(
                "{}: {skipped_modes} primitive(s) of points or lines skipped (only triangles \
                 take part in radiosity)",
                self.shown.display()
            ));
        }
        if skipped_directional > 0 {
            self.warnings.push(format!(
                "{}: {skipped_directional} directional light(s) skipped (luminaires are points \
                 and spots)",
                self.shown.display()
            ));
        }
    }

    /// The positions (file units, untransformed) and triangles of one primitive; None for
    /// primitives that are not triangles.
    fn primitive(
        &self,
        prim: &gltf::Primitive<'_>,
        mesh: &gltf::Mesh<'_>,
        buffers: &Buffers,
    ) -> Result<Option<Triangles>, SceneError> {
        use gltf::mesh::Mode;
        let what = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            return Ok(None);
        }
        let positions = self.positions(prim, &what, buffers)?;
        let n = positions.len();
        let list: Vec<u32> = match prim.indices() {
            None => (0..n as u32).collect(),
            Some(acc) => self.indices(&acc, &what, buffers, n)?,
        };
        let tris: Vec<[u32; 3]> = match mode {
            Mode::Triangles => list.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            Mode::TriangleStrip => (2..list.len())
                .map(|i| {
                    if i % 2 == 0 {
                        [list[i - 2], list[i - 1], list[i]]
                    } else {
                        [list[i - 1], list[i - 2], list[i]]
                    }
                })
                .collect(),
            _ => (2..list.len())
                .map(|i| [list[0], list[i - 1], list[i]])
                .collect(),
        };
        Ok(Some((positions, tris)))
    }

    /// The POSITION attribute of primitive `prim` (named `what` in errors).
    fn positions(
        &self,
        prim: &gltf::Primitive<'_>,
        what: &str,
        buffers: &Buffers,
    ) -> Result<Vec<[f32; 3]>, SceneError> {
        let pos = prim
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| self.err(format!("{what}: no POSITION attribute")))?;
        if pos.data_type() != gltf::accessor::DataType::F32
            || pos.dimensions() != gltf::accessor::Dimensions::Vec3
            || pos.normalized()
        {
            return Err(self.err(format!(
                "{what}: POSITION must be float VEC3 (quantized positions are not read)"
            )));
        }
        let raw = accessor_bytes(&pos, buffers, 12, MAX_OBJ_VERTICES)
            .map_err(|m| self.err(format!("{what}: POSITION {m}")))?;
        Ok(raw
            .map(|b| {
                std::array::from_fn(|k| {
                    f32::from_le_bytes(b[4 * k..4 * k + 4].try_into().unwrap_or([0; 4]))
                })
            })
            .collect())
    }

    /// The vertex indices of accessor `acc` (of primitive `what`), each below `n`.
    fn indices(
        &self,
        acc: &gltf::Accessor<'_>,
        what: &str,
        buffers: &Buffers,
        n: usize,
    ) -> Result<Vec<u32>, SceneError> {
        use gltf::accessor::DataType;
        let size = match acc.data_type() {
            DataType::U8 => 1,
            DataType::U16 => 2,
            DataType::U32 => 4,
            other => {
                return Err(self.err(format!(
                    "{what}: indices must be unsigned integers, not {other:?}"
                )))
            }
        };
        if acc.dimensions() != gltf::accessor::Dimensions::Scalar {
            return Err(self.err(format!("{what}: indices must be SCALAR")));
        }
        let raw = accessor_bytes(acc, buffers, size, 3 * MAX_OBJ_TRIANGLES)
            .map_err(|m| self.err(format!("{what}: indices {m}")))?;
        let list: Vec<u32> = raw
            .map(|b| match size {
                1 => b[0] as u32,
                2 => u16::from_le_bytes([b[0], b[1]]) as u32,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            })
            .collect();
        if let Some(bad) = list.iter().find(|&&i| i as usize >= n) {
            return Err(self.err(format!("{what}: index {bad} out of range ({n} vertices)")));
        }
        Ok(list)
    }

    /// One part: the primitive's triangles in file units, transformed by `world`.
    fn part(
        &self,
        name: &str,
        world: &DMat4,
        positions: &[[f32; 3]],
        tris: &[[u32; 3]],
        prim: &gltf::Primitive<'_>,
        mats: &[u32],
    ) -> Result<ObjPart, SceneError> {
        let flip = world.determinant() < 0.0;
        let mut flat = Vec::with_capacity(3 * positions.len());
        for p in positions {
            let w = world.transform_point3(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            if !w.is_finite() || (w * self.scale).abs().max_element() > MAX_COORD_M {
                return Err(self.err(format!(
                    "node '{name}': vertex {w} lies beyond {MAX_COORD_M} m"
                )));
            }
            flat.extend([w.x as f32, w.y as f32, w.z as f32]);
        }
        let indices = tris
            .iter()
            .flat_map(|t| if flip { [t[0], t[2], t[1]] } else { *t })
            .collect();
        let material = prim
            .material()
            .index()
            .and_then(|i| mats.get(i))
            .map(|&m| m as usize);
        Ok(ObjPart {
            name: name.to_string(),
            material,
            positions: flat,
            indices,
        })
    }
}

/// Names made unique: the first use of a name keeps it, later ones get `-2`, `-3`, ….
/// The next suffix to try is kept per name, so n uses of one name cost O(n), not O(n²).
#[derive(Default)]
struct Unique {
    taken: HashSet<String>,
    next: HashMap<String, usize>,
}

impl Unique {
    fn take(&mut self, name: Option<&str>, fallback: impl FnOnce() -> String) -> String {
        let base = match name.map(str::trim) {
            Some(n) if !n.is_empty() => n.to_string(),
            _ => fallback(),
        };
        if self.taken.insert(base.clone()) {
            return base;
        }
        let k = self.next.entry(base.clone()).or_insert(2);
        loop {
            let name = format!("{base}-{k}");
            *k += 1;
            if self.taken.insert(name.clone()) {
                return name;
            }
        }
    }
}

impl MaterialTable {
    /// Adds a material read from a model file (glTF); its index.
    pub(crate) fn push(&mut self, m: Material, shown: &Path) -> Result<u32, SceneError> {
        if self.materials.len() >= crate::input_limits::MAX_MATERIALS {
            return Err(invalid(
                shown,
                format!("more than {} materials", crate::input_limits::MAX_MATERIALS),
            ));
        }
        let i = self.materials.len() as u32;
        self.index.insert(m.name.clone(), i);
        self.materials.push(m);
        Ok(i)
    }
}

#[cfg(test)]
mod tests {
    use super::lights::sanitize_id;
    use super::{percent_decode, Unique};

    #[test]
    fn names_are_made_unique_and_ids_safe() {
        let mut u = Unique::default();
        assert_eq!(u.take(Some("Desk"), || "x".into()), "Desk");
        assert_eq!(u.take(Some("Desk"), || "x".into()), "Desk-2");
        assert_eq!(u.take(Some(" "), || "node3".into()), "node3");
        assert_eq!(sanitize_id("Pendant Lamp.001"), "pendant-lamp-001");
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("a%2"), None);
    }
}
