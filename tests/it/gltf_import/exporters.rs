//! glTF as exporters write it: every material of a room in one mesh, meshopt-compressed
//! and quantized buffers (`EXT_meshopt_compression`, `KHR_mesh_quantization`), and glass
//! (`KHR_materials_transmission`, `alphaMode` BLEND) that lets daylight in.

use glam::DVec3;
use relight::bake::{load_or_bake, BakeOptions, CachePolicy};
use relight::model::query::IlluminanceQuery;
use relight::model::sky_state::SkySpec;
use relight::model::{Cancel, Model};
use relight::scene::Scene;
use serde_json::{json, Value};

use super::{folder, kd_of, load, load_err, material_scene, png, warned, Doc};
use crate::common;

/// The 4 × 3 × 4 m room of [`room_quads`] as (material, corners) quads.
type Quad = (usize, [[f32; 3]; 4]);

/// A 4 × 4 m room, 3 m high (x, z in 0 … 4), fronts inward: material 0 for the floor, 1
/// for the walls and the roof around a 1 × 1 m opening at x, z in 1.5 … 2.5, and material 2
/// for a pane over the opening at y = 3, facing down.
fn room_quads() -> Vec<Quad> {
    let (w, h) = (4.0f32, 3.0f32);
    let (a, b) = (1.5f32, 2.5f32);
    let mut q: Vec<Quad> = vec![
        (0, [[0., 0., 0.], [0., 0., w], [w, 0., w], [w, 0., 0.]]),
        (1, [[0., 0., 0.], [w, 0., 0.], [w, h, 0.], [0., h, 0.]]),
        (1, [[0., 0., w], [0., h, w], [w, h, w], [w, 0., w]]),
        (1, [[0., 0., 0.], [0., h, 0.], [0., h, w], [0., 0., w]]),
        (1, [[w, 0., 0.], [w, 0., w], [w, h, w], [w, h, 0.]]),
    ];
    // The roof around the opening, facing down (-y).
    for (x0, x1, z0, z1) in [(0., w, 0., a), (0., w, b, w), (0., a, a, b), (b, w, a, b)] {
        q.push((1, [[x0, h, z0], [x1, h, z0], [x1, h, z1], [x0, h, z1]]));
    }
    q.push((2, [[a, h, a], [b, h, a], [b, h, b], [a, h, b]]));
    q
}

/// Positions and triangle indices of `quads`, all in one list.
fn flatten(quads: &[&[[f32; 3]; 4]]) -> (Vec<[f32; 3]>, Vec<u32>) {
    let mut p = Vec::new();
    let mut i = Vec::new();
    for c in quads {
        let k = p.len() as u32;
        p.extend_from_slice(&c[..]);
        i.extend([k, k + 1, k + 2, k, k + 2, k + 3]);
    }
    (p, i)
}

/// The area of a surface, m² (its triangles face several ways).
fn surface_area(s: &Scene, name: &str) -> f64 {
    let k = s.surface_index(name).unwrap() as u32;
    s.triangles
        .iter()
        .filter(|t| t.surface == k)
        .map(|t| (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length() / 2.0)
        .sum()
}

/// The room as one node holding one mesh with a primitive per material (as SketchUp-style
/// exporters write it), materials `mats`; `ext` adds top-level fields (extensionsUsed, …).
fn one_mesh_room(mats: Value, ext: Value) -> Vec<u8> {
    one_mesh_room_in(Doc::default(), mats, ext)
}

/// [`one_mesh_room`] written after what `d` already holds (texture images).
fn one_mesh_room_in(mut d: Doc, mats: Value, ext: Value) -> Vec<u8> {
    let quads = room_quads();
    let mut prims = Vec::new();
    for m in 0..3 {
        let mine: Vec<&[[f32; 3]; 4]> = quads.iter().filter(|q| q.0 == m).map(|q| &q.1).collect();
        let (p, i) = flatten(&mine);
        let (pa, ia) = (d.positions(&p), d.indices(&i));
        prims.push(json!({"attributes": {"POSITION": pa}, "indices": ia, "material": m}));
    }
    let mut rest = json!({
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "Room", "mesh": 0}],
        "meshes": [{"name": "SketchUp", "primitives": prims}],
        "materials": mats,
    });
    for (k, v) in ext.as_object().unwrap() {
        rest[k] = v.clone();
    }
    d.glb(rest)
}

