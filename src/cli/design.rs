//! `design`: the smallest (or largest) value of a key at which a target precision holds.

use crate::design::{DesignRequest, answer_sentence};

use super::args::{DesignArgs, Overrides, output_directory};
use super::failure::Failure;

/// `design`: search, print the answer and the files written; exit 1 if no value holds.
pub fn design(args: DesignArgs) -> Result<(), Failure> {
    let DesignArgs {
        study,
        vary,
        from,
        to,
        target,
        estimator,
        out,
        overrides,
    } = args;
    output_directory("--out", &out)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(overrides.threads().unwrap_or(0))
        .build()
        .map_err(|e| Failure::bad_argument(format!("--threads: {e}")))?;
    // A file that cannot be read is the study loader's error to report (naming the file).
    let text = std::fs::read_to_string(&study).unwrap_or_default();
    if crate::design::campaign::is_design_file(&text) {
        if vary.is_some()
            || from.is_some()
            || to.is_some()
            || target.is_some()
            || estimator.is_some()
        {
            return Err(Failure::bad_argument(format!(
                "{} is a design file: its [design] table gives the targets and choices; \
                 --vary, --from, --to, --target and --estimator are for a study",
                study.display()
            )));
        }
        return campaign(&study, out, &overrides, &pool);
    }
    let (Some(vary), Some(from), Some(to), Some(target)) = (vary, from, to, target) else {
        return Err(Failure::bad_argument(format!(
            "{} is a study: design needs --vary, --from, --to and --target (or a design file \
             with a [design] table)",
            study.display()
        )));
    };
    let study = overrides.load(&study)?;
    let request = DesignRequest {
        key: vary,
        from,
        to,
        target,
        estimator,
        out,
    };
    let result = pool.install(|| crate::design::design(&study, &request))?;
    println!(
        "{}",
        answer_sentence(&request, result.answer, result.answer_sd, result.neighbour)
    );
    let simulated = result.points.iter().filter(|p| p.simulated.is_some());
    let values = format!("{} values evaluated", result.points.len());
    let counts = (result.realisations, &values[..], simulated.count());
    finished(
        &result.estimator,
        counts,
        &result.files,
        result.answer.is_some(),
        "no value in the range meets the target",
    )
}

/// The last lines of a design: what was run, the files written, and the exit status (1
/// when there is no answer, with `none`).
fn finished(
    estimator: &str,
    (realisations, evaluated, simulated): (u64, &str, usize),
    files: &[std::path::PathBuf],
    answered: bool,
    none: &str,
) -> Result<(), Failure> {
    println!(
        "estimator {estimator}, {realisations} realisations per Monte Carlo evaluation, \
         {evaluated} ({simulated} by Monte Carlo); wrote:"
    );
    for f in files {
        println!("  {}", f.display());
    }
    match answered {
        true => Ok(()),
        false => Err(Failure::while_running(none)),
    }
}

/// `design FILE` with a design file.
fn campaign(
    file: &std::path::Path,
    out: std::path::PathBuf,
    overrides: &Overrides,
    pool: &rayon::ThreadPool,
) -> Result<(), Failure> {
    use crate::design::campaign::{Campaign, answer_sentence};
    let mut campaign = Campaign::load(file, out)?;
    campaign.study = overrides.apply(campaign.study)?;
    let result = pool.install(|| crate::design::campaign::campaign(&campaign))?;
    for line in &result.log {
        println!("{line}");
    }
    println!("{}", answer_sentence(&campaign, &result));
    let simulated = result.points.iter().filter(|p| p.simulated.is_some());
    let designs = format!("{} designs predicted", result.points.len());
    let counts = (result.realisations, &designs[..], simulated.count());
    finished(
        &result.estimator,
        counts,
        &result.files,
        result.answer.is_some(),
        "no design meets every target",
    )
}
