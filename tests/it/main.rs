//! The integration tests, in one binary with a module per feature. How they are laid out,
//! how to run one module or one test, and the gate every test takes (`common::shared()` or
//! `common::alone()`) are described once, in `docs/development.md` ("Test layout").

mod common;

mod bench;
mod browser;
mod cache;
mod cli;
mod cluster_patches;
mod configuration_factors;
mod cornell;
mod daylight;
mod final_render;
mod fuzz;
mod fuzz_requests;
mod glare;
mod glossy;
mod gltf_import;
mod grids;
mod hardening;
mod hierarchical;
mod http;
mod lenient;
mod luminaires;
mod placed_luminaires;
mod render;
mod report_pdf;
mod saturation;
mod scene_errors;
mod shards;
mod solver;
mod ugr_table;
mod units;
