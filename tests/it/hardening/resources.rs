//! Exhaustion: memory budget, view cache, concurrency, timeouts, large bodies, slow clients.

use std::time::{Duration, Instant};

use axum::http::{header, StatusCode};
use relight::server::router;
use serde_json::{json, Value};

use super::{post, post_to, problem, state, with};
use crate::common;

#[tokio::test]
async fn render_memory_is_estimated_and_budgeted() {
    let _gate = common::shared();
    // A 256 MB budget: one request may reserve 128 MB, so a 4096² view buffer (up to
    // 2.7 GB) is refused up front with a message naming the limit.
    let small = with(|c| c.memory_budget = 256 << 20);
    let (s, h, v) = post_to(
        router(small.clone()),
        "/api/scenes/cornell-box/render",
        r#"{"width": 4096, "height": 4096}"#,
    )
    .await;
    problem(s, &h, &v, StatusCode::UNPROCESSABLE_ENTITY, "at most");
    assert!(
        v["detail"].as_str().unwrap().contains("memory budget"),
        "{v}"
    );
    // Budget momentarily full: 503 with Retry-After.
    let hold = (
        // 256 MB less 64 MB for the view cache leaves 192 MB; keep 185 MB of it.
        small.budget.reserve(100 << 20, "a test").unwrap(),
        small.budget.reserve(85 << 20, "a test").unwrap(),
    );
    let (s, h, v) = post_to(
        router(small.clone()),
        "/api/scenes/cornell-box/render",
        r#"{"width": 256, "height": 256}"#,
    )
    .await;
    problem(s, &h, &v, StatusCode::SERVICE_UNAVAILABLE, "retry");
    assert!(h.contains_key(header::RETRY_AFTER));
    drop(hold);
    let (s, _, _) = post_to(
        router(small.clone()),
        "/api/scenes/cornell-box/render",
        r#"{"width": 256, "height": 256}"#,
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(small.budget.used(), 0, "reservations are returned");
}

#[tokio::test]
async fn the_same_camera_was_built_twice_at_once() {
    let _gate = common::shared();
    // Four renders of one camera at once: some wait for a render permit. On a loaded CI
    // machine that wait can pass the default 2 s queue limit (a 503, tested elsewhere);
    // this test is about the shared view buffer, so the wait is unbounded here.
    let st = with(|c| c.queue_wait = std::time::Duration::from_secs(120));
    let body = r#"{"width": 300, "height": 200, "camera": {"position": [0.3, 0.3, -0.8], "target": [0.28, 0.27, 0.28], "fov_deg": 50}}"#;
    let tasks: Vec<_> = (0..4)
        .map(|_| {
            let app = router(st.clone());
            tokio::spawn(
                async move { post_to(app, "/api/scenes/cornell-box/render", body).await.0 },
            )
        })
        .collect();
    for t in tasks {
        assert_eq!(t.await.unwrap(), StatusCode::OK);
    }
    let views = st.views.lock().unwrap();
    assert_eq!(views.len(), 1, "one view buffer for one camera");
    // Real bytes: offsets and picking ids (8 per pixel) plus 8 per vertex weight (group
    // images are not made for one group). The estimate assumes at most 8 weights a pixel.
    let px = 300 * 200;
    let weights = (views.bytes() - 8 * px) as f64 / 8.0 / px as f64;
    println!(
        "view buffer: {} bytes, {weights:.2} vertex weights per pixel",
        views.bytes()
    );
    assert!(
        (1.0..=relight::render::EST_WEIGHTS_PER_PIXEL as f64).contains(&weights),
        "{weights}"
    );
}

#[tokio::test]
async fn distinct_cameras_were_free_to_make_and_the_lru_counted_lengths() {
    let _gate = common::shared();
    // A 128 MB budget keeps a 32 MB view cache: many distinct cameras never hold more.
    let st = with(|c| c.memory_budget = 128 << 20);
    let cap = st.budget.view_cache_max() as usize;
    for k in 0..12 {
        let body = json!({"width": 400, "height": 300, "camera": {
            "position": [0.1 + 0.03 * k as f64, 0.3, -0.8], "target": [0.28, 0.27, 0.28], "fov_deg": 50}})
        .to_string();
        let (s, _, v) = post_to(router(st.clone()), "/api/scenes/cornell-box/render", body).await;
        assert_eq!(s, StatusCode::OK, "{v}");
        let bytes = st.views.lock().unwrap().bytes();
        assert!(bytes <= cap, "view cache holds {bytes} bytes, cap {cap}");
    }
}

#[tokio::test]
async fn heavy_requests_beyond_the_concurrency_limit_are_shed_with_503() {
    let _gate = common::shared();
    let st = with(|c| {
        c.max_concurrent = 1;
        c.queue_wait = Duration::from_millis(1);
    });
    // 400 points on the office: tens of milliseconds each.
    let points: Vec<Value> = (0..400)
        .map(|k| json!({"position": [0.5 + (k % 20) as f64 * 0.25, 0.75, 0.5 + (k / 20) as f64 * 0.15], "normal": [0, 1, 0]}))
        .collect();
    let body = json!({"points": points, "surfaces": []}).to_string();
    let tasks: Vec<_> = (0..12)
        .map(|_| {
            let (app, body) = (router(st.clone()), body.clone());
            tokio::spawn(async move { post_to(app, "/api/scenes/office/illuminance", body).await })
        })
        .collect();
    let mut codes = vec![];
    for t in tasks {
        let (s, h, v) = t.await.unwrap();
        if s == StatusCode::SERVICE_UNAVAILABLE {
            assert!(h.contains_key(header::RETRY_AFTER));
            assert!(v["detail"].as_str().unwrap().contains("busy"), "{v}");
        }
        codes.push(s.as_u16());
    }
    assert!(codes.contains(&200) && codes.contains(&503), "{codes:?}");
    assert!(codes.iter().all(|c| *c == 200 || *c == 503), "{codes:?}");
}

#[tokio::test]
async fn spawned_work_kept_running_after_the_client_left() {
    // Alone: the abandoned work runs on rayon's global pool, which every test of this
    // process shares, and a long bake there would hold it past the 5 s allowed below.
    let _gate = common::alone();
    // A 30 ms request timeout on a request that needs seconds: 503 at once, and the
    // abandoned work stops soon after (its memory reservation comes back).
    let st = with(|c| c.request_timeout = Duration::from_millis(30));
    let points: Vec<Value> = (0..10_000)
        .map(|k| json!({"position": [0.5 + (k % 100) as f64 * 0.05, 0.75, 0.5 + (k / 100) as f64 * 0.03], "normal": [0, 1, 0]}))
        .collect();
    let body = json!({"points": points, "surfaces": []}).to_string();
    let t0 = Instant::now();
    let (s, h, v) = post_to(router(st.clone()), "/api/scenes/office/illuminance", body).await;
    problem(
        s,
        &h,
        &v,
        StatusCode::SERVICE_UNAVAILABLE,
        "did not finish within",
    );
    assert!(t0.elapsed() < Duration::from_secs(2), "{:?}", t0.elapsed());
    let t1 = Instant::now();
    while st.budget.used() > 0 {
        assert!(
            t1.elapsed() < Duration::from_secs(5),
            "the abandoned work did not stop"
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

#[tokio::test]
async fn large_bodies_are_parsed_off_the_runtime_within_the_budget() {
    let _gate = common::shared();
    // A 6 MB dense emission for the Cornell box parses (on the blocking pool) and solves.
    let n = state()
        .slot("cornell-box")
        .unwrap()
        .ready()
        .unwrap()
        .model
        .baked
        .transfer
        .n;
    let emission: Vec<[f32; 3]> = (0..n)
        .map(|i| if i == 0 { [1.0; 3] } else { [1.234_567e-9; 3] })
        .collect();
    let body = json!({"emission": emission}).to_string();
    assert!(body.len() > relight::server::parse::INLINE_PARSE_BYTES);
    let (s, _, v) = post("/api/scenes/cornell-box/illuminance", body.clone()).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    // With a tiny budget the same body is refused for its parse, not half-parsed.
    let small = with(|c| c.memory_budget = 64 << 20);
    let big = json!({"emission": vec![[0.0f32; 3]; 400_000]}).to_string();
    let (s, h, v) = post_to(router(small), "/api/scenes/cornell-box/radiosity", big).await;
    assert!(
        s == StatusCode::UNPROCESSABLE_ENTITY || s == StatusCode::PAYLOAD_TOO_LARGE,
        "{s} {v}"
    );
    assert_eq!(h[header::CONTENT_TYPE], "application/problem+json");
}

#[tokio::test]
async fn slow_clients_held_connections_forever() {
    let _gate = common::shared();
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let st = with(|c| c.header_timeout = Duration::from_millis(500));
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(relight::server::run(listener, st, async {
        let _ = stopped.await;
    }));
    // Half a request line, then nothing: the server closes the connection.
    let mut c = tokio::net::TcpStream::connect(addr).await.unwrap();
    c.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
        .await
        .unwrap();
    let t0 = Instant::now();
    let mut buf = vec![0u8; 1024];
    let n = tokio::time::timeout(Duration::from_secs(5), c.read(&mut buf))
        .await
        .expect("the server kept the slow connection open")
        .unwrap_or(0);
    let waited = t0.elapsed();
    // Closed (0 bytes) or answered 408, after about the header timeout.
    let text = String::from_utf8_lossy(&buf[..n]);
    assert!(n == 0 || text.contains("408"), "{text}");
    assert!(
        waited >= Duration::from_millis(400) && waited < Duration::from_secs(3),
        "{waited:?}"
    );
    // A prompt client on the same server is served.
    let mut c = tokio::net::TcpStream::connect(addr).await.unwrap();
    c.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        .await
        .unwrap();
    let mut resp = String::new();
    c.read_to_string(&mut resp).await.unwrap();
    assert!(resp.starts_with("HTTP/1.1 200"), "{resp}");
    let _ = stop.send(());
    server.await.unwrap();
}
