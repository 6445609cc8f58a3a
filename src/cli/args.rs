//! The command line's arguments: every subcommand, its flags and their help text, and the
//! checks of an argument that need no study (the output directory).

use std::path::{Path, PathBuf};

use crate::design::{DesignKey, DesignTarget};
use crate::run::{RunError, Shard};
use crate::stats::plan::{Target, measure_names};
use crate::study::Study;
use clap::{Parser, Subcommand};

use super::failure::Failure;

#[derive(Debug, Parser)]
#[command(
    name = "chassis-mc",
    version,
    about = "Monte Carlo engine for vehicle chassis parameter identifiability",
    long_about = "Monte Carlo engine for vehicle chassis parameter identifiability.\n\n\
        Runs a study (a TOML file: vehicle, drive cycle, terrain scales, noise levels, \
        estimators) with many seeded noise realisations per condition, and writes the \
        estimates, their bias and spread, every bound and their Monte Carlo standard errors \
        as Parquet files that pandas and DuckDB read directly.\n\n\
        Exit status: 0 success, 1 failure while running, 2 bad study file or arguments."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands, each with its arguments.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run a study and write realisations.parquet, summary.parquet and cycles.parquet.
    #[command(long_about = "Run a study and write, into --out DIR:\n\
        \n  realisations.parquet  one row per realisation × estimator (θ̂, M̂, Ĉd, bounds, control \
        variates cv_*, status)\
        \n  summary.parquet       one row per condition × estimator × parameter (bias, EmpSE, \
        RMSE, each bound's SE, EmpSE/bound, coverage, all with Monte Carlo standard errors; and \
        the bias by control variates, bias_cv, often with a thousandth of the plain MCSE)\
        \n  cycles.parquet        each distinct noise-free drive cycle once\n\n\
        and DIR/figures/*.svg. Files appear only when the run completes, and replace the \
        previous run's files as one set (a run killed at any instant leaves the old set, the \
        new one, or a set that is reported incomplete and completed by the next run); your \
        own files in DIR stay. An interrupted run resumes from its completed parts, and a \
        larger --realisations extends an earlier run. One process writes a DIR at a time. \
        A per-condition table is printed on stdout; progress on stderr (a bar on a \
        terminal, a line every 10 s otherwise).\n\n\
        Example: chassis-mc run studies/thesis.toml --out results/thesis")]
    Run(RunArgs),
    /// Check a study without running it: its conditions, the run time and the output size.
    #[command(long_about = "Check a study without running it.\n\n\
        Validates the study file (the same errors and exit status 2 as `run`), prepares the \
        model (simulates the drive cycles), and prints the conditions, the realisations, an \
        estimate of the run time on this machine (a few realisations of every condition timed \
        on one thread, scaled to the realisations and divided by the threads) and of the \
        size of the output files (a sample of rows encoded as `run` writes them). Writes \
        nothing.\n\n\
        Example: chassis-mc check studies/thesis.toml --realisations 100000")]
    Check(CheckArgs),
    /// Rebuild summary.parquet (and cycles.parquet) from realisation files: the shards of a
    /// sharded run, or any run's realisations.parquet.
    #[command(
        long_about = "Rebuild summary.parquet (and cycles.parquet) from realisation files.\n\n\
        Each DIR may be a run's output directory (its realisations.parquet and every \
        shard=*/realisations.parquet are read) or a realisation file. The study is read from \
        the files' footers; every realisation of every condition must be present exactly \
        once. The result is bit-identical to the summary of an unsharded run.\n\n\
        Example: chassis-mc summarize results/thesis"
    )]
    Summarize(SummarizeArgs),
    /// Find the smallest duration or terrain scale (or the largest speed noise or model
    /// error) at which a target precision holds.
    #[command(long_about = design_about())]
    Design(DesignArgs),
    /// Estimate mass, drag and rolling resistance from a measured log, with sandwich SEs and
    /// a parametric bootstrap.
    #[command(
        long_about = "Estimate θ = [1/M, Cd/M, Cr] (and M, Cd) from a measured log.\n\n\
        FIT.toml gives [log] (file, time_column, speed_column, speed_unit, force_column [N] \
        or torque_column [N m] with the vehicle's final_drive_ratio and wheel_radius, \
        grade_column, grade_unit, optional acceleration_column [m/s^2] (else the speed is \
        differentiated), min_speed), [vehicle] (the known frontal_area, air_density, gravity), \
        [noise] (the assumed sensor noise: velocity_sd, output_sd, grade_sd, force_sd, \
        velocity_correlation_time), [estimation] estimators, seed and realisations, and \
        optionally [reference] (mass, drag_coefficient, rolling_resistance to show the fit \
        against). Each estimator's estimate gets its sandwich SE and a parametric bootstrap: \
        the fitted vehicle replayed on the log's rows (along the smoothed measured speed, or \
        simulated under the logged force when the speed is differentiated), the assumed \
        noise re-drawn, re-estimated R times (boot_mean, boot_bias, bias_corrected, 95 % \
        percentile interval). An optional [systematic] table gives magnitudes of the model \
        errors of a study's [truth] (e.g. wind_speed = 2.0, rotating_mass_factor = 0.03, \
        force_scale = 0.05): how far each estimate moves under each is reported beside the \
        interval (DIR/systematic.parquet and a second table). Writes DIR/fit.parquet, \
        DIR/fit.svg and DIR/report.html and prints the table.\n\n\
        A log without a grade: estimation.grade = \"none\" and no grade_column. The ekf and \
        rls_mf filters then estimate the grade with the mass, given [vehicle] \
        drag_coefficient and rolling_resistance and [estimation] prior_mass (and \
        prior_mass_sd, grade_walk, ...): each reports 1/M and M with its own SD and 95 % \
        interval beside the bootstrap's, whose world is the filters' own model with the fit's \
        mass (docs/model.md#fit-no-grade). The other estimators need the log's \
        acceleration_column then (cos θ taken as 1).\n\n\
        Example: chassis-mc fit studies/fit_example.toml --out results/fit"
    )]
    Fit(FitArgs),
    /// Write a synthetic log of a one-condition study: its cycle with one realisation's noise.
    #[command(
        long_about = "Write a synthetic measured log (CSV) of a study with one \
        condition: the noise-free drive cycle (or realisation R's own path, where the truth \
        follows the filters' model at the vehicle's mass: terrain.profile = \"random_walk\", \
        truth.speed_process_sd) plus realisation R's noise of every channel that is on, drawn \
        as a run draws it (seed and R select it). Columns time_s, speed_m_s, \
        force_n, grade_rad, accel_m_s2 (the model acceleration plus the output noise). The \
        input of `fit` for a vehicle whose truth is known.\n\n\
        Example: chassis-mc simulate-log studies/fit_log.toml --out studies/data/fit_log.csv"
    )]
    SimulateLog(SimulateLogArgs),
    /// Redraw DIR/figures/*.svg from an output directory's summary.parquet and cycles.parquet.
    #[command(
        long_about = "Redraw DIR/figures/*.svg from DIR/summary.parquet and DIR/cycles.parquet.\n\n\
        Per parameter: se_<p>.svg (empirical SE ± MCSE and every bound against the terrain \
        metric ς, the thesis's Figures 4-6 and more), bias_<p>.svg, ratio_<p>.svg (EmpSE / \
        bound with its MCSE around 1) and coverage_<p>.svg (against the nominal 95 %); and \
        cycles.svg (speed and grade against time).\n\n\
        Example: chassis-mc figures results/thesis"
    )]
    Figures(FiguresArgs),
}

