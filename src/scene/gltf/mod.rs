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
//!   made unique with `-2`, `-3`, … suffixes; a node whose mesh's primitives use several
//!   materials gives one surface per material, `node / material`.
//! - **Reflectance** (diffuse, per channel): `(1 − metallicFactor) × baseColorFactor.rgb ×`
//!   the mean linear colour of `baseColorTexture` (alpha-weighted). The radiosity
//!   solution is diffuse, so a metal reflects no diffuse light. A channel of 1 or more is
//!   scaled to [`MAX_KD`] with a warning (`strict`: an error).
//! - **Glass**: `alphaMode` BLEND, MASK cut-outs (the base colour texture's texels below
//!   the cutoff, when they are most of it) and `KHR_materials_transmission` make a
//!   material glazing, its transmittance `(1 − α) + α · t · Y(base)` (see
//!   `materials.rs`); `scene.toml` may override it or keep the material `opaque`.
//! - **Compression**: `EXT_meshopt_compression` views are decoded ([`meshopt`]) and
//!   `KHR_mesh_quantization` positions read as integers and dequantized by the node
//!   transforms.
//! - **Gloss** (`final` images only): a material with `roughnessFactor` < 1 or a metallic
//!   part gets glTF's GGX specular lobe ([`Gloss`](crate::scene::Gloss)), its dielectric
//!   Fresnel from `KHR_materials_ior` and `KHR_materials_specular` (factors only).
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

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use super::files::SceneDir;
use super::materials::MaterialTable;
use super::obj::ObjPart;
use super::{SceneError, SceneToml};
use crate::input_limits::MAX_GLTF_BYTES;
use crate::photometry::Luminaire;

mod buffers;
mod lights;
mod materials;
mod meshopt;
mod primitives;
mod tree;
mod walk;

pub(crate) use lights::add_gltf_luminaires;

/// Extensions a file may require. Others (Draco compression, …) are refused by name.
/// Unrequired extensions are ignored. KTX2 and AVIF textures are skipped with a warning
/// (the material's factor alone sets its colour); WebP textures are read.
const READ_EXTENSIONS: [&str; 13] = [
    "EXT_texture_webp",
    "KHR_texture_basisu",
    "EXT_texture_avif",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_mesh_quantization",
    "KHR_materials_transmission",
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
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

use buffers::Buffers;

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
        let mut root = unchecked.document.into_json();
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
        // Every required extension is read here; gltf-json would refuse the ones it does
        // not know itself (compression, quantization).
        root.extensions_required.clear();
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
        let (table, mats) = self.materials(&gltf.document, &buffers, files)?;
        let mut out = GltfModel {
            table,
            parts: Vec::new(),
            luminaires: Vec::new(),
        };
        self.walk(&gltf.document, &buffers, &mats, &mut out)?;
        Ok(out)
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

#[cfg(test)]
mod tests {
    use super::buffers::percent_decode;
    use super::lights::sanitize_id;
    use super::Unique;

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
