//! Light transport: form factors with occlusion ([`formfactor`]), the direct light of
//! point luminaires ([`direct`]), the dense solves ([`solve`]), the links of
//! hierarchical radiosity ([`hierarchy`]), the baked, immutable
//! [`transfer`], illuminance gathered at arbitrary points ([`probe`]), and what surfaces
//! and points see of the sky and the sun ([`sky`]).
//!
//! Exitance and radiosity are in lm/m², illuminance in lux, flux in lm.

pub mod direct;
pub mod formfactor;
pub mod hierarchy;
pub mod probe;
pub mod sky_view;
pub mod solve;
pub mod transfer;
