//! [`ServerConfig`]: everything `relight serve` can be told, with its defaults.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use super::admission;
use crate::bake;
use crate::render::final_gather::FinalSettings;

/// Largest accepted request body (bytes) unless configured.
pub const DEFAULT_BODY_LIMIT: usize = 16 << 20;

/// Everything `relight serve` can be told.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    pub addr: SocketAddr,
    pub scenes: PathBuf,
    pub cache: PathBuf,
    /// Never bake or write: serve only what the cache holds.
    pub read_only: bool,
    /// Folder served at `/` (the web page).
    pub static_dir: PathBuf,
    /// Origins allowed by CORS; empty = same origin only. `*` allows any.
    pub cors_origins: Vec<String>,
    pub body_limit: usize,
    /// Memory budget, bytes (see [`crate::budget`]).
    pub memory_budget: u64,
    /// Heavy requests running at once (renders, batches, gathers, solves); more wait.
    pub max_concurrent: usize,
    /// How long a heavy request may wait for a slot before it is shed (503).
    pub queue_wait: Duration,
    /// Longest time a request may take, from its first byte to its answer.
    pub request_timeout: Duration,
    /// Longest time a client may take to send a request's headers.
    pub header_timeout: Duration,
    /// Most open connections; more are closed at once.
    pub max_connections: usize,
    /// Bake scenes in a child process (`relight bake`), so that a bake that runs out of
    /// memory cannot take the server down. `None` bakes in this process (tests).
    pub bake_command: Option<PathBuf>,
    /// Bearer token for the write endpoints (`PUT`/`DELETE /api/scenes/{id}`); `None`
    /// disables them (403).
    pub admin_token: Option<String>,
    /// Largest uploaded scene (the body of `PUT /api/scenes/{id}`), bytes.
    pub upload_limit: u64,
    /// The work per pixel of `final` images (`relight serve` reads the benches'
    /// `RELIGHT_FINAL_*` overrides once, [`FinalSettings::from_env`]).
    pub final_settings: FinalSettings,
}

/// Default largest upload (256 MiB).
pub const DEFAULT_UPLOAD_LIMIT: u64 = 256 << 20;

/// Default longest request time.
pub(crate) const DEFAULT_REQUEST_TIMEOUT: Duration = Duration::from_secs(60);
/// Default longest time to send request headers.
pub(crate) const DEFAULT_HEADER_TIMEOUT: Duration = Duration::from_secs(10);
/// Default most open connections.
pub const DEFAULT_MAX_CONNECTIONS: usize = 1024;

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig {
            addr: SocketAddr::from(([127, 0, 0, 1], 8080)),
            scenes: PathBuf::from("scenes"),
            cache: bake::default_cache_dir(),
            read_only: false,
            static_dir: PathBuf::from("static"),
            cors_origins: vec![],
            body_limit: DEFAULT_BODY_LIMIT,
            memory_budget: crate::budget::default_budget(),
            max_concurrent: admission::default_max_concurrent(),
            queue_wait: admission::DEFAULT_QUEUE_WAIT,
            request_timeout: DEFAULT_REQUEST_TIMEOUT,
            header_timeout: DEFAULT_HEADER_TIMEOUT,
            max_connections: DEFAULT_MAX_CONNECTIONS,
            bake_command: None,
            admin_token: None,
            upload_limit: DEFAULT_UPLOAD_LIMIT,
            final_settings: FinalSettings::default(),
        }
    }
}
