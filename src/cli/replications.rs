//! `run --replications-for`: each target checked against the study before the run, and
//! after it the realisations per condition the target needs, planned from the run as a
//! pilot (see `stats::plan`).

use crate::model::Layout;
use crate::run::RunReport;
use crate::stats::columns::Measure;
use crate::stats::plan::{Plan, Target, replications_for};
use crate::stats::summary::SummaryRow;
use crate::study::MAX_REALISATIONS;

use super::failure::Failure;
use super::progress::human_duration;

/// Check that every target names a parameter of `layout` (before the run).
pub fn check_targets(layout: &Layout, targets: &[Target]) -> Result<(), Failure> {
    let parameters: Vec<&str> = layout.parameters.iter().map(|p| p.name).collect();
    for target in targets {
        if let Some(p) = &target.parameter
            && !parameters.contains(&p.as_str())
        {
            return Err(Failure::bad_argument(format!(
                "--replications-for: unknown parameter \"{p}\"; expected one of {parameters:?}"
            )));
        }
    }
    Ok(())
}

/// Print, for each target, the realisations it needs and the time they take at the pace of
/// the run just done (`seconds` for `pilot_r` realisations per condition).
pub fn plan_replications(report: &RunReport, targets: &[Target], pilot_r: u64, seconds: f64) {
    let parameters: Vec<&str> = report.layout.parameters.iter().map(|p| p.name).collect();
    for target in targets {
        let what = format!(
            "{}{} MCSE {:e}",
            target
                .parameter
                .as_deref()
                .map_or(String::new(), |p| format!("{p}:")),
            target.measure.name(),
            target.mcse
        );
        let pace = |r: f64| {
            human_duration(std::time::Duration::from_secs_f64(
                (seconds * r / pilot_r as f64).min(1e18),
            ))
        };
        let at = |row: &SummaryRow| {
            format!(
                "condition {}, {}, {}",
                row.condition, report.layout.estimators[row.estimator], parameters[row.parameter]
            )
        };
        match replications_for(&report.summary, &parameters, pilot_r, target) {
            Plan::Reach { realisations, row } => {
                let current = row[target.measure].mcse;
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
                let current = row[target.measure].mcse;
                println!(
                    "replications for {what}: out of reach: it would take R ≈ {needed:.2e} per \
                     condition (now {pilot_r}, MCSE {current:.3e} at {}), more than the \
                     {MAX_REALISATIONS} a study accepts, and about {} at this run's pace; the \
                     smallest MCSE reachable there is {best_mcse:.3e}",
                    at(row),
                    pace(needed)
                );
            }
            Plan::Exact if target.measure == Measure::RelPrecision => println!(
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
                target.measure.name()
            ),
            Plan::Undefined => {
                println!("replications for {what}: no finite MCSE in this run to plan from")
            }
        }
    }
}
