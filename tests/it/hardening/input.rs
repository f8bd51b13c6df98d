//! Hostile request input: huge numbers, repeated ids and keys, odd content types and ids.

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use relight::server::router;
use serde_json::{json, Value};

use super::{post, problem, send, state, with};
use crate::common;

#[tokio::test]
async fn falsecolor_range_up_to_1e39_killed_the_process() {
    let _gate = common::shared();
    let uri = "/api/scenes/cornell-box/render";
    for range in [
        "[1, 1e39]",
        "[1, 1e300]",
        "[0, 10]",
        "[1e-9, 10]",
        "[5, 5]",
        "[1, 1e13]",
    ] {
        let body =
            format!(r#"{{"mode": "falsecolor", "range": {range}, "width": 32, "height": 32}}"#);
        let (s, h, v) = post(uri, body).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{range}: {v}");
        assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
        assert!(v["detail"].as_str().unwrap().contains("range"), "{v}");
    }
    // The widest range allowed still draws.
    let (s, h, _) = post(
        uri,
        r#"{"mode": "falsecolor", "range": [1e-6, 1e12], "width": 64, "height": 64}"#,
    )
    .await;
    assert_eq!(
        (s, &h[header::CONTENT_TYPE]),
        (StatusCode::OK, &"image/png".parse().unwrap())
    );
}

#[tokio::test]
async fn repeated_ids_multiplied_work_and_are_refused() {
    let _gate = common::shared();
    let grids = json!({"grids": vec!["desk"; 200_000], "surfaces": []}).to_string();
    let (s, h, v) = post("/api/scenes/office/illuminance", grids).await;
    problem(
        s,
        &h,
        &v,
        StatusCode::UNPROCESSABLE_ENTITY,
        "grid 'desk' is listed twice",
    );
    let (s, h, v) = post(
        "/api/scenes/office/illuminance",
        r#"{"surfaces": ["floor", "floor"]}"#,
    )
    .await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "listed twice");
    let (s, h, v) = post(
        "/api/scenes/office/batch",
        r#"{"states": [{}], "grids": ["desk", "desk"]}"#,
    )
    .await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "listed twice");
    let (s, h, v) = post(
        "/api/scenes/office/optimize",
        r#"{"targets": [{"grid": "desk", "eavg_min": 300}, {"grid": "desk", "u0_min": 0.5}]}"#,
    )
    .await;
    problem(
        s,
        &h,
        &v,
        StatusCode::UNPROCESSABLE_ENTITY,
        "already has a target",
    );
}

#[tokio::test]
async fn optimize_with_a_group_listed_twice_reported_levels_it_did_not_apply() {
    let _gate = common::shared();
    let (s, h, v) = post(
        "/api/scenes/office/optimize",
        r#"{"targets": [{"grid": "desk", "eavg_min": 500}], "groups": ["window_row", "window_row"]}"#,
    )
    .await;
    problem(
        s,
        &h,
        &v,
        StatusCode::UNPROCESSABLE_ENTITY,
        "'window_row' is listed twice",
    );
    // Listed once, the answer applies the levels it reports.
    let (s, _, v) = post(
        "/api/scenes/office/optimize",
        r#"{"targets": [{"grid": "desk", "eavg_min": 500}], "groups": ["window_row"]}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    assert_eq!(v["targets"][0]["met"], true, "{v}");
    let level = v["lights"]["window_row"]["intensity"].as_f64().unwrap();
    let (_, _, check) = post(
        "/api/scenes/office/illuminance",
        json!({"lights": {"window_row": level}, "grids": ["desk"], "surfaces": []}).to_string(),
    )
    .await;
    let avg = check["grids"]["desk"]["avg"].as_f64().unwrap();
    assert!(
        (avg - 500.0).abs() < 0.5,
        "reported level {level} gives {avg} lx"
    );
}

#[tokio::test]
async fn repeated_json_keys_silently_kept_the_last() {
    let _gate = common::shared();
    for body in [
        r#"{"lights": {"ceiling": 0, "ceiling": 1}}"#,
        r#"{"lights": {}, "lights": {"ceiling": 2}}"#,
    ] {
        let (s, h, v) = post("/api/scenes/cornell-box/radiosity", body).await;
        problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "appears twice");
    }
}

