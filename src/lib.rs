//! # chassis-mc
//!
//! A Monte Carlo statistics engine for one question: how well does a drive cycle identify a
//! vehicle's mass, drag and rolling resistance, and can the error bounds people quote be
//! trusted?
//!
//! It reproduces the 2018 thesis study (a longitudinal vehicle model on a scaled sinusoidal
//! hill, least squares for θ = [1/M, Cd/M, Cr], Fisher-information bounds against a terrain
//! metric) with thousands of seeded noise realisations per condition, and reports each
//! estimator's bias, spread and every bound with Monte Carlo standard errors, as Parquet.
//!
//! The pipeline, one module per stage:
//!
//! study file → [`study`] → [`terrain`] + [`vehicle`] (drive cycle) → [`noise`] →
//! [`estimate`] (estimates and bounds) → [`montecarlo`] (executor over a [`model`]) →
//! [`stats`] (measures and MCSEs) → [`output`] (Parquet) → [`figures`] (SVG). [`run`] ties
//! them together.

#![deny(missing_docs)]

pub mod estimate;
pub mod figures;
pub mod model;
pub mod montecarlo;
pub mod noise;
pub mod numeric;
pub mod output;
pub mod report;
pub mod run;
pub mod stats;
pub mod study;
pub mod terrain;
pub mod vehicle;

pub use run::{RunError, RunOptions, RunReport, run_study};
pub use study::{Study, StudyError};
