//! `Scene::load` on glTF files: a `.gltf` with materials, a texture, lights, a node tree
//! and an embedded buffer, its JSON mutated (bytes, lines, numbers), and a `.glb` with
//! random bytes flipped in its binary chunk; and generated node trees with a child repeated,
//! shared by two parents, listed as a root or hung below itself, always refused.

use proptest::prelude::*;
use relight::scene::Scene;
use serde_json::json;

use super::mutate::{apply, op};
use super::run;
use crate::common;
use crate::gltf_import::{forest, glb, Doc};

/// A small lit room as a glTF document and its binary buffer.
fn seed() -> (serde_json::Value, Vec<u8>) {
    let mut d = Doc::default();
    let p = d.positions(&[[0., 0., 0.], [0., 0., 1.], [1., 0., 1.], [1., 0., 0.]]);
    let i = d.indices(&[0, 1, 2, 0, 2, 3]);
    let doc = d.json(
        json!({
            "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
            "extensions": {"KHR_lights_punctual": {"lights": [
                {"name": "lamp", "type": "point", "intensity": 100, "color": [1, 0.9, 0.8]},
                {"name": "spot", "type": "spot", "intensity": 50,
                 "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}}
            ]}},
            "materials": [
                {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.5, 0.4, 1], "metallicFactor": 0}},
                {"name": "panel", "emissiveFactor": [1, 1, 1],
                 "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10}}}
            ],
            "meshes": [
                {"name": "square", "primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 0}]},
                {"primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 1, "mode": 4}]}
            ],
            "nodes": [
                {"name": "room", "children": [1, 2, 3, 4], "scale": [3, 1, 3]},
                {"name": "floor", "mesh": 0},
                {"name": "ceiling", "mesh": 1, "translation": [0, 2.5, 1], "rotation": [1, 0, 0, 0]},
                {"name": "a", "translation": [0.5, 2, 0.5], "extensions": {"KHR_lights_punctual": {"light": 0}}},
                {"name": "b", "translation": [0.2, 2, 0.2], "extensions": {"KHR_lights_punctual": {"light": 1}}}
            ],
            "scenes": [{"nodes": [0]}],
            "scene": 0
        }),
        None,
    );
    (doc, d.bin)
}

/// Loads `name` with `bytes` in a fresh folder: Ok(accepted) or a failed property.
fn check(name: &str, bytes: &[u8]) -> Result<bool, TestCaseError> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(name), bytes).unwrap();
    let id = dir
        .path()
        .file_name()
        .unwrap()
        .to_string_lossy()
        .into_owned();
    match Scene::load(dir.path()) {
        Ok(_) => Ok(true),
        Err(e) => {
            let m = e.to_string();
            prop_assert!(
                m.starts_with(&format!("{id}/{name}")) || m.starts_with(&format!("{id}:")),
                "{m}"
            );
            prop_assert!(!m.contains("/tmp"), "absolute path: {m}");
            Ok(false)
        }
    }
}

#[test]
fn gltf_json_mutations_never_panic_and_name_the_file() {
    let _gate = common::shared();
    let (mut doc, bin) = seed();
    use base64::Engine as _;
    doc["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    ));
    let text = serde_json::to_string_pretty(&doc).unwrap();
    assert!(
        check("scene.gltf", text.as_bytes()).unwrap(),
        "the seed loads"
    );
    let lines: Vec<&'static str> = text
        .lines()
        .map(|l| &*Box::leak(l.to_string().into_boxed_str()))
        .collect();
    run(
        "Scene::load (.gltf JSON mutated)",
        1500,
        proptest::collection::vec(op(), 1..5),
        |ops| {
            check(
                "scene.gltf",
                &apply(text.clone().into_bytes(), &ops, &lines),
            )
        },
    );
}

#[test]
fn glb_binary_mutations_never_panic_and_name_the_file() {
    let _gate = common::shared();
    let (doc, bin) = seed();
    let seed = glb(&doc, &bin);
    assert!(check("m.glb", &seed).unwrap(), "the seed loads");
    run(
        "Scene::load (.glb bytes flipped)",
        1500,
        proptest::collection::vec((0..seed.len(), any::<u8>()), 1..8),
        |flips| {
            let mut b = seed.clone();
            for (at, v) in flips {
                b[at] = v;
            }
            check("m.glb", &b)
        },
    );
}

#[test]
fn generated_node_trees_with_repeated_or_shared_children_are_refused_naming_the_node() {
    let _gate = common::shared();
    run(
        "Scene::load (.glb node trees, one fault or none)",
        400,
        forest(),
        |f| {
            let dir = tempfile::tempdir().unwrap();
            std::fs::write(dir.path().join("t.glb"), f.glb()).unwrap();
            match (Scene::load(dir.path()), f.fault) {
                (Ok(_), None) => Ok(true),
                (Ok(_), Some(phrase)) => Err(TestCaseError::fail(format!(
                    "accepted, wanted '{phrase}': {f:?}"
                ))),
                (Err(e), fault) => {
                    let m = e.to_string();
                    prop_assert!(fault.is_some(), "a strict forest is refused: {m} ({f:?})");
                    let phrase = fault.unwrap_or_default();
                    prop_assert!(
                        m.contains("/t.glb: nodes[") || m.contains("/t.glb: scenes[0]"),
                        "{m}"
                    );
                    prop_assert!(m.contains(phrase), "wanted '{phrase}': {m} ({f:?})");
                    Ok(false)
                }
            }
        },
    );
}
