//! Flags → validated configuration → library calls. `anyhow` lives only here.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::anyhow;
use chassis_mc::figures::{self, FigureError};
use chassis_mc::montecarlo::Observer;
use chassis_mc::output::OutputError;
use chassis_mc::run::{RunError, RunOptions, Shard, run_study, summarize};
use chassis_mc::study::Study;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

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
        \n  realisations.parquet  one row per realisation × estimator (θ̂, M̂, Ĉd, bounds, status)\
        \n  summary.parquet       one row per condition × estimator × parameter (bias, EmpSE, \
        RMSE, each bound's SE, EmpSE/bound, coverage, all with Monte Carlo standard errors)\
        \n  cycles.parquet        the noise-free drive cycle of each condition\n\n\
        Files appear only when the run completes; existing files are replaced then. \
        A per-condition table is printed on stdout and a progress bar on stderr.\n\n\
        Example: chassis-mc run studies/thesis.toml --out results/thesis")]
    Run {
        /// The study file (TOML), e.g. studies/thesis.toml.
        study: PathBuf,
        /// Output directory (created if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Realisations per condition, overriding the study's `realisations`.
        #[arg(long, value_name = "N")]
        realisations: Option<u64>,
        /// Master seed, overriding the study's `seed`.
        #[arg(long, value_name = "S")]
        seed: Option<u64>,
        /// Worker threads (default: all cores). Results do not depend on it.
        #[arg(long, value_name = "T", value_parser = clap::value_parser!(u16).range(1..))]
        threads: Option<u16>,
        /// Run only shard K of N (0-based): realisations ⌊K·R/N⌋ … ⌊(K+1)·R/N⌋ − 1 of every
        /// condition, written to DIR/shard=K/realisations.parquet. Combine the shards with
        /// `chassis-mc summarize DIR`.
        #[arg(long, value_name = "K/N", value_parser = Shard::parse)]
        shard: Option<Shard>,
        /// Do not draw DIR/figures/*.svg.
        #[arg(long)]
        no_figures: bool,
        /// Print no table and no progress bar.
        #[arg(long)]
        quiet: bool,
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
    /// Redraw DIR/figures/*.svg from an output directory's summary.parquet and cycles.parquet.
    #[command(
        long_about = "Redraw DIR/figures/*.svg from DIR/summary.parquet and DIR/cycles.parquet.\n\n\
        Per parameter: se_<p>.svg (empirical SE ± MCSE and every bound against the terrain \
        metric ς, the thesis's Figures 4-6 and more), bias_<p>.svg, ratio_<p>.svg (EmpSE / \
        bound with its MCSE around 1) and coverage_<p>.svg (against the nominal 95 %); and \
        cycles.svg (speed and grade against time)."
    )]
    Figures {
        /// An output directory of `run` or `summarize`.
        dir: PathBuf,
    },
}

/// A failure with the exit code it maps to.
pub struct Failure {
    pub error: anyhow::Error,
    pub code: u8,
}

impl From<RunError> for Failure {
    fn from(e: RunError) -> Self {
        let code = match e {
            RunError::Study(_) | RunError::Output(OutputError::Locked { .. }) => EXIT_BAD_INPUT,
            RunError::Figures(FigureError::Study(_)) => EXIT_BAD_INPUT,
            RunError::Figures(FigureError::Output(OutputError::Locked { .. })) => EXIT_BAD_INPUT,
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
        let code = match e {
            FigureError::Study(_) | FigureError::Output(OutputError::Locked { .. }) => {
                EXIT_BAD_INPUT
            }
            _ => EXIT_FAILURE,
        };
        Failure {
            error: anyhow!(e),
            code,
        }
    }
}

/// Parse the command line (exits with status 2 on bad arguments, 0 for --help).
pub fn parse() -> Cli {
    Cli::parse()
}

struct Progress(ProgressBar);

impl Observer for Progress {
    fn planned(&self, total: u64, done: u64) {
        self.0.set_length(total);
        self.0.set_position(done);
        if done > 0 {
            self.0.suspend(|| {
                eprintln!(
                    "resuming: {done} of {total} realisations kept from an earlier run; computing {}",
                    total - done
                )
            });
        }
    }

    fn realisations_done(&self, count: u64) {
        self.0.inc(count);
    }

    fn notice(&self, message: &str) {
        self.0.suspend(|| eprintln!("{message}"));
    }
}

/// Execute a parsed command.
pub fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Run {
            study,
            out,
            realisations,
            seed,
            threads,
            shard,
            no_figures,
            quiet,
        } => {
            let study = Study::load(&study)
                .and_then(|s| s.with_overrides(realisations, seed))
                .map_err(RunError::from)?;
            let mut options = RunOptions::new(out);
            options.threads = threads.map(usize::from);
            options.shard = shard;
            options.figures = !no_figures;
            let conditions = study.condition_count();
            let total = conditions as u64 * study.realisations;
            let bar = if quiet {
                ProgressBar::hidden()
            } else {
                ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr())
            };
            bar.set_style(
                ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {human_pos}/{human_len} realisations ({per_sec}, eta {eta})",
                )
                .expect("valid progress template"),
            );
            let started = Instant::now();
            let report = run_study(&study, &options, &Progress(bar.clone()))?;
            bar.finish_and_clear();
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
                    conditions,
                    study.realisations,
                    started.elapsed().as_secs_f64()
                );
                for f in &report.files {
                    println!("  {}", f.display());
                }
            }
            Ok(())
        }
        Command::Summarize {
            inputs,
            out,
            no_figures,
            quiet,
        } => {
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
        Command::Figures { dir } => {
            for f in figures::draw(&dir)? {
                println!("{}", f.display());
            }
            Ok(())
        }
    }
}
