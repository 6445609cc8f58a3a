//! Figures from every run: SVG files drawn with plotters from the Parquet outputs.
//!
//! The thesis's result is a set of plots (its Figures 4–6: each parameter's error bound
//! against the terrain metric ς). This module draws those next to what the thesis could
//! not show — the real spread with its Monte Carlo error bars, the bias, EmpSE/bound and
//! coverage — and the drive cycles. It reads `summary.parquet` (and `cycles.parquet`), so
//! `chassis-mc figures DIR` redraws any run's figures, and `run` draws them the same way.
//!
//! Per parameter p (for the vehicle: `inv_mass`, `drag_over_mass`, `rolling_resistance`):
//!
//! | file | shows |
//! |---|---|
//! | `se_<p>.svg` | EmpSE ± MCSE (circles) and every applicable bound (lines) against ς, log scale |
//! | `bias_<p>.svg` | bias ± MCSE against ς, per estimator, with the zero line |
//! | `ratio_<p>.svg` | EmpSE / bound ± MCSE against ς, with the line at 1, log scale |
//! | `coverage_<p>.svg` | coverage of θ̂ ± 1.96·bound ± MCSE, with the nominal 95 % |
//!
//! and `cycles.svg`: speed and grade against time, one line per distinct terrain scale (at
//! most 12), the samples the regression leaves out in grey; read in batches, so its memory
//! does not grow with the number of conditions.
//! Each plotted condition × estimator (× bound) is one circle marker.

mod axis;
mod chart;
mod cycles;
mod fleet;
mod parameters;
mod tradeoff;

use std::fs;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use thiserror::Error;

use crate::model::Layout;
use crate::output::lock::DirLock;
use crate::output::{self, OutputError, PendingFile, SummaryTable, files, keys, set};
use crate::study::{Study, StudyError};

use cycles::draw_cycles;
use parameters::{draw_parameter, group_labels, x_axis};

/// Directory of the figures inside an output directory.
pub const FIGURES: &str = "figures";

/// The 95 % nominal coverage.
const NOMINAL: f64 = 0.95;
/// Figure size [px].
const SIZE: (u32, u32) = (1200, 620);
/// Width kept on the right of the plot for the legend [px].
const LEGEND_WIDTH: u32 = 280;
/// Most points drawn per cycle line (the cycles are decimated to this).
const MAX_CYCLE_POINTS: usize = 1500;

/// Why figures could not be drawn.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FigureError {
    /// Reading the Parquet outputs failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The study in the files' footer is not valid.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// The directory holds no run's output (no summary.parquet).
    #[error("{0}: not an output directory of `run` or `summarize` (it has no summary.parquet)")]
    NotAnOutputDirectory(PathBuf),
    /// Drawing or writing an SVG failed.
    #[error("{path}: {reason}")]
    Draw {
        /// The figure.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
}

impl FigureError {
    /// Whether the cause is the user's input (exit status 2 at the command line): an invalid
    /// study in the footer, a directory that holds no run's output, or one that cannot be
    /// used as it is ([`OutputError::is_bad_input`]); otherwise a failure while running.
    pub fn is_bad_input(&self) -> bool {
        match self {
            FigureError::Study(_) | FigureError::NotAnOutputDirectory(_) => true,
            FigureError::Output(e) => e.is_bad_input(),
            FigureError::Draw { .. } => false,
        }
    }
}

