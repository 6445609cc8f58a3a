//! Estimation: normal equations, estimators and bounds.
//!
//! `linalg` solves the small normal-equation systems stably; `vehicle` builds them for the
//! longitudinal model from per-realisation sums and computes its bounds.

pub mod linalg;
pub mod vehicle;