/// What `run` and `check` may override in the study file.
#[derive(Debug, clap::Args)]
pub struct Overrides {
    /// Realisations per condition, overriding the study's `realisations`.
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = whole_number(1, u64::MAX))]
    realisations: Option<u64>,
    /// Master seed, overriding the study's `seed`: a whole number from 0 to
    /// 9223372036854775807 (2^63 − 1), as in a study file.
    #[arg(long, value_name = "S", allow_negative_numbers = true, value_parser = whole_number(0, i64::MAX as u64))]
    seed: Option<u64>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long, value_name = "T", allow_negative_numbers = true, value_parser = whole_number(1, u64::from(u16::MAX)))]
    threads: Option<u64>,
}

/// A parser of a whole number in `low..=high` whose error says the range and what was
/// given (a negative number too, instead of clap's advice to write `-- -1`).
fn whole_number(low: u64, high: u64) -> impl Fn(&str) -> Result<u64, String> + Clone {
    move |text: &str| {
        let range = match high {
            u64::MAX => format!("a whole number >= {low}"),
            _ => format!("a whole number from {low} to {high}"),
        };
        match text.trim().parse::<i128>() {
            Ok(v) if (i128::from(low)..=i128::from(high)).contains(&v) => Ok(v as u64),
            _ => Err(format!("must be {range}, got {text}")),
        }
    }
}

// The arguments of `Run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// The study file (TOML), e.g. studies/thesis.toml.
    pub study: PathBuf,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[command(flatten)]
    pub overrides: Overrides,
    /// Run only shard K of N (0-based): realisations ⌊K·R/N⌋ … ⌊(K+1)·R/N⌋ − 1 of every
    /// condition, written to DIR/shard=K/realisations.parquet. Combine the shards with
    /// `chassis-mc summarize DIR`.
    #[arg(long, value_name = "K/N", value_parser = Shard::parse)]
    pub shard: Option<Shard>,
    /// Do not draw DIR/figures/*.svg.
    #[arg(long)]
    pub no_figures: bool,
    /// Print no progress (the results table, the files written and notices such as a
    /// recomputed damaged part are still printed).
    #[arg(long)]
    pub quiet: bool,
    // Its help names the measures of the planner's list, so the two cannot differ.
    #[arg(
        long,
        value_name = "[PARAMETER:]MEASURE=MCSE",
        value_parser = Target::parse,
        help = replications_for_help()
    )]
    pub replications_for: Vec<Target>,
}

