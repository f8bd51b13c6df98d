//! The query layer: everything a client can ask of a baked scene, in engine terms.
//! The CLI, the HTTP server and the examples all answer through it.

pub mod grid;
pub mod lighting;
pub mod optimize;
pub mod report;
