//! EU Directive 70/220/EEC's coast-down precision (its Annex on the road-load
//! determination): at least 4 runs, and in every speed interval the statistical accuracy of
//! the mean coast-down time p = t·s/(√n · T̄) at most 2 %, s the SD of the n runs' times, T̄
//! their mean and t Student's two-sided 95 % quantile at n − 1 degrees of freedom.

use statrs::distribution::{ContinuousCDF, StudentsT};

use super::{CoastTimes, Criterion, CriterionEntry, Verdict};

/// The Directive's largest statistical accuracy p (2 %).
pub const EU_MAX_PRECISION: f64 = 0.02;

/// The Directive's fewest runs.
pub const EU_MIN_RUNS: f64 = 4.0;

/// Student's t two-sided 95 % quantile (the 0.975 quantile) at `dof` degrees of freedom.
pub fn student_t_975(dof: usize) -> f64 {
    StudentsT::new(0.0, 1.0, dof as f64)
        .map(|t| t.inverse_cdf(0.975))
        .unwrap_or(f64::NAN)
}

/// The precision criterion, with its limit and fewest runs.
#[derive(Debug, Clone, PartialEq)]
pub struct EuPrecision {
    /// The largest accepted p in every interval (a fraction of the mean time).
    pub max_precision: f64,
    /// The fewest runs accepted.
    pub min_runs: usize,
}

impl Criterion for EuPrecision {
    fn name(&self) -> &'static str {
        ENTRY.name
    }

    fn reads_times(&self) -> bool {
        true
    }

    fn judge(&self, runs: usize, times: &CoastTimes) -> Verdict {
        if runs < 2 {
            return Verdict {
                passes: false,
                precision: f64::NAN,
            };
        }
        let n = runs as f64;
        let t = student_t_975(runs - 1);
        let mut worst = f64::NEG_INFINITY;
        for j in 0..times.intervals {
            let mean = times.interval(j).sum::<f64>() / n;
            let ss: f64 = times.interval(j).map(|x| (x - mean) * (x - mean)).sum();
            let p = t * (ss / (n - 1.0)).sqrt() / (n.sqrt() * mean);
            // A missing time (NaN) makes the interval, and the campaign, fail.
            worst = if p.is_nan() { f64::NAN } else { worst.max(p) };
            if worst.is_nan() {
                break;
            }
        }
        Verdict {
            passes: runs >= self.min_runs && worst <= self.max_precision,
            precision: worst,
        }
    }
}

/// The entry: `criterion = "eu_70_220"`, keys `precision` and `min_runs`.
pub(super) static ENTRY: CriterionEntry = CriterionEntry {
    name: "eu_70_220",
    description: "EU Directive 70/220/EEC: at least min_runs runs, and in every speed interval \
                  t·s/(√n·T̄) ≤ precision (t Student's 95 % at n − 1)",
    keys: &[("precision", EU_MAX_PRECISION), ("min_runs", EU_MIN_RUNS)],
    make: |values| {
        let [precision, min_runs] = [values[0], values[1]];
        if !(precision > 0.0 && precision.is_finite()) {
            return Err((
                "precision",
                format!(
                    "must be a positive fraction of the mean time (0.02 is 2 %), got {precision}"
                ),
            ));
        }
        if !(min_runs >= 2.0 && min_runs.fract() == 0.0 && min_runs < 1e6) {
            return Err((
                "min_runs",
                format!(
                    "must be a whole number of runs, at least 2 (an SD needs two), got {min_runs}"
                ),
            ));
        }
        Ok(Box::new(EuPrecision {
            max_precision: precision,
            min_runs: min_runs as usize,
        }))
    },
};
