//! The integration tests, in one binary with a module per feature (as ripgrep does): one
//! build and one link for all of them, and `common`'s helpers compiled once.
//!
//! `cargo test --release` runs them with the rest; `cargo test --release --test it`
//! runs only these, and a name filter picks a module or a test:
//!
//! ```text
//! cargo test --release --test it http::
//! cargo test --release --test it -- --exact hardening::resources::slow_clients_held_connections_forever
//! ```
//!
//! The tests run on parallel threads of this one process. Each holds a gate for its whole
//! run, `let _gate = common::shared();` as its first line. The few that need the machine
//! to themselves take `common::alone()` instead, and nothing else runs meanwhile:
//! `saturation` (health latency under load), `browser` (Chromium; it reports timings) and
//! `hardening::resources::spawned_work_kept_running_after_the_client_left` (it times work
//! on rayon's global pool, which the whole process shares). A new test takes one of the
//! two as well.

mod common;

mod browser;
mod cache;
mod cli;
mod configuration_factors;
mod cornell;
mod daylight;
mod fuzz;
mod fuzz_requests;
mod gltf_import;
mod grids;
mod hardening;
mod hierarchical;
mod http;
mod lenient;
mod luminaires;
mod render;
mod saturation;
mod scene_errors;
mod shards;
mod solver;
