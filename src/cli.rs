//! Flags → validated configuration → library calls. `anyhow` lives only here.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::anyhow;
use chassis_mc::design::{
    DesignError, DesignKey, DesignRequest, DesignTarget, answer_sentence, design,
};
use chassis_mc::figures::{self, FigureError};
use chassis_mc::fit::{FitError, FitSpec, simulate_log};
use chassis_mc::output::OutputError;
use chassis_mc::run::{RunError, RunOptions, Shard, run_study, summarize};
use chassis_mc::stats::plan::{self, Plan, Target, replications_for};
use chassis_mc::study::MAX_REALISATIONS;
use chassis_mc::study::Study;
use clap::{Parser, Subcommand};

use crate::progress::{Progress, human_duration};

/// Exit status for a bad study file or bad arguments.
pub const EXIT_BAD_INPUT: u8 = 2;
/// Exit status for a failure while running.
pub const EXIT_FAILURE: u8 = 1;

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
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
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
    Run {
        /// The study file (TOML), e.g. studies/thesis.toml.
        study: PathBuf,
        /// Output directory (created if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        #[command(flatten)]
        overrides: Overrides,
        /// Run only shard K of N (0-based): realisations ⌊K·R/N⌋ … ⌊(K+1)·R/N⌋ − 1 of every
        /// condition, written to DIR/shard=K/realisations.parquet. Combine the shards with
        /// `chassis-mc summarize DIR`.
        #[arg(long, value_name = "K/N", value_parser = Shard::parse)]
        shard: Option<Shard>,
        /// Do not draw DIR/figures/*.svg.
        #[arg(long)]
        no_figures: bool,
        /// Print no table and no progress (notices such as a recomputed damaged part are
        /// still printed on stderr).
        #[arg(long)]
        quiet: bool,
        /// Treat this run as a pilot: print the realisations per condition needed for the
        /// Monte Carlo standard error of MEASURE (mean, bias, rel_bias, emp_se, mse, rmse,
        /// rel_precision) to reach MCSE in every condition × estimator (× parameter, or only
        /// PARAMETER's), R·(MCSE now / MCSE wanted)², with the run time that takes at this
        /// run's pace. Repeatable.
        #[arg(long, value_name = "[PARAMETER:]MEASURE=MCSE", value_parser = Target::parse)]
        replications_for: Vec<Target>,
    },
    /// Check a study without running it: its conditions, the run time and the output size.
    #[command(long_about = "Check a study without running it.\n\n\
        Validates the study file (the same errors and exit status 2 as `run`), prepares the \
        model (simulates the drive cycles), and prints the conditions, the realisations, an \
        estimate of the run time on this machine (a few realisations of every condition timed \
        on one thread, scaled to the realisations and divided by the threads) and of the \
        size of the output files (a sample of rows encoded as `run` writes them). Writes \
        nothing.\n\n\
        Example: chassis-mc check studies/thesis.toml --realisations 100000")]
    Check {
        /// The study file (TOML).
        study: PathBuf,
        #[command(flatten)]
        overrides: Overrides,
    },
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
    Summarize {
        /// Output directories or realisation files.
        #[arg(required = true, value_name = "DIR")]
        inputs: Vec<PathBuf>,
        /// Where to write summary.parquet and cycles.parquet (default: the first DIR).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Do not draw OUT/figures/*.svg.
        #[arg(long)]
        no_figures: bool,
        /// Print no table.
        #[arg(long)]
        quiet: bool,
    },
    /// Find the smallest duration or terrain scale (or the largest speed noise) at which a
    /// target precision holds.
    #[command(
        long_about = "Find the smallest value of KEY in [FROM, TO] (the largest, for \
        noise.velocity_sd) at which a target on one parameter holds for one estimator.\n\n\
        KEY is drive.duration [s] (torque drive mode; the answer is a whole number of time \
        steps), terrain.scale or noise.velocity_sd [m/s]; the study must have one condition \
        once KEY is set. The target is PARAMETER:MEASURE<=VALUE with MEASURE rel_rmse, \
        rel_emp_se or abs_rel_bias (fractions of the true value). First-order predictions \
        (the bound's SE and the first-order speed-noise bias) on a grid of 25 values bracket \
        the answer; Monte Carlo runs of the study (its realisations and seed) confirm and \
        bisect it to 1 % of the range. A value holds when the Monte Carlo estimate of the \
        measure is at most the target. Prints the answer with the measure's MCSE there and \
        writes, into --out DIR, design.parquet (every value evaluated: predicted and \
        simulated measure with its MCSE, is_answer; the answer also in the footer key \
        chassis_mc.design.answer), figures/design.svg and report.html.\n\n\
        Example: chassis-mc design studies/design_thesis.toml --vary drive.duration --from 60 \
        --to 600 --target 'drag_over_mass:rel_rmse<=0.001' --estimator bcls --out \
        results/design"
    )]
    Design {
        /// The study file (TOML).
        study: PathBuf,
        /// The key varied: drive.duration, terrain.scale or noise.velocity_sd.
        #[arg(long, value_name = "KEY", value_parser = DesignKey::parse)]
        vary: DesignKey,
        /// The lower end of the range searched.
        #[arg(long, value_name = "A", allow_negative_numbers = true)]
        from: f64,
        /// The upper end of the range searched.
        #[arg(long, value_name = "B", allow_negative_numbers = true)]
        to: f64,
        /// PARAMETER:MEASURE<=VALUE, e.g. drag_over_mass:rel_rmse<=0.001.
        #[arg(long, value_name = "TARGET", value_parser = DesignTarget::parse)]
        target: DesignTarget,
        /// The estimator (one of the study's; default its first).
        #[arg(long, value_name = "E")]
        estimator: Option<String>,
        /// Output directory (created if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        #[command(flatten)]
        overrides: Overrides,
    },
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
        percentile interval). Writes DIR/fit.parquet, DIR/fit.svg and DIR/report.html and \
        prints the table.\n\n\
        Example: chassis-mc fit studies/fit_example.toml --out results/fit"
    )]
    Fit {
        /// The fit file (TOML).
        fit: PathBuf,
        /// Output directory (created if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
    },
    /// Write a synthetic log of a one-condition study: its cycle with one realisation's noise.
    #[command(
        long_about = "Write a synthetic measured log (CSV) of a study with one \
        condition: the noise-free drive cycle plus realisation R's noise of every channel that \
        is on, drawn as a run draws it (seed and R select it). Columns time_s, speed_m_s, \
        force_n, grade_rad, accel_m_s2 (the model acceleration plus the output noise). The \
        input of `fit` for a vehicle whose truth is known.\n\n\
        Example: chassis-mc simulate-log studies/fit_log.toml --out studies/data/fit_log.csv"
    )]
    SimulateLog {
        /// The study file (TOML), one condition.
        study: PathBuf,
        /// The CSV file to write.
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// Which realisation's noise.
        #[arg(long, value_name = "R", default_value_t = 0)]
        realisation: u64,
        #[command(flatten)]
        overrides: Overrides,
    },
    /// Redraw DIR/figures/*.svg from an output directory's summary.parquet and cycles.parquet.
    #[command(
        long_about = "Redraw DIR/figures/*.svg from DIR/summary.parquet and DIR/cycles.parquet.\n\n\
        Per parameter: se_<p>.svg (empirical SE ± MCSE and every bound against the terrain \
        metric ς, the thesis's Figures 4-6 and more), bias_<p>.svg, ratio_<p>.svg (EmpSE / \
        bound with its MCSE around 1) and coverage_<p>.svg (against the nominal 95 %); and \
        cycles.svg (speed and grade against time).\n\n\
        Example: chassis-mc figures results/thesis"
    )]
    Figures {
        /// An output directory of `run` or `summarize`.
        dir: PathBuf,
    },
}