fn materials(glass: Value) -> Value {
    json!([
        {"name": "Oak", "pbrMetallicRoughness": {"baseColorFactor": [0.4, 0.3, 0.2, 1], "metallicFactor": 0}},
        {"name": "Paint", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0}},
        glass,
    ])
}

const OPAQUE_GLASS: &str = r#"{"name": "Glass", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0}}"#;

#[test]
fn one_mesh_of_many_materials_gives_one_surface_per_material() {
    let glb = one_mesh_room(
        materials(serde_json::from_str(OPAQUE_GLASS).unwrap()),
        json!({}),
    );
    let dir = folder(&[("room.glb", &glb)]);
    let s = load(dir.path());
    let mut names: Vec<&str> = s.surfaces.iter().map(|x| x.name.as_str()).collect();
    names.sort_unstable();
    assert_eq!(names, ["Room / Glass", "Room / Oak", "Room / Paint"]);
    // Areas: the floor 16 m², walls 4 × 12 m² and the roof 16 − 1 m², the pane 1 m².
    assert!((surface_area(&s, "Room / Oak") - 16.0).abs() < 1e-9);
    assert!((surface_area(&s, "Room / Paint") - 63.0).abs() < 1e-9);
    assert!((surface_area(&s, "Room / Glass") - 1.0).abs() < 1e-9);
    // Every triangle keeps its own material.
    for t in &s.triangles {
        let surface = &s.surfaces[t.surface as usize].name;
        let material = &s.materials[t.material as usize].name;
        assert!(
            surface.ends_with(material.as_str()),
            "{surface} / {material}"
        );
    }
    // A `[surface.NAME]` option names the split surface.
    std::fs::write(
        dir.path().join("scene.toml"),
        "[surface.\"Room / Glass\"]\ntwo_sided = true\n",
    )
    .unwrap();
    let s = load(dir.path());
    let g = s.surface_index("Room / Glass").unwrap();
    assert!(s.surfaces[g].two_sided);
    // The node's own name is no surface: the error lists the ones it became.
    std::fs::write(
        dir.path().join("scene.toml"),
        "[surface.Room]\ntwo_sided = true\n",
    )
    .unwrap();
    let e = load_err(dir.path());
    assert!(
        e.contains("[surface.Room]: no such object/group")
            && e.contains("'Room / Glass', 'Room / Oak', 'Room / Paint'"),
        "{e}"
    );
}

/// The room in a folder with `scene.toml` text `toml` (a site is added).
fn room_scene(glb: &[u8], toml: &str) -> tempfile::TempDir {
    let toml = format!(
        "[site]\nlatitude = 49.5\nlongitude = 8.5\ntimezone = 1\n[mesh]\ntarget_patches = \
         300\n{toml}"
    );
    folder(&[("room.glb", glb), ("scene.toml", toml.as_bytes())])
}

/// The floor's mean illuminance (lx) and the illuminance at the floor's centre, under a
/// uniform sky of 10 klx, factored mode.
fn sky_on_floor(dir: &std::path::Path) -> (f64, f64) {
    let opts = BakeOptions {
        mode: Some(relight::transport::transfer::TransferMode::Factored),
        ..Default::default()
    };
    let m = Model::new(load_or_bake(dir, CachePolicy::Off, &opts, &|_, _| {}).unwrap());
    let spec: SkySpec =
        serde_json::from_value(json!({"type": "uniform", "horizontal_illuminance": 10000}))
            .unwrap();
    let state = spec.resolve(m.site().unwrap()).unwrap();
    let floor = m.baked.scene.surface_index("Room / Oak").unwrap();
    let q = IlluminanceQuery {
        surfaces: vec![floor],
        points: vec![(DVec3::new(2.0, 0.0, 2.0), DVec3::Y)],
        ..Default::default()
    };
    let a = m.daylight(&state, None, &q, &Cancel::default()).unwrap();
    (a.surfaces["Room / Oak"].avg.lux, a.points[0].lux)
}

