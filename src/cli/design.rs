//! `design`: the smallest (or largest) value of a key at which a target precision holds.

use crate::design::{DesignRequest, answer_sentence};

use super::args::{DesignArgs, output_directory};
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
        .map_err(|e| Failure::bad_argument(format!("--threads: {e}")))?;
    let result = pool.install(|| crate::design::design(&study, &request))?;
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
        return Err(Failure::while_running(
            "no value in the range meets the target",
        ));
    }
    Ok(())
}
