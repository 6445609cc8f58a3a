//! A fixed number of runs (SAE J2263, 40 CFR 1066.310: 16 runs, 8 each way): the campaign
//! passes when it has at least that many runs, half each way (a coast-down's runs alternate
//! direction, docs/model.md#coastdown, so n even runs are n/2 each way).

use super::{CoastTimes, Criterion, CriterionEntry, Verdict};

/// The fewest runs of SAE J2263 and 40 CFR 1066.310.
pub const RUN_COUNT_MIN_RUNS: f64 = 16.0;

/// The run-count criterion.
#[derive(Debug, Clone, PartialEq)]
pub struct RunCount {
    /// The fewest runs accepted (even: half each way).
    pub min_runs: usize,
}

impl Criterion for RunCount {
    fn name(&self) -> &'static str {
        ENTRY.name
    }

    fn reads_times(&self) -> bool {
        false
    }

    fn judge(&self, runs: usize, _times: &CoastTimes) -> Verdict {
        Verdict {
            passes: runs >= self.min_runs && runs.is_multiple_of(2),
            precision: f64::NAN,
        }
    }
}

/// The entry: `criterion = "run_count"`, key `min_runs`.
pub(super) static ENTRY: CriterionEntry = CriterionEntry {
    name: "run_count",
    description: "a fixed number of runs, half each way (SAE J2263, 40 CFR 1066.310: 16)",
    keys: &[("min_runs", RUN_COUNT_MIN_RUNS)],
    make: |values| {
        let min_runs = values[0];
        if !(min_runs >= 2.0
            && min_runs.fract() == 0.0
            && (min_runs / 2.0).fract() == 0.0
            && min_runs < 1e6)
        {
            return Err((
                "min_runs",
                format!("must be an even whole number of runs (half each way), got {min_runs}"),
            ));
        }
        Ok(Box::new(RunCount {
            min_runs: min_runs as usize,
        }))
    },
};