// The arguments of `Check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// The study file (TOML).
    pub study: PathBuf,
    #[command(flatten)]
    pub overrides: Overrides,
}

// The arguments of `Summarize`.
#[derive(Debug, clap::Args)]
pub struct SummarizeArgs {
    /// Output directories or realisation files.
    #[arg(required = true, value_name = "DIR")]
    pub inputs: Vec<PathBuf>,
    /// Where to write summary.parquet and cycles.parquet (default: the first DIR).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Do not draw OUT/figures/*.svg.
    #[arg(long)]
    pub no_figures: bool,
    /// Print no table.
    #[arg(long)]
    pub quiet: bool,
}

/// `--vary`'s help: every key `design` varies, from [`DesignKey::all`].
fn vary_help() -> String {
    let names: Vec<&str> = DesignKey::all().into_iter().map(DesignKey::name).collect();
    format!("The key varied: {}.", names.join(", "))
}

/// `design --help`'s long text; the keys it lists are [`DesignKey::all`] (the model errors
/// that are axes of `[truth]` among them).
fn design_about() -> String {
    let truth: Vec<String> = DesignKey::all()
        .into_iter()
        .filter(|k| matches!(k, DesignKey::Truth(_)))
        .map(|k| {
            let neutral = match k {
                DesignKey::Truth(t) => t.entry().neutral,
                _ => unreachable!("filtered to the truth keys"),
            };
            match k.unit() {
                "-" => format!("{} ({neutral})", k.name()),
                unit => format!("{} [{unit}] ({neutral})", k.name()),
            }
        })
        .collect();
    format!(
        "Find the smallest value of KEY in [FROM, TO] (the largest, for noise.velocity_sd and \
         the truth.* keys) at which a target on one parameter holds for one estimator.\n\n\
         KEY is drive.duration [s] (torque drive mode; the answer is a whole number of time \
         steps), drive.runs (coastdown drive mode: FROM, TO and the answer are even numbers \
         of runs, bisected to two runs), terrain.scale, noise.velocity_sd [m/s], or a steady \
         model error of [truth] \
         (docs/model.md#model-errors): {}; the study must have one condition once KEY is set. \
         For a truth.* key FROM may be its value without the error (in parentheses) and the \
         answer is the end of the run of values that hold from FROM upward (a bias may change \
         sign further out; for a headwind search e.g. --from 0 --to 8). The target is \
         PARAMETER:MEASURE<=VALUE with MEASURE rel_rmse, rel_emp_se or abs_rel_bias \
         (fractions of the true value). First-order predictions (the bound's SE and the \
         first-order bias: the speed noise's, and the model errors' through the noise-free \
         rows) on a grid of 25 values bracket the answer; Monte Carlo runs of the study (its \
         realisations and seed) confirm and bisect it to 1 % of the range (to two runs, for \
         drive.runs). A value holds when the Monte Carlo estimate of the measure is at most \
         the target. Prints the answer \
         with the measure's MCSE there and writes, into --out DIR, design.parquet (every \
         value evaluated: predicted and simulated measure with its MCSE, is_answer; the \
         answer also in the footer key chassis_mc.design.answer), figures/design.svg and \
         report.html.\n\n\
         Example: chassis-mc design studies/design_thesis.toml --vary drive.duration --from \
         60 --to 600 --target 'drag_over_mass:rel_rmse<=0.001' --estimator bcls --out \
         results/design\n\n\
         With a design file instead of a study (docs/model.md#design-campaign): its [design] \
         table names the study, the targets (all must hold), the choices ([[design.choices]]: \
         a study key and its options, or options that are tables of keys, each with a cost) and \
         an amount ([design.amount]: drive.duration, drive.runs or terrain.scale from FROM to \
         TO by STEP at a cost rate). Every combination at every amount is predicted by the \
         bound; the cheapest predicted to meet every target is run by Monte Carlo, and the next \
         when it misses. Prints the answer and writes design.parquet (every point, its cost, \
         predicted and simulated measures, the Pareto front of cost against the first \
         target's measure, the answer), figures/design.svg and report.html.\n\n\
         Example: chassis-mc design studies/design_campaign.toml --out results/campaign",
        truth.join(", ")
    )
}