#[test]
fn glass_materials_let_the_sky_in_as_the_same_pane_declared_in_scene_toml() {
    let _gate = common::shared();
    // Thin-walled glass: transmission 1 through a base colour of luminance 0.8.
    let transmissive = json!({"name": "Glass", "pbrMetallicRoughness":
        {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0, "roughnessFactor": 0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}}});
    let used = json!({"extensionsUsed": ["KHR_materials_transmission"]});
    let file_glass = one_mesh_room(materials(transmissive), used);
    let plain = one_mesh_room(
        materials(serde_json::from_str(OPAQUE_GLASS).unwrap()),
        json!({}),
    );
    // The same pane, opaque in the file and declared glazing in scene.toml.
    let declared = room_scene(&plain, "[material.Glass]\ntransmittance = 0.8\n");
    let from_file = room_scene(&file_glass, "");
    let s = load(from_file.path());
    assert!(
        s.surface_index("Room / Glass").is_none(),
        "glazing is not meshed"
    );
    assert_eq!(s.glazing.len(), 2);
    assert!(s
        .glazing
        .iter()
        .all(|p| (p.transmittance - 0.8).abs() < 1e-6));
    let want = sky_on_floor(declared.path());
    let got = sky_on_floor(from_file.path());
    assert!(
        want.1 > 100.0,
        "the sky reaches the floor through the pane: {want:?}"
    );
    assert!(
        (got.0 - want.0).abs() <= 1e-9 * want.0,
        "{got:?} vs {want:?}"
    );
    assert!(
        (got.1 - want.1).abs() <= 1e-9 * want.1,
        "{got:?} vs {want:?}"
    );
    // scene.toml overrides the file: another transmittance, or opaque.
    let half = room_scene(&file_glass, "[material.Glass]\ntransmittance = 0.4\n");
    let h = sky_on_floor(half.path());
    assert!(
        (h.1 - 0.5 * got.1).abs() <= 5e-3 * got.1,
        "{h:?} vs {got:?}"
    );
    let shut = room_scene(&file_glass, "[material.Glass]\nopaque = true\n");
    let s = load(shut.path());
    assert!(s.glazing.is_empty() && s.surface_index("Room / Glass").is_some());
    // Shut, the room is closed: what is left are the few sky rays from random points on
    // patches that slip out through the room's edges (see daylight.rs).
    let dark = sky_on_floor(shut.path());
    assert!(
        dark.0 < 1e-2 * got.0 && dark.1 < 1e-2 * got.1,
        "{dark:?} vs {got:?}"
    );
}