/// What `run` and `check` may override in the study file.
#[derive(Debug, clap::Args)]
struct Overrides {
    /// Realisations per condition, overriding the study's `realisations`.
    #[arg(long, value_name = "N")]
    realisations: Option<u64>,
    /// Master seed, overriding the study's `seed`: a whole number from 0 to
    /// 9223372036854775807 (2^63 − 1), as in a study file.
    #[arg(long, value_name = "S")]
    seed: Option<u64>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long, value_name = "T", value_parser = clap::value_parser!(u16).range(1..))]
    threads: Option<u16>,
}

impl Overrides {
    /// The study file at `path` with these overrides.
    fn load(&self, path: &Path) -> Result<Study, Failure> {
        Ok(Study::load(path)
            .and_then(|s| s.with_overrides(self.realisations, self.seed))
            .map_err(RunError::from)?)
    }

    fn threads(&self) -> Option<usize> {
        self.threads.map(usize::from)
    }
}

/// A failure with the exit code it maps to.
pub struct Failure {
    pub error: anyhow::Error,
    pub code: u8,
}

impl From<RunError> for Failure {
    fn from(e: RunError) -> Self {
        let code = match &e {
            RunError::Study(_) | RunError::Figures(FigureError::Study(_)) => EXIT_BAD_INPUT,
            RunError::Output(o) | RunError::Figures(FigureError::Output(o)) => output_code(o),
            _ => EXIT_FAILURE,
        };
        Failure {
            error: anyhow!(e),
            code,
        }
    }
}