fn draw_error(path: &Path, e: impl std::fmt::Display) -> FigureError {
    FigureError::Draw {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// Every name (under [`FIGURES`]) a figure of a summary with `layout` may take: each
/// parameter's standard error, bias, ratio, coverage and trade-off figures (one per
/// estimator and one comparing two) and, with `cycles`, the drive cycles'. Which of them are
/// drawn depends on the results; a run checks all of them for a user's file before it
/// starts, so that such a file cannot stop its commit after the work is done.
pub fn possible_names(layout: &Layout, cycles: bool) -> Vec<String> {
    if crate::stats::fleet::is_fleet(layout) {
        return fleet::possible_names(layout);
    }
    let mut names = Vec::new();
    for p in &layout.parameters {
        for figure in ["se", "bias", "ratio", "coverage", "tradeoff"] {
            names.push(format!("{figure}_{}.svg", p.name));
        }
        for est in &layout.estimators {
            names.push(format!("tradeoff_{}_{est}.svg", p.name));
        }
    }
    if cycles {
        names.push("cycles.svg".into());
    }
    names
}

/// Redraw the figures of the output directory `dir` from its summary and cycles into
/// `dir/figures/`, replacing the figures of its output set together (a user's own files
/// there stay). Returns the files written.
pub fn draw(dir: &Path) -> Result<Vec<PathBuf>, FigureError> {
    if !dir.exists() {
        return Err(OutputError::Missing {
            path: dir.to_path_buf(),
        }
        .into());
    }
    if !dir.is_dir() {
        return Err(FigureError::NotAnOutputDirectory(dir.to_path_buf()));
    }
    // Locked first: a run writing `dir` is named, whatever it has written so far.
    let _lock = DirLock::acquire(dir)?;
    set::ensure_complete(dir)?;
    let summary = dir.join(files::SUMMARY);
    if !summary.is_file() {
        return Err(FigureError::NotAnOutputDirectory(dir.to_path_buf()));
    }
    let cycles = dir.join(files::CYCLES);
    let cycles = cycles.exists().then_some(cycles.as_path());
    // Checked against the manifest before anything is drawn from them: a damaged file is
    // named as such, not drawn or reported as a Parquet error. (The lock keeps runs from
    // replacing them until the figures are committed.)
    for path in std::iter::once(summary.as_path()).chain(cycles) {
        set::open_checked(path).map_err(|e| match e {
            OutputError::Damaged {
                path,
                recorded,
                found,
                ..
            } => OutputError::Damaged {
                path,
                recorded,
                found,
                remedy: format!(
                    "run `chassis-mc summarize {}` (or the study) again to rewrite it",
                    dir.display()
                ),
            },
            other => other,
        })?;
    }
    let layout = layout_in_footer(&summary)?;
    let pending = draw_staged(dir, &layout, &summary, cycles)?;
    let written = set::commit(dir, pending, &|path| {
        path.starts_with(&format!("{FIGURES}/"))
    });
    let _ = fs::remove_dir_all(dir.join(output::temporary_name(FIGURES)));
    Ok(written?)
}

/// The layout of the run whose summary is at `summary_path`, from the study its footer
/// records (for `figures DIR`, which is given only a directory).
fn layout_in_footer(summary_path: &Path) -> Result<Layout, FigureError> {
    let footer = output::read_metadata(summary_path)?;
    let study_toml = footer
        .get(keys::STUDY)
        .ok_or_else(|| OutputError::format(summary_path, "no study in the footer"))?;
    let study = Study::from_toml_in(
        study_toml,
        &format!("{} (footer)", summary_path.display()),
        &output::footer_dir(&footer, summary_path),
    )?;
    Ok(crate::model::layout_of(&study))
}

/// Draw every figure of the summary at `summary_path` (and the cycles at `cycles_path`),
/// a run's with `layout`, into a staging directory inside `dir`. Returns the figures as
/// files to be committed to `dir/figures/` with the rest of the output set.
pub fn draw_staged(
    dir: &Path,
    layout: &Layout,
    summary_path: &Path,
    cycles_path: Option<&Path>,
) -> Result<Vec<PendingFile>, FigureError> {
    let summary = output::read_summary(summary_path, layout)?;
    let staging = dir.join(output::temporary_name(FIGURES));
    let _ = fs::remove_dir_all(&staging);
    fs::create_dir_all(&staging).map_err(|e| OutputError::io(&staging, e))?;
    let names = draw_into(&staging, layout, &summary, cycles_path);
    let target = dir.join(FIGURES);
    // Each drawn figure is removed again if it is never committed.
    let names = names.inspect_err(|_| {
        let _ = fs::remove_dir_all(&staging);
    })?;
    Ok(names
        .into_iter()
        .map(|n| PendingFile::new(staging.join(&n), target.join(&n)))
        .collect())
}

fn draw_into(
    dir: &Path,
    layout: &Layout,
    t: &SummaryTable,
    cycles: Option<&Path>,
) -> Result<Vec<String>, FigureError> {
    if crate::stats::fleet::is_fleet(layout) {
        return fleet::draw_fleet(dir, layout, t);
    }
    let x = x_axis(layout, t);
    let groups = group_labels(layout, t, &x);
    // One job per parameter (four figures each) and one for the cycles, in parallel.
    let (per_parameter, cycle_figure) = rayon::join(
        || {
            layout
                .parameters
                .par_iter()
                .enumerate()
                .map(|p| draw_parameter(dir, layout, t, &x, &groups, p))
                .collect::<Result<Vec<_>, _>>()
        },
        || match (cycles, layout.axes.iter().position(|a| a.name == "scale")) {
            (Some(cy), Some(a)) => draw_cycles(dir, t, cy, a).map(Some),
            _ => Ok(None),
        },
    );
    let mut names: Vec<String> = per_parameter?.into_iter().flatten().collect();
    names.extend(cycle_figure?);
    names.extend(tradeoff::draw_tradeoffs(dir, layout, t)?);
    Ok(names)
}

/// The figure of a `design` search: the measure against the varied key, its first-order
/// prediction as a line, the Monte Carlo evaluations as points with ±2 MCSE bars, and the
/// target as a dashed line. Written to `path`.
pub fn design_chart(
    path: &Path,
    titles: [&str; 3],
    predicted: &[(f64, f64)],
    simulated: &[(f64, f64, f64)],
    target: f64,
) -> Result<(), FigureError> {
    let [title, x_label, y_label] = titles;
    let series = [
        chart::Series {
            label: "first-order prediction".into(),
            color: chart::color(0),
            points: predicted.iter().map(|&(x, y)| (x, y, f64::NAN)).collect(),
            markers: false,
        },
        chart::Series {
            label: "Monte Carlo ± 2 MCSE".into(),
            color: chart::color(1),
            points: simulated.iter().map(|&(x, y, m)| (x, y, 2.0 * m)).collect(),
            markers: true,
        },
    ];
    let reference = [chart::Reference {
        y: target,
        label: format!("target {target:.3e}"),
    }];
    chart::chart(
        path,
        &chart::Axes {
            title,
            x_label,
            y_label,
            log_y: false,
        },
        &series,
        &reference,
    )
}