#[test]
fn alpha_blending_and_masks_set_the_transmittance() {
    // BLEND at alpha 0.3 with no transmission: 70 % passes. MASK below the cutoff: all
    // of it. MASK above it, and OPAQUE whatever its alpha: none (meshed as before).
    for (glass, want) in [
        (json!({"alphaMode": "BLEND"}), Some(0.7)),
        (json!({"alphaMode": "MASK", "alphaCutoff": 0.5}), Some(1.0)),
        (json!({"alphaMode": "MASK", "alphaCutoff": 0.2}), None),
        (json!({"alphaMode": "OPAQUE"}), None),
    ] {
        let mut m: Value = serde_json::from_str(OPAQUE_GLASS).unwrap();
        m["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.8, 0.8, 0.8, 0.3]);
        for (k, v) in glass.as_object().unwrap() {
            m[k] = v.clone();
        }
        let dir = folder(&[("room.glb", &one_mesh_room(materials(m), json!({})))]);
        let s = load(dir.path());
        match want {
            Some(t) => {
                assert_eq!(s.glazing.len(), 2, "{glass}");
                assert!(s
                    .glazing
                    .iter()
                    .all(|p| (p.transmittance as f64 - t).abs() < 1e-6));
            }
            None => assert!(s.glazing.is_empty(), "{glass}"),
        }
    }
    // Emissive glass stays an opaque emitter, with a warning.
    let mut m: Value = serde_json::from_str(OPAQUE_GLASS).unwrap();
    m["alphaMode"] = json!("BLEND");
    m["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.8, 0.8, 0.8, 0.3]);
    m["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    let dir = folder(&[("room.glb", &one_mesh_room(materials(m), json!({})))]);
    let s = load(dir.path());
    assert!(s.glazing.is_empty());
    assert!(warned(&s, &["'Glass'", "emits"]), "{:?}", s.warnings);
}

#[test]
fn mask_cut_outs_pass_light_through_their_clear_texels() {
    // A leaf card's texture: 3 of 10 texels opaque, the rest clear. Under MASK, 30 % of
    // the pane is leaf and 70 % of the daylight passes. A perforated panel (8 of 10
    // opaque) stays an opaque surface, with a warning.
    let texture = |opaque: u32| {
        let img = image::RgbaImage::from_fn(10, 1, |x, _| {
            image::Rgba(if x < opaque {
                [60, 110, 40, 255]
            } else {
                [0, 0, 0, 0]
            })
        });
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    };
    for (opaque, want) in [(3, Some(0.7)), (8, None)] {
        let mut d = Doc::default();
        let view = d.view(&texture(opaque));
        let mask = json!({"name": "Glass", "alphaMode": "MASK", "pbrMetallicRoughness":
            {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "baseColorTexture": {"index": 0}}});
        let images = json!({"images": [{"bufferView": view, "mimeType": "image/png"}],
                            "textures": [{"source": 0}]});
        let dir = folder(&[("room.glb", &one_mesh_room_in(d, materials(mask), images))]);
        let s = load(dir.path());
        match want {
            Some(t) => {
                assert_eq!(s.glazing.len(), 2, "{opaque} opaque texels");
                assert!(
                    s.glazing
                        .iter()
                        .all(|p| (p.transmittance as f64 - t).abs() < 1e-6),
                    "{:?}",
                    s.glazing
                        .iter()
                        .map(|p| p.transmittance)
                        .collect::<Vec<_>>()
                );
            }
            None => {
                assert!(s.glazing.is_empty());
                assert!(s.surface_index("Room / Glass").is_some());
                assert!(warned(&s, &["'Glass'", "MASK", "80 %"]), "{:?}", s.warnings);
            }
        }
    }
}

/// The room as one mesh whose positions are `KHR_mesh_quantization` unsigned shorts
/// (normalized, dequantized by the node's scale) and, with `meshopt`, whose views are
/// `EXT_meshopt_compression` streams (positions: ATTRIBUTES of stride 8; indices:
/// TRIANGLES) with a fallback buffer that has no data.
fn packed_room(meshopt: bool) -> Vec<u8> {
    let quads = room_quads();
    let all: Vec<&[[f32; 3]; 4]> = quads.iter().map(|q| &q.1).collect();
    let (p, idx) = flatten(&all);
    // 4 m spans 0 … 65535: the room's corners (multiples of 0.5 m) land on exact steps
    // of 4/65535 m only at 0 and 4; others round to the nearest step.
    let q: Vec<[u16; 4]> = p
        .iter()
        .map(|v| {
            let c = |x: f32| (x / 4.0 * 65535.0).round() as u16;
            [c(v[0]), c(v[1]), c(v[2]), 0]
        })
        .collect();
    let raw_pos: Vec<u8> = q.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let raw_idx: Vec<u8> = idx.iter().flat_map(|x| x.to_le_bytes()).collect();
    let (n, m) = (p.len(), idx.len());
    let mut bin = Vec::new();
    let mut views = Vec::new();
    let push = |bin: &mut Vec<u8>, bytes: &[u8]| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let at = bin.len();
        bin.extend_from_slice(bytes);
        (at, bytes.len())
    };
    if meshopt {
        let ep = ::meshopt::encoding::encode_vertex_buffer(&q).unwrap();
        let ei = ::meshopt::encoding::encode_index_buffer(&idx, n).unwrap();
        let (a, la) = push(&mut bin, &ep);
        let (b, lb) = push(&mut bin, &ei);
        views.push(
            json!({"buffer": 1, "byteOffset": 0, "byteLength": 8 * n, "byteStride": 8,
            "target": 34962, "extensions": {"EXT_meshopt_compression": {"buffer": 0,
            "byteOffset": a, "byteLength": la, "byteStride": 8, "count": n,
            "mode": "ATTRIBUTES"}}}),
        );
        views.push(
            json!({"buffer": 1, "byteOffset": 8 * n, "byteLength": 4 * m,
            "target": 34963, "extensions": {"EXT_meshopt_compression": {"buffer": 0,
            "byteOffset": b, "byteLength": lb, "byteStride": 4, "count": m,
            "mode": "TRIANGLES"}}}),
        );
    } else {
        let (a, la) = push(&mut bin, &raw_pos);
        let (b, lb) = push(&mut bin, &raw_idx);
        views.push(json!({"buffer": 0, "byteOffset": a, "byteLength": la, "byteStride": 8}));
        views.push(json!({"buffer": 0, "byteOffset": b, "byteLength": lb}));
    }
    let mut buffers = vec![json!({"byteLength": bin.len()})];
    let mut used = vec!["KHR_mesh_quantization"];
    if meshopt {
        buffers.push(json!({"byteLength": 8 * n + 4 * m,
            "extensions": {"EXT_meshopt_compression": {"fallback": true}}}));
        used.push("EXT_meshopt_compression");
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "gltfpack-style test"},
        "extensionsUsed": used, "extensionsRequired": used,
        "buffers": buffers, "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5123, "normalized": true, "count": n,
             "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5125, "count": m, "type": "SCALAR"},
        ],
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "Room", "mesh": 0, "scale": [4, 4, 4]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    });
    super::glb(&doc, &bin)
}

