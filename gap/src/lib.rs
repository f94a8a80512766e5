//! Sim-to-real gap diagnosis.
//!
//! The paper's model (a rig's thrust → power curve and eqs. 1–9) is the "sim"; flight logs are
//! the "real". This crate says where the two part, which unmodelled effect causes it, and how far
//! the gap shrinks once that effect is added — and checks itself blind on simulated flights whose
//! truth it never reads.

pub mod flight;
pub mod lipo;
pub mod model;
pub mod truth;
