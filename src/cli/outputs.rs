//! The commands that write or redraw a run's output set: `run`, `summarize` and `figures`.

use std::path::PathBuf;
use std::time::Instant;

use crate::figures;
use crate::run::{RunOptions, run_study};

use super::args::{FiguresArgs, RunArgs, SummarizeArgs, output_directory};
use super::failure::Failure;
use super::progress::Progress;
use super::replications::{check_targets, plan_replications};

/// `run`: the study's realisations, summary, cycles and figures into `--out`.
pub fn run(args: RunArgs) -> Result<(), Failure> {
    let RunArgs {
        study,
        out,
        overrides,
        shard,
        no_figures,
        quiet,
        replications_for,
    } = args;
    output_directory("--out", &out)?;
    let study = overrides.load(&study)?;
    check_targets(&crate::model::layout_of(&study), &replications_for)?;
    if let Some(shard) = shard
        && shard.range(study.realisations()).is_empty()
    {
        return Err(Failure::bad_argument(format!(
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
    if let Some(shard) = shard {
        println!(
            "shard {shard}: {} realisations computed, {} kept; wrote {}",
            report.computed,
            report.reused,
            report.files[0].display()
        );
        println!("when every shard is done: chassis-mc summarize <DIR>");
    } else {
        print!(
            "{}",
            crate::report::table(&report.layout, &report.infos, &report.summary)
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
    );
    Ok(())
}

/// `summarize`: the summary (and cycles, figures) of realisation files.
pub fn summarize(args: SummarizeArgs) -> Result<(), Failure> {
    let SummarizeArgs {
        inputs,
        out,
        no_figures,
        quiet,
    } = args;
    if let Some(out) = &out {
        output_directory("--out", out)?;
    }
    let out = out.unwrap_or_else(|| inputs[0].clone());
    let out = if out.is_file() {
        out.parent().map(PathBuf::from).unwrap_or_default()
    } else {
        out
    };
    let report = crate::run::summarize(&inputs, &out, !no_figures)?;
    if !quiet {
        print!(
            "{}",
            crate::report::table(&report.layout, &report.infos, &report.summary)
        );
        for f in &report.files {
            println!("  {}", f.display());
        }
    }
    Ok(())
}

/// `figures`: redraw an output directory's figures.
pub fn figures(args: FiguresArgs) -> Result<(), Failure> {
    for f in figures::draw(&args.dir)? {
        println!("{}", f.display());
    }
    Ok(())
}