// The arguments of `Design`.
#[derive(Debug, clap::Args)]
pub struct DesignArgs {
    /// The study file (TOML), or a design file (a `[design]` table: targets, priced choices
    /// and an amount; then no --vary, --from, --to, --target).
    pub study: PathBuf,
    /// The key varied (`design --help` lists them).
    #[arg(long, value_name = "KEY", value_parser = DesignKey::parse, help = vary_help())]
    pub vary: Option<DesignKey>,
    /// The lower end of the range searched.
    #[arg(long, value_name = "A", allow_negative_numbers = true)]
    pub from: Option<f64>,
    /// The upper end of the range searched.
    #[arg(long, value_name = "B", allow_negative_numbers = true)]
    pub to: Option<f64>,
    /// PARAMETER:MEASURE<=VALUE, e.g. drag_over_mass:rel_rmse<=0.001.
    #[arg(long, value_name = "TARGET", value_parser = DesignTarget::parse)]
    pub target: Option<DesignTarget>,
    /// The estimator (one of the study's; default its first).
    #[arg(long, value_name = "E")]
    pub estimator: Option<String>,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[command(flatten)]
    pub overrides: Overrides,
}

// The arguments of `Fit`.
#[derive(Debug, clap::Args)]
pub struct FitArgs {
    /// The fit file (TOML).
    pub fit: PathBuf,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

// The arguments of `SimulateLog`.
#[derive(Debug, clap::Args)]
pub struct SimulateLogArgs {
    /// The study file (TOML), one condition.
    pub study: PathBuf,
    /// The CSV file to write.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Which realisation's noise.
    #[arg(long, value_name = "R", default_value_t = 0)]
    pub realisation: u64,
    /// Replace FILE even if it is not a log simulate-log wrote (without it, a file whose
    /// first line is not simulate-log's header is never overwritten: exit 2).
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub overrides: Overrides,
}

// The arguments of `Figures`.
#[derive(Debug, clap::Args)]
pub struct FiguresArgs {
    /// An output directory of `run` or `summarize`.
    pub dir: PathBuf,
}

/// The help of `run --replications-for`, naming every measure the planner accepts.
fn replications_for_help() -> String {
    format!(
        "Treat this run as a pilot: print the realisations per condition needed for the \
         Monte Carlo standard error of MEASURE ({}) to reach MCSE in every condition × \
         estimator (× parameter, or only PARAMETER's), R·(MCSE now / MCSE wanted)², with the \
         run time that takes at this run's pace. Repeatable.",
        measure_names().join(", ")
    )
}

impl Overrides {
    /// The study file at `path` with these overrides.
    pub fn load(&self, path: &Path) -> Result<Study, Failure> {
        Ok(Study::load(path)
            .and_then(|s| s.with_overrides(self.realisations, self.seed))
            .map_err(RunError::from)?)
    }

    /// `study` with `--realisations` and `--seed` applied.
    pub fn apply(&self, study: Study) -> Result<Study, Failure> {
        Ok(study
            .with_overrides(self.realisations, self.seed)
            .map_err(RunError::from)?)
    }

    /// Worker threads (`None`: every core).
    pub fn threads(&self) -> Option<usize> {
        self.threads.map(|t| t as usize)
    }
}

/// `--out` (or a command's directory) must be a directory or not exist yet, under a
/// directory (not under a file).
pub fn output_directory(flag: &str, dir: &Path) -> Result<(), Failure> {
    if let Some(existing) = dir.ancestors().find(|a| a.exists())
        && !existing.is_dir()
    {
        let what = if existing == dir {
            "is a file, not a directory".to_string()
        } else {
            format!("{} is a file, not a directory", existing.display())
        };
        return Err(Failure::bad_argument(format!(
            "{flag} {}: {what}",
            dir.display()
        )));
    }
    // Inside the engine's own bookkeeping (a run's staging directory, a file being written)
    // the directory would be deleted or replaced by the run that owns it.
    let absolute = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    if let Some(inside) = absolute.ancestors().skip(1).find(|a| {
        a.file_name().is_some_and(|n| {
            let n = n.to_string_lossy();
            n == crate::run::STAGING || crate::output::is_temporary(&n)
        })
    }) {
        return Err(Failure::bad_argument(format!(
            "{flag} {}: is inside {}, which a chassis-mc run owns and deletes when it ends; \
             choose a directory outside it",
            dir.display(),
            inside.display()
        )));
    }
    Ok(())
}

/// `--out FILE` of a command that writes one file: not a directory, under a directory.
pub fn output_file(flag: &str, file: &Path) -> Result<(), Failure> {
    if file.is_dir() {
        return Err(Failure::bad_argument(format!(
            "{flag} {}: is a directory; give the path of the file to write",
            file.display()
        )));
    }
    match file.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(parent) => output_directory(flag, parent),
        None => Ok(()),
    }
}
