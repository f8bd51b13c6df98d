//! `GET …/report`: the printable design report of the bundled office, checked against the
//! `illuminance` answer of the same lighting state (schedule, Ēm, pass or fail), for
//! self-containment (nothing from the internet) and for escaping.

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use base64::Engine as _;
use serde_json::{json, Value};

use super::{app, post, send};
use crate::common;

/// The report's status, content type and text.
async fn report(query: &str) -> (StatusCode, String, String) {
    let uri = format!("/api/scenes/office/report{query}");
    let (s, h, b) = send(app(), Request::get(uri).body(Body::empty()).unwrap()).await;
    let ct = h
        .get(header::CONTENT_TYPE)
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    (s, ct, String::from_utf8(b).unwrap())
}

/// The office's illuminance answer on every grid for `lights`.
async fn illuminance(lights: Value) -> Value {
    let body = json!({"lights": lights, "grids": ["desk", "workplane"]});
    let (s, _, v) = post(app(), "/api/scenes/office/illuminance", body.to_string()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    v
}

/// The text of the element with `id` (up to its first tag).
fn text_of<'a>(html: &'a str, id: &str) -> &'a str {
    let at = html
        .find(&format!("id=\"{id}\">"))
        .unwrap_or_else(|| panic!("no element #{id}"));
    let rest = &html[at + id.len() + 6..];
    rest[..rest.find('<').unwrap()].trim()
}

/// The table row holding the element with `id`.
fn row_of<'a>(html: &'a str, id: &str) -> &'a str {
    let at = html.find(&format!("id=\"{id}\"")).unwrap();
    let start = html[..at].rfind("<tr>").unwrap();
    let end = at + html[at..].find("</tr>").unwrap();
    &html[start..end]
}

/// The section of grid `id`, and its index in the report.
fn grid_section<'a>(html: &'a str, id: &str) -> (&'a str, String) {
    let at = html.find(&format!("data-grid=\"{id}\"")).unwrap();
    let start = html[..at].rfind("<section").unwrap();
    let end = at + html[at..].find("</section>").unwrap();
    let s = &html[start..end];
    let i = s["<section class=\"page grid\" id=\"grid-".len()..]
        .split('"')
        .next()
        .unwrap();
    (s, i.to_string())
}

/// As the report prints lux.
fn lux(v: f64) -> String {
    if v.abs() >= 10.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

/// Pass marks of a requirement's row agree with the illuminance answer's check.
fn assert_mark(section: &str, row_id: &str, checks: &Value, requirement: &str) {
    let check = checks
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["requirement"] == requirement)
        .unwrap();
    let row = row_of(section, row_id);
    let (pass, fail) = (row.contains('✓'), row.contains('✗'));
    assert!(pass != fail, "{row}");
    assert_eq!(
        pass,
        check["pass"].as_bool().unwrap(),
        "{requirement}: {row}"
    );
}

#[tokio::test]
async fn the_office_report_matches_the_illuminance_answer() {
    let _gate = common::shared();
    for (query, lights) in [
        ("", json!({})),
        (
            "?light.window_row=0.5&light.corridor_row=0.8",
            json!({"window_row": 0.5, "corridor_row": 0.8}),
        ),
    ] {
        let (s, ct, html) = report(query).await;
        assert_eq!(s, StatusCode::OK, "{html}");
        assert_eq!(ct, "text/html; charset=utf-8");
        assert!(html.starts_with("<!DOCTYPE html>"));
        let answer = illuminance(lights).await;
        // The schedule: six downlights of one type; rated lumens.
        assert_eq!(text_of(&html, "luminaire-count"), "6");
        assert!(
            html.contains("downlight.ies"),
            "the photometric file is named"
        );
        let rated = illuminance(json!({})).await["power"]["luminaire_lumens"]
            .as_f64()
            .unwrap();
        assert_eq!(text_of(&html, "total-lumens"), lux(rated));
        // The desk: Ēm as the maintained average, pass marks as the compliance answer.
        let (desk, i) = grid_section(&html, "desk");
        let em = answer["maintained"]["grids"]["desk"]["avg"]
            .as_f64()
            .unwrap();
        assert_eq!(text_of(desk, &format!("em-{i}")), format!("{} lx", lux(em)));
        let initial = answer["grids"]["desk"]["avg"].as_f64().unwrap();
        assert_eq!(
            text_of(desk, &format!("eavg-{i}")),
            format!("{} lx", lux(initial))
        );
        let checks = &answer["compliance"]["desk"]["checks"];
        for (row, requirement) in [("em", "em"), ("u0", "u0"), ("ugr", "ugr_l"), ("ra", "ra")] {
            assert_mark(desk, &format!("{row}-{i}"), checks, requirement);
        }
        let pass = answer["compliance"]["desk"]["pass"].as_bool().unwrap();
        let verdict = text_of(desk, &format!("verdict-{i}"));
        assert_eq!(verdict, if pass { "all met" } else { "not all met" });
        // Both grids have a plan.
        assert_eq!(html.matches("<svg class=\"plan\"").count(), 2);
    }
}

