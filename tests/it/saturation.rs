//! `/healthz` and `/readyz` stay fast while the heavy endpoints are saturated: a real
//! server on a loopback port, clients hammering renders and point gathers beyond the
//! concurrency limit, and a prober on its own thread measuring health latency.
//!
//! The test holds `common::alone()`, so that no other test competes for the cores meanwhile.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use relight::server::{AppState, ServerConfig};
use serde_json::json;

use crate::common;

/// One GET over a fresh connection; the time to the full answer.
fn probe(addr: std::net::SocketAddr, path: &str) -> (Duration, String) {
    let t0 = Instant::now();
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    (t0.elapsed(), out)
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

#[test]
fn health_answers_within_50_ms_p99_while_heavy_endpoints_are_saturated() {
    let _gate = common::alone();
    let cache = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("http-cache");
    let state = AppState::new(ServerConfig {
        scenes: common::scenes_dir(),
        cache,
        ..ServerConfig::default()
    })
    .unwrap();
    common::bake_all(&state);
    assert!(state.slots().iter().all(|s| s.status().0 == "ready"));

    // The server on its own runtime.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.set_nonblocking(true).unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let server = std::thread::spawn(move || {
        let rt = tokio::runtime::Runtime::new().unwrap();
        rt.block_on(async move {
            let listener = tokio::net::TcpListener::from_std(listener).unwrap();
            relight::server::run(listener, state, async {
                let _ = stop_rx.await;
            })
            .await
        })
    });

    // Load: 16 clients (the limit is the core count, with 4 waiting per slot) sending renders from fresh cameras and
    // 300-point gathers, back to back, for 5 seconds.
    let running = Arc::new(AtomicBool::new(true));
    let (done, shed, other) = (
        Arc::new(AtomicUsize::new(0)),
        Arc::new(AtomicUsize::new(0)),
        Arc::new(AtomicUsize::new(0)),
    );
    let load = {
        let (running, done, shed, other) =
            (running.clone(), done.clone(), shed.clone(), other.clone());
        std::thread::spawn(move || {
            let rt = tokio::runtime::Runtime::new().unwrap();
            rt.block_on(async move {
                let client = reqwest::Client::new();
                let base = format!("http://{addr}/api/scenes");
                let tasks: Vec<_> = (0..16)
                    .map(|c| {
                        let (client, base) = (client.clone(), base.clone());
                        let (running, done, shed, other) =
                            (running.clone(), done.clone(), shed.clone(), other.clone());
                        tokio::spawn(async move {
                            let mut k = 0;
                            while running.load(Ordering::Relaxed) {
                                k += 1;
                                let (uri, body) = if c % 2 == 0 {
                                    let x = 0.05 + 0.001 * (k * 8 + c) as f64;
                                    (
                                        format!("{base}/cornell-box/render"),
                                        json!({"width": 640, "height": 480, "format": "jpeg",
                                               "camera": {"position": [x, 0.3, -0.8],
                                                          "target": [0.28, 0.27, 0.28], "fov_deg": 50}}),
                                    )
                                } else {
                                    let pts: Vec<_> = (0..300)
                                        .map(|i| json!({"position": [0.5 + (i % 20) as f64 * 0.25, 0.75,
                                                                     0.5 + (i / 20) as f64 * 0.15],
                                                        "normal": [0, 1, 0]}))
                                        .collect();
                                    (
                                        format!("{base}/office/illuminance"),
                                        json!({"points": pts, "surfaces": []}),
                                    )
                                };
                                let r = client
                                    .post(uri)
                                    .header("content-type", "application/json")
                                    .body(body.to_string())
                                    .send()
                                    .await;
                                match r.map(|r| r.status().as_u16()) {
                                    Ok(200) => done.fetch_add(1, Ordering::Relaxed),
                                    Ok(503) => {
                                        // A polite client backs off a little.
                                        tokio::time::sleep(Duration::from_millis(20)).await;
                                        shed.fetch_add(1, Ordering::Relaxed)
                                    }
                                    _ => other.fetch_add(1, Ordering::Relaxed),
                                };
                            }
                        })
                    })
                    .collect();
                for t in tasks {
                    t.await.unwrap();
                }
            })
        })
    };

    // Probe health every 20 ms once the load is on.
    std::thread::sleep(Duration::from_millis(500));
    let mut lat = vec![];
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(5) {
        let path = if lat.len() % 2 == 0 {
            "/healthz"
        } else {
            "/readyz"
        };
        let (d, resp) = probe(addr, path);
        assert!(resp.starts_with("HTTP/1.1 200"), "{path}: {resp}");
        lat.push(d);
        std::thread::sleep(Duration::from_millis(20));
    }
    running.store(false, Ordering::Relaxed);
    load.join().unwrap();
    let _ = stop_tx.send(());
    server.join().unwrap();

    lat.sort();
    let (p50, p99, max) = (
        percentile(&lat, 0.5),
        percentile(&lat, 0.99),
        lat[lat.len() - 1],
    );
    let (done, shed, other) = (
        done.load(Ordering::Relaxed),
        shed.load(Ordering::Relaxed),
        other.load(Ordering::Relaxed),
    );
    println!(
        "health under saturation: {} probes, p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms; \
         heavy requests: {done} answered, {shed} shed (503), {other} other",
        lat.len(),
        p50.as_secs_f64() * 1e3,
        p99.as_secs_f64() * 1e3,
        max.as_secs_f64() * 1e3,
    );
    assert!(done > 10, "the load did not run: {done} answered");
    assert!(shed > 0, "the load never exceeded the limit");
    assert_eq!(other, 0, "heavy requests got answers other than 200 or 503");
    assert!(p99 < Duration::from_millis(50), "p99 {p99:?}");
}
