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
//! The equations, estimators, bounds and measures are in `docs/model.md`; the study keys,
//! the output columns and the commands in the README.
//!
//! # The pipeline
//!
//! One module per stage, each using only the stages before it (a test checks this):
//!
//! | layer | module | holds |
//! |---|---|---|
//! | foundation | [`numeric`] | exact order-independent sums, the small SPD solver |
//! | foundation | [`noise`] | ChaCha8 streams keyed by (seed, condition, channel), the ziggurat |
//! | world | [`terrain`] | elevation profiles, grade tables, the terrain metric ς |
//! | world | [`vehicle`] | vehicle parameters, the RK4 drive-cycle simulation |
//! | estimation | [`estimate`] | the regression, per-realisation moments (the kernel), estimators, bounds |
//! | input | [`study`] | TOML study files → a validated [`Study`]; errors name file, key and line |
//! | model | [`model`] | what one realisation computes and the [`model::Layout`] of its rows |
//! | execution | [`montecarlo`] | the rayon executor over a `&dyn Model`, observers |
//! | statistics | [`stats`] | performance measures with MCSEs, the two-pass summary, the summary columns |
//! | output | [`output`] | Parquet tables, the output set (manifest, journal, lock), parts and resume |
//! | output | [`figures`] | SVG figures from the summary and cycles |
//! | top | [`report`], [`run`], [`check`] | the printed table; run, shard and summarize; a study checked without running |
//!
//! # Where to add
//!
//! - **an estimator**: one [`estimate::estimators::Estimator`] impl, listed in
//!   [`estimate::estimators::ESTIMATORS`]; study files can then name it, every realisation
//!   runs it on the same draws, and its rows, summary and figures follow.
//! - **a bound**: one entry of [`estimate::bounds::BOUNDS`] (name, description, when it
//!   applies, how its standard errors are computed).
//! - **a per-row extra column**: one entry of [`estimate::conversions::EXTRAS`].
//! - **a summary measure**: a variant of [`stats::columns::Measure`] or
//!   [`stats::columns::BoundMeasure`] (the writer, the decoder and the figures take it from
//!   there) and its computation in [`stats::summary`].
//! - **a model**: one [`model::Model`] impl and an arm of [`model::prepare`]; the executor,
//!   statistics, output and figures work from its [`model::Layout`].
//! - **a terrain profile**: one [`terrain::Profile`] impl and one entry of
//!   [`terrain::profiles::PROFILES`] (its name in study files and how it reads its own keys
//!   of `[terrain]`), both in `terrain/profiles.rs`; grade tables, scaling and ς follow.
//! - **a noise channel, a drive-cycle source, a condition axis**: today these still touch
//!   the study, the model and the moment accumulator; see [`noise::NoiseLevels`] and
//!   [`model::vehicle`].

#![deny(missing_docs)]

pub mod check;
pub mod estimate;
pub mod figures;
pub mod model;
pub mod montecarlo;
pub mod noise;
pub mod numeric;
pub mod output;
pub mod report;
pub mod run;
pub mod settings;
pub mod stats;
pub mod study;
pub mod terrain;
pub mod vehicle;

pub use run::{RunError, RunOptions, RunReport, run_study};
pub use study::{Study, StudyError};
