//! `GET …/export.glb`: the relit scene as glTF binary. Checked against the shading mesh and
//! per-patch radiosity the API serves (so against what a client would draw itself), and
//! imported again as a scene: same geometry.

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use relight::scene::Scene;
use serde_json::Value;

use super::{app, get, ready, send};
use crate::common;

/// A parsed GLB: the JSON document and the binary chunk.
struct Glb {
    doc: Value,
    bin: Vec<u8>,
}

fn parse_glb(b: &[u8]) -> Glb {
    let u = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap()) as usize;
    assert_eq!(&b[..4], b"glTF");
    assert_eq!(u(4), 2);
    assert_eq!(u(8), b.len());
    let jl = u(12);
    assert_eq!(&b[16..20], b"JSON");
    assert_eq!(jl % 4, 0);
    let doc: Value = serde_json::from_slice(&b[20..20 + jl]).unwrap();
    let at = 20 + jl;
    let bl = u(at);
    assert_eq!(&b[at + 4..at + 8], b"BIN\0");
    assert_eq!(at + 8 + bl, b.len());
    // The gltf crate validates the document as well.
    gltf::Gltf::from_slice(b).expect("the gltf crate reads it");
    Glb {
        doc,
        bin: b[at + 8..].to_vec(),
    }
}

impl Glb {
    /// The 4-byte words an accessor reads (tightly packed views).
    fn words(&self, accessor: &Value) -> Vec<u32> {
        let a = &self.doc["accessors"][accessor.as_u64().unwrap() as usize];
        let v = &self.doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let per = match a["type"].as_str().unwrap() {
            "SCALAR" => 1,
            "VEC3" => 3,
            t => panic!("{t}"),
        };
        let n = a["count"].as_u64().unwrap() as usize * per;
        let off = v["byteOffset"].as_u64().unwrap_or(0) as usize
            + a["byteOffset"].as_u64().unwrap_or(0) as usize;
        (0..n)
            .map(|k| u32::from_le_bytes(self.bin[off + 4 * k..off + 4 * k + 4].try_into().unwrap()))
            .collect()
    }

    fn floats(&self, accessor: &Value) -> Vec<f32> {
        self.words(accessor)
            .into_iter()
            .map(f32::from_bits)
            .collect()
    }

    fn primitive(&self) -> &Value {
        &self.doc["meshes"][0]["primitives"][0]
    }
}

async fn export(uri: &str) -> (StatusCode, axum::http::HeaderMap, Vec<u8>) {
    send(app(), Request::get(uri).body(Body::empty()).unwrap()).await
}