#[tokio::test]
async fn sparse_emission_keys_plus_1_and_1_both_meant_patch_1() {
    let _gate = common::shared();
    let uri = "/api/scenes/cornell-box/radiosity";
    for key in ["+1", "01", " 1", "1.0", "-0", "1e0"] {
        let body = format!(r#"{{"emission": {{"{key}": [1, 1, 1]}}}}"#);
        let (s, h, v) = post(uri, body).await;
        problem(
            s,
            &h,
            &v,
            StatusCode::UNPROCESSABLE_ENTITY,
            "not a patch index",
        );
    }
    let (s, h, v) = post(uri, r#"{"emission": {"1": [1, 1, 1], "1": [2, 2, 2]}}"#).await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "appears twice");
    let (s, _, v) = post(uri, r#"{"emission": {"1": [1, 1, 1], "0": [2, 2, 2]}}"#).await;
    assert_eq!(s, StatusCode::OK, "{v}");
}

#[tokio::test]
async fn a_normal_of_1e300_passed_the_zero_check_and_answered_0_lux() {
    let _gate = common::shared();
    let uri = "/api/scenes/cornell-box/illuminance";
    let at = |n: &str| {
        format!(
            r#"{{"points": [{{"position": [0.28, 0.01, 0.28], "normal": {n}}}], "surfaces": []}}"#
        )
    };
    for n in ["[1e300, 1e300, 0]", "[0, 0, 0]", "[1e39, 0, 0]"] {
        let (s, h, v) = post(uri, at(n)).await;
        assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{n}: {v}");
        assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
    }
    // Tiny and large finite normals are directions like any other.
    let (s1, _, a) = post(uri, at("[0, 1, 0]")).await;
    let (s2, _, b) = post(uri, at("[0, 1e-30, 0]")).await;
    let (s3, _, c) = post(uri, at("[0, 1e30, 0]")).await;
    assert_eq!(
        (s1, s2, s3),
        (StatusCode::OK, StatusCode::OK, StatusCode::OK)
    );
    let lux = |v: &Value| v["points"][0]["lux"].as_f64().unwrap();
    assert!(lux(&a) > 0.0);
    assert_eq!(lux(&a), lux(&b));
    assert_eq!(lux(&a), lux(&c));
    // Positions beyond the documented bound are refused.
    let far = r#"{"points": [{"position": [1e7, 0, 0], "normal": [0, 1, 0]}]}"#;
    let (s, h, v) = post(uri, far).await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "within ±");
}

#[tokio::test]
async fn any_content_type_was_parsed_as_json() {
    let _gate = common::shared();
    for ct in [
        "text/plain",
        "application/x-www-form-urlencoded",
        "multipart/form-data; boundary=x",
    ] {
        let req = Request::post("/api/scenes/cornell-box/radiosity")
            .header(header::CONTENT_TYPE, ct)
            .body(Body::from(r#"{"lights": {}}"#))
            .unwrap();
        let (s, h, b) = send(router(state()), req).await;
        assert_eq!(s, StatusCode::UNSUPPORTED_MEDIA_TYPE, "{ct}");
        assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
        assert!(String::from_utf8_lossy(&b).contains("application/json"));
    }
    // No content type with a body: 415 too; an empty body means the defaults.
    let req = Request::post("/api/scenes/cornell-box/radiosity")
        .body(Body::from("{}"))
        .unwrap();
    assert_eq!(
        send(router(state()), req).await.0,
        StatusCode::UNSUPPORTED_MEDIA_TYPE
    );
    let req = Request::post("/api/scenes/cornell-box/radiosity")
        .body(Body::empty())
        .unwrap();
    assert_eq!(send(router(state()), req).await.0, StatusCode::OK);
}

#[tokio::test]
async fn unknown_http_methods_became_new_metrics_series() {
    let _gate = common::shared();
    let app = router(with(|_| {}));
    for m in ["FOO", "BAR", "X-ATTACK"] {
        let req = Request::builder()
            .method(m)
            .uri("/healthz")
            .body(Body::empty())
            .unwrap();
        let _ = send(app.clone(), req).await;
    }
    let (_, _, b) = send(app, Request::get("/metrics").body(Body::empty()).unwrap()).await;
    let text = String::from_utf8(b).unwrap();
    assert!(
        !text.contains("FOO") && !text.contains("X-ATTACK"),
        "{text}"
    );
    assert!(text.contains("method=\"other\""), "{text}");
}

#[tokio::test]
async fn repeated_query_parameters_on_render_png_are_refused() {
    let _gate = common::shared();
    let req = Request::get(
        "/api/scenes/cornell-box/render.png?w=32&h=32&light.ceiling=1&light.ceiling=0",
    )
    .body(Body::empty())
    .unwrap();
    let (s, _, b) = send(router(state()), req).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(String::from_utf8_lossy(&b).contains("twice"));
}

#[tokio::test]
async fn a_scene_id_that_is_not_utf8_got_a_plain_text_400() {
    let _gate = common::shared();
    for uri in [
        "/api/scenes/%FF/patches",
        "/api/scenes/%FF",
        "/api/scenes/%C3%28/render.png",
    ] {
        let req = Request::get(uri).body(Body::empty()).unwrap();
        let (s, h, b) = send(router(state()), req).await;
        assert_eq!(s, StatusCode::NOT_FOUND, "{uri}");
        assert_eq!(h[header::CONTENT_TYPE], "application/problem+json", "{uri}");
        assert!(
            String::from_utf8_lossy(&b).contains("no such scene"),
            "{uri}"
        );
    }
}