impl From<FigureError> for Failure {
    fn from(e: FigureError) -> Self {
        let code = match &e {
            FigureError::Study(_) | FigureError::NotAnOutputDirectory(_) => EXIT_BAD_INPUT,
            FigureError::Output(o) => output_code(o),
            _ => EXIT_FAILURE,
        };
        Failure {
            error: anyhow!(e),
            code,
        }
    }
}

/// The exit status of an output error: 2 when the directory or file given cannot be used
/// as it is (see [`OutputError::is_bad_input`]), 1 for a failure while running.
fn output_code(e: &OutputError) -> u8 {
    match e.is_bad_input() {
        true => EXIT_BAD_INPUT,
        false => EXIT_FAILURE,
    }
}

/// Parse the command line (exits with status 2 on bad arguments, 0 for --help).
pub fn parse() -> Cli {
    Cli::parse()
}

/// A bad argument: exit status 2 with `message`.
fn bad_argument(message: String) -> Failure {
    Failure {
        error: anyhow!(message),
        code: EXIT_BAD_INPUT,
    }
}

/// `--out` (or a command's directory) must be a directory or not exist yet, under a
/// directory (not under a file).
fn output_directory(flag: &str, dir: &Path) -> Result<(), Failure> {
    if let Some(existing) = dir.ancestors().find(|a| a.exists())
        && !existing.is_dir()
    {
        let what = if existing == dir {
            "is a file, not a directory".to_string()
        } else {
            format!("{} is a file, not a directory", existing.display())
        };
        return Err(bad_argument(format!("{flag} {}: {what}", dir.display())));
    }
    Ok(())
}

/// Check that every target names a parameter of `layout` (before the run).
fn check_targets(layout: &chassis_mc::model::Layout, targets: &[Target]) -> Result<(), Failure> {
    let parameters: Vec<&str> = layout.parameters.iter().map(|p| p.name).collect();
    for target in targets {
        if let Some(p) = &target.parameter
            && !parameters.contains(&p.as_str())
        {
            return Err(bad_argument(format!(
                "--replications-for: unknown parameter \"{p}\"; expected one of {parameters:?}"
            )));
        }
    }
    Ok(())
}

/// Print, for each target, the realisations it needs and the time they take at the pace of
/// the run just done (`seconds` for `pilot_r` realisations per condition).
fn plan_replications(
    report: &chassis_mc::run::RunReport,
    targets: &[Target],
    pilot_r: u64,
    seconds: f64,
) -> Result<(), Failure> {
    let parameters: Vec<&str> = report.layout.parameters.iter().map(|p| p.name).collect();
    for target in targets {
        let what = format!(
            "{}{} MCSE {:e}",
            target
                .parameter
                .as_deref()
                .map_or(String::new(), |p| format!("{p}:")),
            target.measure,
            target.mcse
        );
        let pace = |r: f64| {
            human_duration(std::time::Duration::from_secs_f64(
                (seconds * r / pilot_r as f64).min(1e18),
            ))
        };
        let at = |row: &chassis_mc::stats::summary::SummaryRow| {
            format!(
                "condition {}, {}, {}",
                row.condition, report.layout.estimators[row.estimator], parameters[row.parameter]
            )
        };
        match replications_for(&report.summary, &parameters, pilot_r, target) {
            Plan::Reach { realisations, row } => {
                let current = plan::measure(row, &target.measure).map_or(f64::NAN, |m| m.mcse);
                println!(
                    "replications for {what}: R = {realisations} per condition (now {pilot_r}, \
                     MCSE {current:.3e} at {}); about {} at this run's pace",
                    at(row),
                    pace(realisations as f64)
                );
            }
            Plan::OutOfReach {
                needed,
                row,
                best_mcse,
            } => {
                let current = plan::measure(row, &target.measure).map_or(f64::NAN, |m| m.mcse);
                println!(
                    "replications for {what}: out of reach: it would take R ≈ {needed:.2e} per \
                     condition (now {pilot_r}, MCSE {current:.3e} at {}), more than the \
                     {MAX_REALISATIONS} a study accepts, and about {} at this run's pace; the \
                     smallest MCSE reachable there is {best_mcse:.3e}",
                    at(row),
                    pace(needed)
                );
            }
            Plan::Exact if target.measure == "rel_precision" => println!(
                "replications for {what}: nothing to plan: rel_precision compares each \
                 estimator's spread with the first estimator's ({}), whose own is 0 by \
                 definition, without Monte Carlo error{}",
                report.layout.estimators[0],
                match report.layout.estimators.len() {
                    1 => "; this study has no other estimator",
                    _ => "",
                }
            ),
            Plan::Exact => println!(
                "replications for {what}: nothing to plan: {} has no Monte Carlo error here \
                 (its MCSE is 0 in every row)",
                target.measure
            ),
            Plan::Undefined => {
                println!("replications for {what}: no finite MCSE in this run to plan from")
            }
        }
    }
    Ok(())
}