#[tokio::test]
async fn exported_glb_matches_the_served_mesh_and_radiosity_and_imports_as_the_same_geometry() {
    let _gate = common::shared();
    let (s, h, b) = export("/api/scenes/desk-room/export.glb?light.lamp=0.4&light.ceiling=1,0.5,0.25&exposure=-6&tonemap=clamp").await;
    assert_eq!(s, StatusCode::OK, "{}", String::from_utf8_lossy(&b));
    assert_eq!(h[header::CONTENT_TYPE], "model/gltf-binary");
    assert_eq!(
        h[header::CONTENT_DISPOSITION],
        "attachment; filename=\"desk-room.glb\""
    );
    assert_eq!(h["x-relight-exposure"], "-6.000");
    let g = parse_glb(&b);
    let extras = &g.doc["asset"]["extras"]["relight"];
    assert_eq!(extras["exposure"], -6.0);
    assert_eq!(extras["tonemap"], "clamp");
    assert_eq!(g.doc["extensionsUsed"][0], "KHR_materials_unlit");

    // The shading mesh as served: positions, triangles, and per-vertex patch weights.
    let (_, _, m) = send(
        app(),
        Request::get("/api/scenes/desk-room/mesh")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    let u = |i: usize| u32::from_le_bytes(m[i..i + 4].try_into().unwrap());
    let f = |i: usize| f32::from_bits(u(i));
    let (nv, nt, nw) = (u(8) as usize, u(12) as usize, u(16) as usize);
    let (pos, tri) = (20, 20 + 12 * nv);
    let start = tri + 16 * nt;
    let (patch, weight) = (start + 4 * (nv + 1), start + 4 * (nv + 1) + 4 * nw);
    let prim = g.primitive();
    let indices = g.words(&prim["indices"]);
    assert_eq!(indices.len(), 3 * nt);
    assert!(
        indices
            .iter()
            .enumerate()
            .all(|(k, &i)| i == u(tri + 4 * k)),
        "same triangles"
    );
    let position = g.floats(&prim["attributes"]["POSITION"]);
    assert_eq!(position.len(), 3 * nv);
    assert!(
        position
            .iter()
            .enumerate()
            .all(|(k, &p)| p == f(pos + 4 * k)),
        "same positions"
    );

    // Colours: clamp(2^ev · Σ weight · B / π) from the binary radiosity of the same state.
    let req = Request::post("/api/scenes/desk-room/radiosity")
        .header(header::CONTENT_TYPE, "application/json")
        .header(header::ACCEPT, "application/octet-stream")
        .body(Body::from(
            r#"{"lights": {"lamp": 0.4, "ceiling": {"intensity": 1, "color": [1, 0.5, 0.25]}}}"#,
        ))
        .unwrap();
    let (_, _, rb) = send(app(), req).await;
    let rad: &[f32] = bytemuck::cast_slice(&rb);
    let mut radiance = vec![[0f64; 3]; nv];
    for (v, l) in radiance.iter_mut().enumerate() {
        for k in u(start + 4 * v)..u(start + 4 * v + 4) {
            let (p, w) = (
                u(patch + 4 * k as usize) as usize,
                f(weight + 4 * k as usize) as f64,
            );
            for c in 0..3 {
                l[c] += w * rad[3 * p + c] as f64 / std::f64::consts::PI;
            }
        }
    }
    let color = g.floats(&prim["attributes"]["COLOR_0"]);
    let k = 2f64.powf(-6.0);
    let mut lit = 0;
    for (v, l) in radiance.iter().enumerate() {
        for c in 0..3 {
            let want = (k * l[c]).min(1.0);
            let got = color[3 * v + c] as f64;
            assert!(
                (got - want).abs() <= 1e-5 + 1e-5 * want,
                "vertex {v}: {got} vs {want}"
            );
            lit += usize::from(want > 0.01 && want < 0.99);
        }
    }
    assert!(
        lit > nv,
        "most vertices are neither black nor clipped ({lit})"
    );

    // Relightable: Σ weight_g · _LIGHT_g is the radiance, for the weights in the extras.
    let groups = extras["groups"].as_array().unwrap();
    assert_eq!(groups.len(), 2);
    let mut sum = vec![[0f64; 3]; nv];
    for gr in groups {
        let w: Vec<f64> = gr["weight"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let want_w = if gr["id"] == "lamp" {
            vec![0.4; 3]
        } else {
            vec![1.0, 0.5, 0.25]
        };
        assert!(
            w.iter().zip(&want_w).all(|(a, b)| (a - b).abs() < 1e-6),
            "{w:?}"
        );
        let name = gr["attribute"].as_str().unwrap();
        assert!(name.starts_with("_LIGHT_"), "{name}");
        let a = g.floats(&prim["attributes"][name]);
        for (v, s) in sum.iter_mut().enumerate() {
            for c in 0..3 {
                s[c] += w[c] * a[3 * v + c] as f64;
            }
        }
    }
    for (v, (s, l)) in sum.iter().zip(&radiance).enumerate() {
        for c in 0..3 {
            assert!(
                (s[c] - l[c]).abs() <= 1e-4 * l[c].max(1e-3),
                "vertex {v}: {} vs {}",
                s[c],
                l[c]
            );
        }
    }
    // Camera presets come along as glTF cameras.
    let r = ready("desk-room");
    assert_eq!(
        g.doc["cameras"].as_array().unwrap().len(),
        r.model.baked.scene.cameras.len()
    );

    // Imported again, the file is the same geometry: the mesh's patches, in order.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("relit.glb"), &b).unwrap();
    let s = Scene::load(dir.path()).unwrap();
    let mesh = &r.model.baked.mesh;
    assert_eq!(s.triangles.len(), mesh.elements.len());
    for (t, p) in s.triangles.iter().zip(&mesh.elements) {
        for k in 0..3 {
            let want = mesh.vertices[p.v[k] as usize];
            assert!((t.p[k] - want).length() < 1e-5, "{} vs {want}", t.p[k]);
        }
    }
}

#[tokio::test]
async fn export_options_and_precise_errors() {
    let _gate = common::shared();
    let (s, _, full) = export("/api/scenes/cornell-box/export.glb").await;
    assert_eq!(s, StatusCode::OK);
    let (s, h, lean) =
        export("/api/scenes/cornell-box/export.glb?relightable=false&tonemap=filmic&exposure=auto")
            .await;
    assert_eq!(s, StatusCode::OK);
    let g = parse_glb(&lean);
    let attrs = g.primitive()["attributes"].as_object().unwrap();
    assert_eq!(attrs.keys().collect::<Vec<_>>(), ["COLOR_0", "POSITION"]);
    assert!(lean.len() < full.len());
    // Auto exposure: a finite number of stops, stated in the file and the header.
    let ev = g.doc["asset"]["extras"]["relight"]["exposure"]
        .as_f64()
        .unwrap();
    assert!(ev.is_finite());
    assert_eq!(
        h["x-relight-exposure"].to_str().unwrap(),
        format!("{ev:.3}")
    );

    for (uri, status, needle) in [
        (
            "/api/scenes/cornell-box/export.glb?light.nope=1",
            422,
            "nope",
        ),
        (
            "/api/scenes/cornell-box/export.glb?light.light=-1",
            422,
            "light",
        ),
        (
            "/api/scenes/cornell-box/export.glb?exposure=abc",
            400,
            "not a number",
        ),
        (
            "/api/scenes/cornell-box/export.glb?exposure=100",
            422,
            "±40",
        ),
        (
            "/api/scenes/cornell-box/export.glb?exposure=1&exposure=2",
            400,
            "twice",
        ),
        (
            "/api/scenes/cornell-box/export.glb?tonemap=sepia",
            422,
            "filmic or clamp",
        ),
        (
            "/api/scenes/cornell-box/export.glb?relightable=yes",
            400,
            "true or false",
        ),
        (
            "/api/scenes/cornell-box/export.glb?camera=front",
            400,
            "unknown query parameter",
        ),
        ("/api/scenes/nowhere/export.glb", 404, "nowhere"),
    ] {
        let (s, v) = get(app(), uri).await;
        assert_eq!(s.as_u16(), status, "{uri}: {v}");
        assert!(
            v["detail"].as_str().unwrap_or("").contains(needle),
            "{uri}: {v}"
        );
    }
}

/// `POST …/export.glb` exports any state: with a luminaire placed per request, the
/// groups' attributes at their weights plus `_LIGHT_REQUEST` give the state's radiance,
/// which `COLOR_0` shows (clamp, fixed exposure), and the request's own light does not
/// depend on the groups' settings.
#[tokio::test]
async fn exported_glb_of_a_placed_luminaire_state_adds_up_to_the_state() {
    let _gate = common::shared();
    let ies = include_str!("../../../scenes/office-floor/downlight.ies");
    let task =
        serde_json::json!({"id": "task", "position": [1.2, 2.6, 2.4], "ies": ies, "lumens": 1200});
    let post = |ceiling: f64| {
        let body = serde_json::json!({"lights": {"ceiling": ceiling, "lamp": 0},
            "luminaires": [task.clone()], "exposure": -6, "tonemap": "clamp"});
        send(
            app(),
            Request::post("/api/scenes/desk-room/export.glb")
                .header(header::CONTENT_TYPE, "application/json")
                .body(Body::from(body.to_string()))
                .unwrap(),
        )
    };
    let (s, h, b) = post(0.5).await;
    assert_eq!(s, StatusCode::OK, "{}", String::from_utf8_lossy(&b));
    assert_eq!(
        h[header::CONTENT_DISPOSITION],
        "attachment; filename=\"desk-room.glb\""
    );
    let g = parse_glb(&b);
    let extras = &g.doc["asset"]["extras"]["relight"];
    assert_eq!(extras["request"]["attribute"], "_LIGHT_REQUEST", "{extras}");
    let attr = |g: &Glb, name: &str| g.floats(&g.primitive()["attributes"][name]);
    let (ceiling, own, color) = (
        attr(&g, "_LIGHT_CEILING"),
        attr(&g, "_LIGHT_REQUEST"),
        attr(&g, "COLOR_0"),
    );
    let peak = own.iter().fold(0f32, |a, &x| a.max(x));
    assert!(peak > 1.0, "the luminaire lights the room: {peak} cd/m²");
    let k = (-6f32).exp2();
    for ((c, o), shown) in ceiling.iter().zip(&own).zip(&color) {
        let want = ((0.5 * c + o) * k).min(1.0);
        assert!(
            (shown - want).abs() < 1e-5 * want.max(1.0),
            "{shown} against {want}"
        );
    }
    // The groups off: the same request light.
    let (_, _, b) = post(0.0).await;
    let alone = attr(&parse_glb(&b), "_LIGHT_REQUEST");
    let worst = own
        .iter()
        .zip(&alone)
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    assert!(worst < 1e-4 * peak, "{worst}");
    // Bad input: the same errors as every lighting state.
    for (body, status) in [
        (
            r#"{"emission": {"0": [1, 1]}}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
        ),
        (r#"{"exposure": 99}"#, StatusCode::UNPROCESSABLE_ENTITY),
        (
            r#"{"luminaires": [{"id": "x", "position": [9, 1, 1], "lumens": 10}]}"#,
            StatusCode::UNPROCESSABLE_ENTITY,
        ),
    ] {
        let (s, _, b) = send(
            app(),
            Request::post("/api/scenes/desk-room/export.glb")
                .header(header::CONTENT_TYPE, "application/json")
                .body(Body::from(body))
                .unwrap(),
        )
        .await;
        assert_eq!(s, status, "{body}: {}", String::from_utf8_lossy(&b));
    }
}
