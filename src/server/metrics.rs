//! Prometheus metrics in the text exposition format: request counts and latency
//! histograms per route and status, and bake times per scene.

use std::collections::BTreeMap;
use std::sync::Mutex;

/// Upper bounds of the latency buckets, seconds.
const BUCKETS: [f64; 12] = [
    0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.5, 2.5,
];

#[derive(Default)]
struct Histogram {
    counts: [u64; BUCKETS.len()],
    count: u64,
    sum: f64,
}

#[derive(Default)]
pub(crate) struct Metrics {
    /// (method, route) → latency histogram.
    latency: Mutex<BTreeMap<(String, String), Histogram>>,
    /// (method, route, status) → count.
    requests: Mutex<BTreeMap<(String, String, u16), u64>>,
    /// scene → (seconds, from cache).
    bakes: Mutex<BTreeMap<String, (f64, bool)>>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The method as a metrics label: the standard methods by name, anything else as
/// "other", so that no client can create new series at will.
pub(crate) fn method_label(m: &axum::http::Method) -> &'static str {
    use axum::http::Method;
    match *m {
        Method::GET => "GET",
        Method::POST => "POST",
        Method::PUT => "PUT",
        Method::DELETE => "DELETE",
        Method::HEAD => "HEAD",
        Method::OPTIONS => "OPTIONS",
        Method::PATCH => "PATCH",
        _ => "other",
    }
}

impl Metrics {
    pub(crate) fn observe(&self, method: &str, route: &str, status: u16, seconds: f64) {
        {
            let mut l = lock(&self.latency);
            let h = l.entry((method.into(), route.into())).or_default();
            for (k, b) in BUCKETS.iter().enumerate() {
                if seconds <= *b {
                    h.counts[k] += 1;
                }
            }
            h.count += 1;
            h.sum += seconds;
        }
        *lock(&self.requests)
            .entry((method.into(), route.into(), status))
            .or_default() += 1;
    }

    pub(crate) fn bake_done(&self, scene: &str, seconds: f64, from_cache: bool) {
        lock(&self.bakes).insert(scene.into(), (seconds, from_cache));
    }

    pub fn render(&self) -> String {
        let mut out = String::new();
        out += "# HELP relight_http_requests_total HTTP requests by route and status.\n";
        out += "# TYPE relight_http_requests_total counter\n";
        for ((m, r, s), n) in lock(&self.requests).iter() {
            out += &format!(
                "relight_http_requests_total{{method=\"{m}\",route=\"{r}\",status=\"{s}\"}} {n}\n"
            );
        }
        out += "# HELP relight_http_request_duration_seconds Request latency by route.\n";
        out += "# TYPE relight_http_request_duration_seconds histogram\n";
        for ((m, r), h) in lock(&self.latency).iter() {
            let labels = format!("method=\"{m}\",route=\"{r}\"");
            for (k, b) in BUCKETS.iter().enumerate() {
                out += &format!(
                    "relight_http_request_duration_seconds_bucket{{{labels},le=\"{b}\"}} {}\n",
                    h.counts[k]
                );
            }
            out += &format!(
                "relight_http_request_duration_seconds_bucket{{{labels},le=\"+Inf\"}} {}\n",
                h.count
            );
            out += &format!(
                "relight_http_request_duration_seconds_sum{{{labels}}} {}\n",
                h.sum
            );
            out += &format!(
                "relight_http_request_duration_seconds_count{{{labels}}} {}\n",
                h.count
            );
        }
        out += "# HELP relight_bake_seconds Time to bake or load each scene.\n";
        out += "# TYPE relight_bake_seconds gauge\n";
        for (s, (secs, cached)) in lock(&self.bakes).iter() {
            out +=
                &format!("relight_bake_seconds{{scene=\"{s}\",from_cache=\"{cached}\"}} {secs}\n");
        }
        out
    }
}