/// Execute a parsed command.
pub fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Run {
            study,
            out,
            overrides,
            shard,
            no_figures,
            quiet,
            replications_for,
        } => {
            output_directory("--out", &out)?;
            let study = overrides.load(&study)?;
            check_targets(&chassis_mc::model::layout_of(&study), &replications_for)?;
            if let Some(shard) = shard
                && shard.range(study.realisations()).is_empty()
            {
                return Err(bad_argument(format!(
                    "--shard {shard}: holds none of the {} realisations per condition; with R \
                     realisations use at most R shards (--shard K/N with N <= {})",
                    study.realisations(),
                    study.realisations()
                )));
            }
            let mut options = RunOptions::new(out);
            options.threads = overrides.threads();
            options.shard = shard;
            options.figures = !no_figures;
            let started = Instant::now();
            let progress = Progress::new(quiet);
            let report = run_study(&study, &options, &progress)?;
            progress.finish();
            if let (Some(shard), false) = (shard, quiet) {
                println!(
                    "shard {shard}: {} realisations computed, {} kept; wrote {}",
                    report.computed,
                    report.reused,
                    report.files[0].display()
                );
                println!("when every shard is done: chassis-mc summarize <DIR>");
            } else if !quiet {
                print!(
                    "{}",
                    chassis_mc::report::table(&report.layout, &report.infos, &report.summary)
                );
                println!(
                    "{} conditions × {} realisations in {:.1} s; wrote:",
                    report.infos.len(),
                    study.realisations(),
                    started.elapsed().as_secs_f64()
                );
                for f in &report.files {
                    println!("  {}", f.display());
                }
            }
            plan_replications(
                &report,
                &replications_for,
                study.realisations(),
                started.elapsed().as_secs_f64(),
            )?;
            Ok(())
        }
        Command::Summarize {
            inputs,
            out,
            no_figures,
            quiet,
        } => {
            if let Some(out) = &out {
                output_directory("--out", out)?;
            }
            let out = out.unwrap_or_else(|| inputs[0].clone());
            let out = if out.is_file() {
                out.parent().map(PathBuf::from).unwrap_or_default()
            } else {
                out
            };
            let report = summarize(&inputs, &out, !no_figures)?;
            if !quiet {
                print!(
                    "{}",
                    chassis_mc::report::table(&report.layout, &report.infos, &report.summary)
                );
                for f in &report.files {
                    println!("  {}", f.display());
                }
            }
            Ok(())
        }
        Command::Check { study, overrides } => {
            let study = overrides.load(&study)?;
            let found = chassis_mc::check::check(&study, overrides.threads())?;
            print!("{}", check_report(&study, &found));
            Ok(())
        }
        Command::Design {
            study,
            vary,
            from,
            to,
            target,
            estimator,
            out,
            overrides,
        } => {
            output_directory("--out", &out)?;
            let study = overrides.load(&study)?;
            let request = DesignRequest {
                key: vary,
                from,
                to,
                target,
                estimator,
                out,
            };
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(overrides.threads().unwrap_or(0))
                .build()
                .map_err(|e| bad_argument(format!("--threads: {e}")))?;
            let result = pool.install(|| design(&study, &request)).map_err(|e| {
                let code = match &e {
                    DesignError::Study(_) | DesignError::Request(_) => EXIT_BAD_INPUT,
                    DesignError::Output(o) => output_code(o),
                    _ => EXIT_FAILURE,
                };
                Failure {
                    error: anyhow!(e),
                    code,
                }
            })?;
            println!(
                "{}",
                answer_sentence(&request, result.answer, result.answer_sd, result.neighbour)
            );
            println!(
                "estimator {}, {} realisations per Monte Carlo evaluation, {} values evaluated \
                 ({} by Monte Carlo); wrote:",
                result.estimator,
                result.realisations,
                result.points.len(),
                result
                    .points
                    .iter()
                    .filter(|p| p.simulated.is_some())
                    .count()
            );
            for f in &result.files {
                println!("  {}", f.display());
            }
            if result.answer.is_none() {
                return Err(Failure {
                    error: anyhow!("no value in the range meets the target"),
                    code: EXIT_FAILURE,
                });
            }
            Ok(())
        }
        Command::Fit { fit, out } => {
            output_directory("--out", &out)?;
            let code = |e: &FitError| match e {
                FitError::Study(_) => EXIT_BAD_INPUT,
                FitError::Output(o) => output_code(o),
                _ => EXIT_FAILURE,
            };
            let fail = |e: FitError| Failure {
                code: code(&e),
                error: anyhow!(e),
            };
            let spec = FitSpec::load(&fit).map_err(|e| fail(e.into()))?;
            let result = chassis_mc::fit::fit(&spec, &out).map_err(fail)?;
            print!("{}", chassis_mc::fit::table(&result.rows));
            println!("wrote:");
            for f in &result.files {
                println!("  {}", f.display());
            }
            Ok(())
        }
        Command::SimulateLog {
            study,
            out,
            realisation,
            overrides,
        } => {
            let study = overrides.load(&study)?;
            let n = simulate_log(&study, realisation, &out).map_err(|e| Failure {
                code: match e {
                    FitError::Study(_) => EXIT_BAD_INPUT,
                    _ => EXIT_FAILURE,
                },
                error: anyhow!(e),
            })?;
            println!("wrote {} ({n} samples)", out.display());
            Ok(())
        }
        Command::Figures { dir } => {
            for f in figures::draw(&dir)? {
                println!("{}", f.display());
            }
            Ok(())
        }
    }
}

