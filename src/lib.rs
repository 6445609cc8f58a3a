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
//! A study file becomes a validated [`Study`]; [`model::prepare`] turns it into a
//! [`model::Model`] (for the vehicle: one drive cycle per terrain scale, its regression, and
//! the conditions of the grid); the [`montecarlo`] executor runs every realisation of every
//! condition in parallel, each from its own random streams (a run streams them to files;
//! `design`, `check` and `fit`'s bootstrap hold them in memory, through the same executor);
//! [`stats`] summarises them with
//! Monte Carlo standard errors; [`output`] writes the Parquet set and [`figures`] the SVGs;
//! [`run`] ties these together (with resume, shards and `summarize`).
//!
//! One module per stage, each using only the stages before it (a test checks this):
//!
//! | layer | module | holds |
//! |---|---|---|
//! | foundation | [`numeric`] | exact order-independent sums, the small SPD solver |
//! | foundation | [`settings`] | typed reading of the study-file keys an extension owns |
//! | foundation | [`tabular`] | numeric columns of a user's CSV or Parquet file, errors naming column and line |
//! | foundation | [`noise`] | ChaCha8 streams keyed by (seed, condition or draw group, channel), the ziggurat |
//! | world | [`terrain`] | elevation profiles, grade tables, the terrain metric ς |
//! | world | [`dynamics`] | vehicle parameters, drive cycles and where they come from (drive modes) |
//! | estimation | [`estimate`] | noise channels, the regression, per-realisation moments (the kernel), estimators, bounds |
//! | input | [`study`] | TOML study files → a validated [`Study`]; errors name file, key and line |
//! | model | [`model`] | what one realisation computes, the condition grid and the [`model::Layout`] of its rows |
//! | execution | [`montecarlo`] | the rayon executor over a `&dyn Model`, observers |
//! | statistics | [`stats`] | performance measures with MCSEs, the two-pass summary, the summary columns |
//! | output | [`output`] | Parquet tables, the output set (manifest, journal, lock), parts and resume |
//! | output | [`figures`] | SVG figures from the summary and cycles |
//! | top | [`report`], [`run`], [`check`], [`design`], [`fit`] | the printed table and report.html; run, shard and summarize; a study checked without running; the smallest duration (or scale, or largest noise) meeting a target; estimates from a measured log |
//! | command line | [`cli`] | the `chassis-mc` command: flags, exit statuses, progress; `src/main.rs` and the Python wheel's `chassis-mc` call [`cli::main`] |
//!
//! # Where to add
//!
//! Each kind of extension is one typed entry; the study keys, the layout, the output columns,
//! the summary and the figures are derived from the entries.
//!
//! - **an estimator**: one [`estimate::estimator::Estimator`] impl (its estimate from a
//!   realisation's moments, or also from its measured rows when it says it reads them or
//!   from its own [`estimate::estimator::RowScan`] of them; its own columns of the
//!   realisation table; its first-order bias; which bounds it reports), in its own file in
//!   `estimate/` when it is more than normal equations (as `wbcls.rs`, `rls/`,
//!   `road_load.rs`), and one line of the `estimators!` registry in `estimate/mod.rs`
//!   ([`estimate::ESTIMATORS`]). Study files can then name it and every realisation runs it
//!   on the same draws.
//! - **a bound**: one entry of [`estimate::bounds::BOUNDS`] (name, description, when it
//!   applies, how its standard errors are computed), in `estimate/bounds.rs`.
//! - **a per-row extra column**: one entry of [`estimate::conversions::EXTRAS`] (every
//!   estimator's row), or an estimator's own ([`estimate::estimator::Estimator::columns`]).
//! - **a noise channel**: one file in `estimate/channels/` with a unit struct implementing
//!   [`estimate::channels::ChannelTerms`] (its study key and column, unit, default, stream,
//!   the measured columns it moves, how its draw perturbs a sample, its term of the
//!   equation-error variance Ω, its expectations of the columns, its BCLS correction of the
//!   sums and, where rows share its noise, its part of the sandwich off the diagonal, the
//!   variance it adds to a differentiated ỹ, its correlation time and the slot for its
//!   covariances, its place in the order of Ω's terms and its stream identifier), and one
//!   line of the `channels!` registry in `estimate/channels/mod.rs`. The `[noise]`
//!   key, the condition axis, the stream, which control variates vary, the bounds, BCLS and
//!   wbcls's weights and left-out neighbours follow.
//! - **a sum of the normal equations**: one line of the table in `estimate/sums.rs`
//!   ([`estimate::sums::Sum`]); [`estimate::sums::Moments`], the general kernel's sums and
//!   the control variates follow; the hand-written lists (the fast path's in
//!   `estimate/moments.rs`, the segments' in `estimate/moments/segment_sums.rs` and `estimate/wbcls.rs`,
//!   the noise-free ones in `estimate/regression.rs`) name every field, so the compiler lists them, and
//!   `every_hand_written_list_sums_each_sum_by_its_factors` checks their values.
//! - **a terrain profile**: one [`terrain::Profile`] impl and one entry of
//!   [`terrain::profiles::PROFILES`] (its name in study files and how it reads its own keys
//!   of `[terrain]`), both in `terrain/profiles.rs`; grade tables, scaling and ς follow.
//! - **a drive mode (cycle source)**: one [`dynamics::CycleSource`] impl that reads its own
//!   keys of `[drive]` (its own file, as `dynamics/torque.rs`) and one entry of
//!   [`dynamics::DRIVE_MODES`].
//! - **a condition axis** of the vehicle model whose levels are numbers under `[noise]`:
//!   one `LevelAxisEntry` impl in its own file in `study/axes/` (its key and column, unit,
//!   the level without the key, the check of a level, what a level does to a condition's
//!   noise levels) and one line of the `level_axes!` registry there; the study reads its
//!   levels, the grid, the columns and the values follow, and a consumer reads a
//!   condition's level by [`study::LevelAxis`] ([`model::vehicle::Point::level`];
//!   docs/model.md#condition-axes). The noise channels and the model errors are axes
//!   through their own registries.
//! - **a summary measure**: one [`stats::summary::SummaryMeasure`] impl in its own file
//!   under `stats/summary/measure/` (its column, whether it has an MCSE, how it is computed
//!   from the condition's sums) and one line of the `summary_measures!` registry there; the
//!   summary, the writer, the decoder and the figures take it from the registry. A measure
//!   of a bound is a variant of [`stats::columns::BoundMeasure`].
//! - **a model error** (how the simulated truth differs from the regression's equation):
//!   one [`dynamics::truth::ModelError`] impl (the inertia and force the equation leaves out
//!   at a sample, or what it does to the logged force, and whether it is drawn per
//!   realisation) and one entry of [`dynamics::truth::MODEL_ERRORS`] (its key of `[truth]`,
//!   unit, neutral value, whether it is an axis), in `dynamics/truth/`; the study reads it,
//!   the drive modes apply it and `bias_model` reports it from there
//!   (docs/model.md#model-errors).
//! - **a model**: one [`model::Model`] impl and an arm of [`model::prepare`]; the executor,
//!   statistics, output and figures work from its [`model::Layout`].

#![deny(missing_docs)]

pub mod check;
pub mod cli;
pub mod design;
pub mod dynamics;
pub mod estimate;
pub mod figures;
pub mod fit;
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
pub mod tabular;
pub mod terrain;

pub use run::{RunError, RunOptions, RunReport, run_study};
pub use study::{Study, StudyError};
