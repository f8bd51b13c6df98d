//! `relight serve` (the HTTP server and the web page) and `relight health` (a container
//! health check that needs no curl).

use std::path::PathBuf;

use anyhow::{Context, Result};

use super::outln;
use relight::bake;

#[derive(clap::Parser)]
#[command(
    after_help = "Every option also reads the environment variable shown in brackets \
(flags win). RELIGHT_LOG sets the log filter: error, warn, info (default), debug, or \
per module, e.g. relight=debug,tower_http=info."
)]
pub struct ServeArgs {
    /// Address to listen on.
    #[arg(long, env = "RELIGHT_ADDR", default_value = "127.0.0.1:8080")]
    addr: std::net::SocketAddr,
    /// Folder of scene folders.
    #[arg(long, env = "RELIGHT_SCENES", default_value = "scenes")]
    scenes: PathBuf,
    /// Cache folder for baked transfers [default: $XDG_CACHE_HOME/relight or ~/.cache/relight].
    #[arg(long, env = "RELIGHT_CACHE")]
    cache: Option<PathBuf>,
    /// Serve only what the cache holds: never bake, never write.
    #[arg(long, env = "RELIGHT_READ_ONLY")]
    read_only: bool,
    /// Folder with the web page, served at /.
    #[arg(long, env = "RELIGHT_STATIC", default_value = "static")]
    static_dir: PathBuf,
    /// Origins allowed by CORS (repeat or comma-separate; `*` for any). Default: same origin only.
    #[arg(
        long = "cors-origin",
        env = "RELIGHT_CORS_ORIGINS",
        value_delimiter = ','
    )]
    cors_origins: Vec<String>,
    /// Largest request body in bytes.
    #[arg(long, env = "RELIGHT_BODY_LIMIT", default_value_t = relight::server::DEFAULT_BODY_LIMIT)]
    body_limit: usize,
    /// Memory budget for requests and bakes: bytes with an optional unit (4G, 512M) or a
    /// percentage of the machine's or the container's memory (50%) [default: 50%].
    #[arg(long, env = "RELIGHT_MEMORY_BUDGET", value_parser = relight::budget::parse_budget)]
    memory_budget: Option<u64>,
    /// Heavy requests (renders, batches, point gathers, solves) running at once; more
    /// wait briefly, then get 503 [default: the number of cores].
    #[arg(long, env = "RELIGHT_MAX_CONCURRENT")]
    max_concurrent: Option<usize>,
    /// Longest time for one request, seconds (503 after that).
    #[arg(long, env = "RELIGHT_REQUEST_TIMEOUT", default_value_t = 60.0)]
    request_timeout: f64,
    /// Longest time a client may take to send its request headers, seconds.
    #[arg(long, env = "RELIGHT_HEADER_TIMEOUT", default_value_t = 10.0)]
    header_timeout: f64,
    /// Most open connections.
    #[arg(long, env = "RELIGHT_MAX_CONNECTIONS", default_value_t = relight::server::DEFAULT_MAX_CONNECTIONS)]
    max_connections: usize,
    /// Bake in this process instead of a child `relight bake` process.
    #[arg(long, env = "RELIGHT_BAKE_IN_PROCESS")]
    bake_in_process: bool,
    /// Bearer token that allows uploading and deleting scenes (PUT/DELETE
    /// /api/scenes/{id}); without one those answer 403. Prefer the environment variable
    /// (a flag shows in the process list).
    #[arg(long, env = "RELIGHT_ADMIN_TOKEN", hide_env_values = true)]
    admin_token: Option<String>,
    /// Largest uploaded scene (.glb or .zip), bytes with an optional unit (256M, 1G).
    #[arg(long, env = "RELIGHT_UPLOAD_LIMIT", value_parser = parse_upload_limit)]
    upload_limit: Option<u64>,
}

/// Runs the server until SIGINT/SIGTERM.
pub fn run(a: ServeArgs) -> Result<()> {
    let defaults = relight::server::ServerConfig::default();
    let bake_command = if a.bake_in_process {
        None
    } else {
        std::env::current_exe().ok()
    };
    let config = relight::server::ServerConfig {
        addr: a.addr,
        scenes: a.scenes,
        cache: a.cache.unwrap_or_else(bake::default_cache_dir),
        read_only: a.read_only,
        static_dir: a.static_dir,
        cors_origins: a.cors_origins,
        body_limit: a.body_limit,
        memory_budget: a.memory_budget.unwrap_or(defaults.memory_budget),
        max_concurrent: a.max_concurrent.unwrap_or(defaults.max_concurrent).max(1),
        request_timeout: seconds("request-timeout", a.request_timeout)?,
        header_timeout: seconds("header-timeout", a.header_timeout)?,
        max_connections: a.max_connections.max(1),
        bake_command,
        admin_token: match a.admin_token {
            Some(t) => {
                anyhow::ensure!(
                    t.len() >= 16
                        && t.is_ascii()
                        && !t.chars().any(|c| c.is_ascii_control() || c == ' '),
                    "--admin-token: use at least 16 printable ASCII characters without spaces"
                );
                Some(t)
            }
            None => None,
        },
        upload_limit: a.upload_limit.unwrap_or(defaults.upload_limit),
        final_settings: relight::render::final_gather::FinalSettings::from_env(),
        ..defaults
    };
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(relight::server::serve(config))
}

/// An upload limit: bytes with an optional unit, at least 1 KiB.
fn parse_upload_limit(s: &str) -> Result<u64, String> {
    if s.contains('%') {
        return Err(format!(
            "upload limit '{s}': give bytes (e.g. 256M), not a percentage"
        ));
    }
    let n =
        relight::budget::parse_budget(s).map_err(|e| e.replace("memory budget", "upload limit"))?;
    if n < 1024 {
        return Err(format!("upload limit '{s}': at least 1K"));
    }
    Ok(n)
}

/// Seconds from the command line as a Duration (finite, positive, at most a day).
fn seconds(what: &str, s: f64) -> Result<std::time::Duration> {
    anyhow::ensure!(
        s.is_finite() && s > 0.0 && s <= 86_400.0,
        "--{what} {s}: give seconds in (0, 86400]"
    );
    Ok(std::time::Duration::from_secs_f64(s))
}

/// GET /healthz over a plain TCP connection, with a 3 s budget.
pub fn health(mut addr: std::net::SocketAddr) -> Result<()> {
    use std::io::{Read, Write};
    use std::time::Duration;
    if addr.ip().is_unspecified() {
        addr.set_ip(match addr.ip() {
            std::net::IpAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
            std::net::IpAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
        });
    }
    let t = Duration::from_secs(3);
    let mut s = std::net::TcpStream::connect_timeout(&addr, t)
        .with_context(|| format!("cannot connect to {addr}"))?;
    s.set_read_timeout(Some(t))?;
    s.set_write_timeout(Some(t))?;
    s.write_all(b"GET /healthz HTTP/1.0\r\nHost: localhost\r\n\r\n")?;
    let mut head = [0u8; 64];
    let n = s.read(&mut head)?;
    let line = String::from_utf8_lossy(&head[..n]);
    let status = line.lines().next().unwrap_or("");
    anyhow::ensure!(
        status.split_whitespace().nth(1) == Some("200"),
        "{addr}/healthz answered '{status}'"
    );
    outln!("ok: {addr} healthy");
    Ok(())
}