#[tokio::test]
async fn the_report_is_self_contained_with_an_image_per_camera() {
    let _gate = common::shared();
    let (s, _, html) = report("?title=Office%20A&project=P-17&author=Ann").await;
    assert_eq!(s, StatusCode::OK);
    assert!(!html.contains("http://") && !html.contains("https://"));
    for attr in ["src=\"", "href=\""] {
        for (at, _) in html.match_indices(attr) {
            let value = &html[at + attr.len()..];
            assert!(
                value.starts_with("data:"),
                "{}",
                &value[..40.min(value.len())]
            );
        }
    }
    assert!(!html.contains("<link") && !html.contains("@import") && !html.contains("url("));
    // One PNG per camera preset (the office has two), decodable.
    let prefix = "src=\"data:image/png;base64,";
    let images: Vec<&str> = html
        .match_indices(prefix)
        .map(|(at, _)| {
            let b = &html[at + prefix.len()..];
            &b[..b.find('"').unwrap()]
        })
        .collect();
    assert_eq!(images.len(), 2);
    for b in images {
        let png = base64::engine::general_purpose::STANDARD.decode(b).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    }
    for text in [
        "Office A",
        "P-17",
        "Ann",
        "Luminaire schedule",
        "W/m²",
        "Reflectance",
    ] {
        assert!(html.contains(text), "{text}");
    }
    assert!(html.contains("@page") && html.contains("break-before: page"));
}

#[tokio::test]
async fn query_text_is_escaped() {
    let _gate = common::shared();
    let evil = "%3Cscript%3Ealert(1)%3C%2Fscript%3E%22%27%26";
    let q = format!("?title={evil}&project={evil}&author={evil}&camera=desk");
    let (s, _, html) = report(&q).await;
    assert_eq!(s, StatusCode::OK);
    assert!(!html.contains("<script"), "raw markup from the query");
    assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt;&quot;&#39;&amp;"));
    // `camera` limits the images to that preset.
    assert_eq!(html.matches("data:image/png;base64,").count(), 1);
}

#[tokio::test]
async fn bad_queries_are_refused() {
    let _gate = common::shared();
    let long = "x".repeat(201);
    for (q, status) in [
        (
            "?light.nope=1".to_string(),
            StatusCode::UNPROCESSABLE_ENTITY,
        ),
        (
            "?light.window_row=-1".into(),
            StatusCode::UNPROCESSABLE_ENTITY,
        ),
        ("?camera=nope".into(), StatusCode::UNPROCESSABLE_ENTITY),
        (format!("?title={long}"), StatusCode::UNPROCESSABLE_ENTITY),
        ("?w=0".into(), StatusCode::UNPROCESSABLE_ENTITY),
        ("?title=a&title=b".into(), StatusCode::BAD_REQUEST),
        ("?colour=red".into(), StatusCode::BAD_REQUEST),
    ] {
        let (s, ct, body) = report(&q).await;
        assert_eq!(s, status, "{q}: {body}");
        assert_eq!(ct, "application/problem+json", "{q}");
    }
    let req = Request::get("/api/scenes/nope/report").body(Body::empty());
    let (s, _, _) = send(app(), req.unwrap()).await;
    assert_eq!(s, StatusCode::NOT_FOUND);
}

#[tokio::test]
async fn the_office_report_time_is_reported() {
    let _gate = common::shared();
    // Reported, not asserted (the target is 3 s in a release build): the first request may
    // build the views; the second finds them.
    for what in ["first", "second"] {
        let t = std::time::Instant::now();
        let (s, _, html) = report("?light.window_row=0.7").await;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!(s, StatusCode::OK);
        eprintln!("office report ({what}): {ms:.0} ms, {} bytes", html.len());
        let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("office-report.html");
        std::fs::write(out, &html).unwrap();
    }
}

/// `POST …/report` takes any state as JSON: the same report as the query for a group
/// state, and with a luminaire placed per request its schedule lists it (inline IES, no
/// group) and its flux and power count.
#[tokio::test]
async fn a_posted_report_lists_the_luminaires_placed_for_it() {
    let _gate = common::shared();
    let post_report = |scene: &str, body: Value| {
        let r = Request::post(format!("/api/scenes/{scene}/report"))
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body.to_string()))
            .unwrap();
        send(app(), r)
    };
    let (s, _, b) = post_report(
        "office",
        json!({"lights": {"window_row": 0.5}, "title": "Option B", "width": 64, "height": 40}),
    )
    .await;
    let html = String::from_utf8(b).unwrap();
    assert_eq!(s, StatusCode::OK, "{html}");
    assert!(html.contains("Option B"));
    assert_eq!(text_of(&html, "luminaire-count"), "6");
    let (_, _, got) = report("?light.window_row=0.5&title=Option%20B&w=64&h=40").await;
    assert_eq!(
        text_of(&got, "luminaire-count"),
        text_of(&html, "luminaire-count")
    );
    let ies = include_str!("../../../scenes/office-floor/downlight.ies");
    let task = json!({"id": "task", "position": [1.2, 2.6, 2.4], "ies": ies, "lumens": 1200,
        "watts": 12});
    let (s, _, b) = post_report(
        "desk-room",
        json!({"lights": {"ceiling": 0, "lamp": 0}, "luminaires": [task], "width": 32, "height": 24}),
    )
    .await;
    let html = String::from_utf8(b).unwrap();
    assert_eq!(s, StatusCode::OK, "{html}");
    assert_eq!(text_of(&html, "luminaire-count"), "1");
    assert_eq!(text_of(&html, "total-lumens"), "1200");
    let row = row_of(&html, "luminaire-count");
    assert!(row.contains("12.0"), "installed watts: {row}");
    assert!(
        html.contains("inline IES") && html.contains("(no group)"),
        "schedule"
    );
    // Bad input as every request: an unknown field, a title too long.
    for body in [json!({"titel": "x"}), json!({"title": "x".repeat(201)})] {
        let (s, _, b) = post_report("office", body).await;
        assert!(s.is_client_error(), "{}", String::from_utf8_lossy(&b));
    }
}