/// The triangles of a scene as sorted lists of corners, rounded to 0.1 mm.
fn corners(s: &Scene) -> Vec<[[i64; 3]; 3]> {
    let key = |p: DVec3| (p * 1e4).round().as_i64vec3().to_array();
    let mut v: Vec<[[i64; 3]; 3]> = s
        .triangles
        .iter()
        .map(|t| {
            let mut c = t.p.map(key);
            c.sort_unstable();
            c
        })
        .collect();
    v.sort_unstable();
    v
}

#[test]
fn meshopt_compressed_and_quantized_files_load_to_the_same_triangles_as_their_plain_twins() {
    let quads = room_quads();
    let all: Vec<&[[f32; 3]; 4]> = quads.iter().map(|q| &q.1).collect();
    let (p, i) = flatten(&all);
    let mut d = Doc::default();
    let (pa, ia) = (d.positions(&p), d.indices(&i));
    let plain = d.glb(json!({
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "Room", "mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pa}, "indices": ia}]}],
    }));
    let twin = corners(&load(folder(&[("room.glb", &plain)]).path()));
    for meshopt in [false, true] {
        let dir = folder(&[("room.glb", &packed_room(meshopt))]);
        let s = load(dir.path());
        assert_eq!(corners(&s), twin, "meshopt {meshopt}");
        assert!((surface_area(&s, "Room") - 80.0).abs() < 1e-3);
    }
}

