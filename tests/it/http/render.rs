//! Server-rendered images (`render`, `render.png`) and the `mesh` a client shades itself.

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use serde_json::json;

use super::{app, floats, post, ready, send};
use crate::common;

#[tokio::test]
async fn render_endpoints_return_images_and_precise_errors() {
    let _gate = common::shared();
    let req = |uri: &str| Request::get(uri).body(Body::empty()).unwrap();
    // Quick GET: PNG; a brighter light gives a brighter image (fixed exposure).
    let (s, h, dim) = send(app(), req("/api/scenes/cornell-box/render.png?camera=front&w=64&h=64&exposure=0&light.ceiling=0.5")).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h[header::CONTENT_TYPE], "image/png");
    assert_eq!(&dim[1..4], b"PNG");
    let (_, _, bright) = send(app(), req("/api/scenes/cornell-box/render.png?camera=front&w=64&h=64&exposure=0&light.ceiling=1.5")).await;
    let mean = |png: &[u8]| {
        let img = image::load_from_memory(png).unwrap().to_rgb8();
        img.pixels()
            .map(|p| p.0.iter().map(|&v| v as f64).sum::<f64>())
            .sum::<f64>()
    };
    assert!(mean(&bright) > mean(&dim) * 1.2);
    // POST: JPEG, EXR, false colour with its range header.
    for (fmt, ct) in [("jpeg", "image/jpeg"), ("exr", "image/x-exr")] {
        let body = json!({"camera": "front", "width": 32, "height": 32, "format": fmt}).to_string();
        let r = Request::post("/api/scenes/cornell-box/render")
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body))
            .unwrap();
        let (s, h, b) = send(app(), r).await;
        assert_eq!(
            (s, h[header::CONTENT_TYPE].to_str().unwrap()),
            (StatusCode::OK, ct)
        );
        assert!(b.len() > 100);
    }
    let body = json!({"camera": {"position": [0.278, 0.273, -0.8], "target": [0.278, 0.273, 0], "fov_deg": 39.3},
                      "width": 48, "height": 32, "mode": "falsecolor"});
    let (s, h, _) = send(
        app(),
        Request::post("/api/scenes/cornell-box/render")
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body.to_string()))
            .unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert!(h.contains_key("x-relight-falsecolor-lux"));
    // Errors.
    for (body, needle) in [
        (json!({"width": 5000}), "4096"),
        (json!({"camera": "top"}), "unknown camera 'top'"),
        (json!({"format": "gif"}), "format 'gif'"),
        (
            json!({"camera": {"position": [0, 0, 0], "target": [0, 0, 0], "fov_deg": 40}}),
            "target must differ",
        ),
        (json!({"mode": "falsecolor", "format": "exr"}), "8-bit"),
    ] {
        let (s, _, v) = post(app(), "/api/scenes/cornell-box/render", body.to_string()).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{body}");
        assert!(
            v["detail"].as_str().unwrap().contains(needle),
            "{body}: {v}"
        );
    }
    let (s, _, _) = send(app(), req("/api/scenes/cornell-box/render.png?w=big")).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
}

/// `quality=final` on both routes: an image from the traced view, relit by light-group
/// settings without a new build; a per-patch emission traced for its state; a bad name or
/// too many pixels refused.
#[tokio::test]
async fn final_quality_renders_light_groups_and_emission_states() {
    let _gate = common::shared();
    let req = |uri: &str| Request::get(uri).body(Body::empty()).unwrap();
    let uri = "/api/scenes/cornell-box/render.png?w=40&h=30&exposure=0&quality=final";
    let (s, h, dim) = send(app(), req(&format!("{uri}&light.ceiling=0.5"))).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h[header::CONTENT_TYPE], "image/png");
    let (_, _, bright) = send(app(), req(&format!("{uri}&light.ceiling=2"))).await;
    let mean = |png: &[u8]| {
        let img = image::load_from_memory(png).unwrap().to_rgb8();
        img.pixels()
            .map(|p| p.0.iter().map(|&v| v as f64).sum::<f64>())
            .sum::<f64>()
    };
    assert!(mean(&bright) > mean(&dim) * 1.2);
    let body = json!({"width": 32, "height": 24, "quality": "final", "format": "exr"});
    let (s, h, _) = send(
        app(),
        Request::post("/api/scenes/cornell-box/render")
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body.to_string()))
            .unwrap(),
    )
    .await;
    assert_eq!(
        (s, h[header::CONTENT_TYPE].to_str().unwrap()),
        (StatusCode::OK, "image/x-exr")
    );
    for (body, needle) in [
        (json!({"quality": "best"}), "quality 'best'"),
        (
            json!({"quality": "final", "width": 2048, "height": 1024}),
            "at most 1048576 pixels",
        ),
    ] {
        let (s, _, v) = post(app(), "/api/scenes/cornell-box/render", body.to_string()).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{v}");
        assert!(v["detail"].as_str().unwrap().contains(needle), "{v}");
    }
    // An emission state: the patches given emission show lit, the rest dark but for
    // their light; twice the emission is twice the image (a fixed exposure, EXR).
    let emit = |e: f64| {
        let body = json!({"width": 32, "height": 24, "quality": "final", "format": "exr",
            "emission": {"17": [e, e, e], "300": [e, e, e]}});
        let r = Request::post("/api/scenes/cornell-box/render")
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body.to_string()))
            .unwrap();
        send(app(), r)
    };
    let sum = |exr: &[u8]| {
        let img = image::load_from_memory(exr).unwrap().to_rgb32f();
        img.pixels().map(|p| p.0[1] as f64).sum::<f64>()
    };
    let ((s1, _, one), (s2, _, two)) = (emit(1000.0).await, emit(2000.0).await);
    assert_eq!((s1, s2), (StatusCode::OK, StatusCode::OK));
    let (a, b) = (sum(&one), sum(&two));
    assert!(a > 0.0 && (b / a - 2.0).abs() < 1e-3, "{a} then {b}");
}