/// What `check` prints.
fn check_report(study: &Study, c: &chassis_mc::check::StudyCheck) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: study \"{}\", seed {}",
        study.origin(),
        study.name(),
        study.seed()
    );
    let mut header = format!("{:>4}", "cond");
    for axis in &c.layout.axes {
        let _ = write!(header, " {:>12}", axis.name);
    }
    let _ = write!(header, " {:>14}", "ms/realisation");
    let _ = writeln!(out, "{header}");
    for (i, (info, t)) in c.infos.iter().zip(&c.per_realisation).enumerate() {
        let mut line = format!("{i:>4}");
        for v in &info.axes {
            let _ = write!(line, " {:>12}", v.to_string());
        }
        let _ = writeln!(line, " {:>14.3}", t.as_secs_f64() * 1e3);
        out.push_str(&line);
    }
    let total = c.realisations * c.infos.len() as u64;
    let _ = writeln!(
        out,
        "{} conditions × {} realisations = {total} realisations",
        c.infos.len(),
        c.realisations
    );
    let _ = writeln!(
        out,
        "estimated run time on {} threads ({} cores): about {} (preparing the model {:.2} s, summary, \
         figures and report {:.2} s; a lower bound when the cores are shared)",
        c.threads,
        c.cores,
        human_duration(c.estimated_run_time()),
        c.prepare.as_secs_f64(),
        c.outputs.as_secs_f64()
    );
    let _ = writeln!(
        out,
        "estimated output: about {} in all",
        human_bytes(c.total_bytes())
    );
    // The figures on one line, every other file on its own.
    let (figures, files): (Vec<_>, Vec<_>) = c.files.iter().partition(|f| {
        f.name
            .starts_with(&format!("{}/", chassis_mc::figures::FIGURES))
    });
    for f in files {
        let _ = writeln!(out, "  {:<28} {:>10}", f.name, human_bytes(f.bytes));
    }
    if !figures.is_empty() {
        let name = format!(
            "{}/ ({} SVG files)",
            chassis_mc::figures::FIGURES,
            figures.len()
        );
        let bytes = figures.iter().map(|f| f.bytes).sum();
        let _ = writeln!(out, "  {name:<28} {:>10}", human_bytes(bytes));
    }
    out
}

/// Bytes for people: `3.4 MB`, `1.2 GB`.
fn human_bytes(b: f64) -> String {
    match b {
        b if b >= 1e12 => format!("{:.1} TB", b / 1e12),
        b if b >= 1e9 => format!("{:.1} GB", b / 1e9),
        b if b >= 1e6 => format!("{:.1} MB", b / 1e6),
        b if b >= 1e3 => format!("{:.0} kB", b / 1e3),
        b => format!("{b:.0} B"),
    }
}