#[test]
fn malformed_compressed_views_are_refused_naming_the_view() {
    let good = packed_room(true);
    // Corrupt the first compressed stream (the positions start the binary chunk).
    let json_len = u32::from_le_bytes(good[12..16].try_into().unwrap()) as usize;
    let bin_at = 20 + json_len + 8;
    let mut bad = good.clone();
    bad[bin_at] = 0x00;
    let e = load_err(folder(&[("room.glb", &bad)]).path());
    assert!(e.contains("bufferViews[0] (meshopt compression)"), "{e}");
    // A count that would decode past the limit is refused before anything is allocated.
    let text = std::str::from_utf8(&good[20..20 + json_len]).unwrap();
    let mut doc: Value = serde_json::from_str(text).unwrap();
    doc["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["count"] = json!(1u64 << 40);
    let bin = &good[bin_at..];
    let e = load_err(folder(&[("room.glb", &super::glb(&doc, bin))]).path());
    assert!(
        e.contains("bufferViews[0]") && e.contains("decoded views"),
        "{e}"
    );
    // An unknown filter names itself.
    doc["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["count"] = json!(32);
    doc["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["filter"] = json!("WAVELET");
    let e = load_err(folder(&[("room.glb", &super::glb(&doc, bin))]).path());
    assert!(e.contains("filter 'WAVELET'"), "{e}");
}

/// Each material's total area (m²) and the triangle count of a scene.
fn material_areas(s: &Scene) -> (std::collections::BTreeMap<String, f64>, usize) {
    let mut out = std::collections::BTreeMap::new();
    for t in &s.triangles {
        let a = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length() / 2.0;
        *out.entry(s.materials[t.material as usize].name.clone())
            .or_insert(0.0) += a;
    }
    (out, s.triangles.len())
}

#[test]
fn the_gallery_packed_by_gltfpack_loads_as_the_plain_gallery() {
    // tests/data/gltfpack/gallery-packed.glb is scenes/gallery written by gltfpack 1.3
    // (`gltfpack -i gallery.gltf -o gallery-packed.glb -c -kn -km`): meshopt-compressed
    // views, 14-bit integer positions (KHR_mesh_quantization) dequantized by the nodes.
    let repo = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let plain = load(&repo.join("scenes/gallery"));
    let packed_dir = folder(&[(
        "gallery.glb",
        &std::fs::read(repo.join("tests/data/gltfpack/gallery-packed.glb")).unwrap(),
    )]);
    // gltfpack drops the lights' names: their groups take the ids `light0`, `light1`.
    let toml = std::fs::read_to_string(repo.join("scenes/gallery/scene.toml"))
        .unwrap()
        .replace("id = \"spots\"", "id = \"light0\"")
        .replace("id = \"lamp\"", "id = \"light1\"");
    std::fs::write(packed_dir.path().join("scene.toml"), toml).unwrap();
    let packed = load(packed_dir.path());
    let (want, n) = material_areas(&plain);
    let (got, m) = material_areas(&packed);
    assert_eq!(m, n);
    assert_eq!(
        got.keys().collect::<Vec<_>>(),
        want.keys().collect::<Vec<_>>()
    );
    for (k, a) in &want {
        // 14 bits over the gallery's 6 m: a step of 0.37 mm on each coordinate.
        assert!((got[k] - a).abs() <= 1e-3 * a, "{k}: {} vs {a} m²", got[k]);
    }
    let groups = |s: &Scene| s.lights.iter().map(|g| g.name.clone()).collect::<Vec<_>>();
    assert_eq!(groups(&packed), groups(&plain));
    // gltfpack moves each mesh onto an unnamed child of its named node: the surfaces take
    // the nearest named ancestor's name, as in the plain file.
    let names = |s: &Scene| {
        let mut v: Vec<String> = s.surfaces.iter().map(|x| x.name.clone()).collect();
        v.sort();
        v
    };
    assert_eq!(names(&packed), names(&plain));
    let (lo, hi) = plain.bounds();
    let (plo, phi) = packed.bounds();
    assert!((plo - lo).abs().max_element() < 1e-3 && (phi - hi).abs().max_element() < 1e-3);
}

/// A 4 × 4 lossless WebP of one colour.
fn webp(rgba: [u8; 4]) -> Vec<u8> {
    let mut out = Vec::new();
    let img = image::RgbaImage::from_pixel(4, 4, image::Rgba(rgba));
    image::codecs::webp::WebPEncoder::new_lossless(&mut out)
        .encode(img.as_raw(), 4, 4, image::ExtendedColorType::Rgba8)
        .unwrap();
    out
}

#[test]
fn webp_textures_are_read_and_ktx2_ones_leave_the_factor_with_a_warning() {
    // Three materials over one colour: a PNG texture, the same colour as a WebP texture
    // (EXT_texture_webp, no PNG fallback), and a KTX2 texture (KHR_texture_basisu), which
    // relight does not decode.
    let mut d = Doc::default();
    let colour = [200, 100, 50, 255];
    let (a, b) = (d.view(&png(colour)), d.view(&webp(colour)));
    let c = d.view(b"\xabKTX 20\xbb\r\n\x1a\n not decoded");
    let base = |t: usize| {
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 1, 1, 1],
        "metallicFactor": 0, "baseColorTexture": {"index": t}}})
    };
    let mut mats = vec![base(0), base(1), base(2)];
    for (m, name) in mats.iter_mut().zip(["png", "webp", "ktx2"]) {
        m["name"] = json!(name);
    }
    let used = ["EXT_texture_webp", "KHR_texture_basisu"];
    let glb = material_scene(
        json!(mats),
        &mut d,
        json!({"images": [{"bufferView": a, "mimeType": "image/png"},
                          {"bufferView": b, "mimeType": "image/webp"},
                          {"bufferView": c, "mimeType": "image/ktx2"}],
               "textures": [{"source": 0},
                            {"extensions": {"EXT_texture_webp": {"source": 1}}},
                            {"extensions": {"KHR_texture_basisu": {"source": 2}}}],
               "extensionsUsed": used, "extensionsRequired": used}),
    );
    let dir = folder(&[("m.glb", &glb)]);
    let s = load(dir.path());
    let (png_kd, webp_kd, ktx_kd) = (kd_of(&s, "s0"), kd_of(&s, "s1"), kd_of(&s, "s2"));
    assert_eq!(webp_kd, png_kd);
    assert!(
        (png_kd[0] - 0.5 * super::linear(200)).abs() < 1e-6,
        "{png_kd:?}"
    );
    // The factor alone, its channel of 1 scaled to 0.95 with its colour kept.
    let want = [0.475, 0.95, 0.95];
    assert!(
        (0..3).all(|k| (ktx_kd[k] - want[k]).abs() < 1e-6),
        "{ktx_kd:?}"
    );
    assert!(
        warned(
            &s,
            &["'ktx2'", "KHR_texture_basisu", "factor is used alone"]
        ),
        "{:?}",
        s.warnings
    );
    // strict = true refuses it, naming the texture.
    std::fs::write(dir.path().join("scene.toml"), "strict = true\n").unwrap();
    let e = load_err(dir.path());
    assert!(
        e.contains("textures[2]") && e.contains("KHR_texture_basisu"),
        "{e}"
    );
}