#[tokio::test]
async fn mesh_and_per_patch_illuminance_let_a_client_shade_like_the_server() {
    let _gate = common::shared();
    let (s, h, b) = send(
        app(),
        Request::get("/api/scenes/desk-room/mesh")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(h[header::CONTENT_TYPE], "application/octet-stream");
    assert_eq!(&b[..8], b"RLMESH01");
    let u = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap());
    let (nv, nt, nw) = (u(8) as usize, u(12) as usize, u(16) as usize);
    let r = ready("desk-room");
    let mesh = &r.model.baked.mesh;
    assert_eq!(nt, mesh.len());
    assert_eq!(b.len(), 20 + 4 * (3 * nv + 3 * nt + nt + nv + 1 + 2 * nw));
    let f = |i: usize| f32::from_bits(u(i));
    let (pos, tri) = (20, 20 + 12 * nv);
    let (surf, start) = (tri + 12 * nt, tri + 16 * nt);
    let (patch, weight) = (start + 4 * (nv + 1), start + 4 * (nv + 1) + 4 * nw);
    for (t, p) in mesh.elements.iter().enumerate() {
        assert_eq!(u(surf + 4 * t), mesh.patches[p.patch as usize].surface);
        // Each triangle corner sits on the patch's mesh vertex, counter-clockwise.
        for k in 0..3 {
            let v = u(tri + 12 * t + 4 * k) as usize;
            let want = mesh.vertices[p.v[k] as usize].as_vec3();
            let got = glam::Vec3::new(f(pos + 12 * v), f(pos + 12 * v + 4), f(pos + 12 * v + 8));
            assert!((got - want).length() < 1e-6);
        }
    }
    // Vertex colours from the CSR weights and the binary radiosity match the renderer's.
    let req = Request::post("/api/scenes/desk-room/radiosity")
        .header(header::CONTENT_TYPE, "application/json")
        .header(header::ACCEPT, "application/octet-stream")
        .body(Body::from(r#"{"lights": {"lamp": 0.4}}"#))
        .unwrap();
    let (_, _, rb) = send(app(), req).await;
    let rad: &[f32] = bytemuck::cast_slice(&rb);
    let want = r.shading().vertex_values(rad);
    for (v, w) in want.iter().enumerate() {
        let mut acc = [0f32; 3];
        let mut wsum = 0.0;
        for k in u(start + 4 * v)..u(start + 4 * v + 4) {
            let (p, wt) = (
                u(patch + 4 * k as usize) as usize,
                f(weight + 4 * k as usize),
            );
            wsum += wt;
            for c in 0..3 {
                acc[c] += wt * rad[3 * p + c];
            }
        }
        assert!((wsum - 1.0).abs() < 1e-5);
        for c in 0..3 {
            assert!((acc[c] - w[c]).abs() <= 1e-4 * w[c].max(1.0));
        }
    }
    // quantity = illuminance gives H (lux), binary and JSON alike.
    let weights: Vec<relight::color::Rgb> = r
        .model
        .groups
        .iter()
        .map(|g| {
            let k = if g.id == "lamp" { 0.4 } else { g.intensity };
            g.color * k
        })
        .collect();
    let h_want = r.model.baked.transfer.relight(&weights).h;
    let req = Request::post("/api/scenes/desk-room/radiosity")
        .header(header::CONTENT_TYPE, "application/json")
        .header(header::ACCEPT, "application/octet-stream")
        .body(Body::from(
            r#"{"lights": {"lamp": 0.4}, "quantity": "illuminance"}"#,
        ))
        .unwrap();
    let (s, h, hb) = send(app(), req).await;
    assert_eq!(s, StatusCode::OK);
    assert!(h["x-relight-layout"].to_str().unwrap().contains("lx"));
    assert_eq!(bytemuck::cast_slice::<u8, f32>(&hb), h_want.as_slice());
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/radiosity",
        r#"{"lights": {"lamp": 0.4}, "quantity": "illuminance"}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v["unit"], "lx");
    assert_eq!(floats(&v["illuminance"]).len(), 3 * mesh.len());
    let (s, _, v) = post(
        app(),
        "/api/scenes/desk-room/radiosity",
        r#"{"quantity": "luminance"}"#,
    )
    .await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(v["detail"].as_str().unwrap().contains("'quantity'"), "{v}");
}
