//! A coast-down campaign's pass or fail under a standard's criterion on its runs
//! (docs/model.md#campaign): the coast-down time of each run through each speed interval,
//! read from the measured speed, and the criteria, one typed entry per file of this module
//! ([`CRITERIA`]).
//!
//! The coast-down time of run i in interval j is the time between the measured speed's
//! first crossings, going down, of v_j + Δv and then of v_j − Δv, each interpolated
//! linearly between the two samples around it. A run that does not cross both (it starts
//! below v_j + Δv, or its samples end above v_j − Δv) has no time there (NaN), and a
//! campaign with a missing time fails: the test would have to be driven again.

mod eu_precision;
mod run_count;

use std::fmt;

pub use eu_precision::{EU_MAX_PRECISION, EU_MIN_RUNS, EuPrecision, student_t_975};
pub use run_count::{RUN_COUNT_MIN_RUNS, RunCount};

/// The realisation column of a campaign's pass (1) or fail (0), the same in every
/// estimator's row; the summary's `pass_probability` is its mean.
pub const CAMPAIGN_PASS: &str = "campaign_pass";

/// One speed interval of a campaign: v_j ± Δv \[m/s\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedInterval {
    /// Its centre v_j \[m/s\].
    pub speed_m_s: f64,
    /// Its half width Δv \[m/s\].
    pub half_width_m_s: f64,
}

impl SpeedInterval {
    /// The upper edge v_j + Δv \[m/s\], where the run's time through it starts.
    pub fn upper(&self) -> f64 {
        self.speed_m_s + self.half_width_m_s
    }

    /// The lower edge v_j − Δv \[m/s\], where it ends.
    pub fn lower(&self) -> f64 {
        self.speed_m_s - self.half_width_m_s
    }
}

/// The coast-down times of a campaign: `n` runs × the intervals, run-major \[s\] (NaN where a
/// run does not cross an interval's edges).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CoastTimes {
    /// `times[i · intervals + j]`: run i's time through interval j \[s\].
    pub times: Vec<f64>,
    /// The number of intervals.
    pub intervals: usize,
    /// The number of runs.
    pub runs: usize,
}

impl CoastTimes {
    /// Interval `j`'s times, one per run.
    pub fn interval(&self, j: usize) -> impl Iterator<Item = f64> + '_ {
        (0..self.runs).map(move |i| self.times[i * self.intervals + j])
    }

    /// Measure the coast-down times of the first `runs` runs from samples at times `t_s`
    /// \[s\] of runs `run` (each run's samples consecutive and in time order), whose
    /// measured speed at sample k is `speed(k)` \[m/s\]. Samples of a run not below `runs`
    /// are ignored.
    pub fn measure(
        t_s: &[f64],
        run: &[u32],
        speed: impl Fn(usize) -> f64,
        runs: usize,
        intervals: &[SpeedInterval],
    ) -> CoastTimes {
        let m = intervals.len();
        let mut times = vec![f64::NAN; runs * m];
        let mut start = 0;
        while start < t_s.len() {
            let i = run[start] as usize;
            let end = start
                + run[start..]
                    .iter()
                    .take_while(|&&r| r == run[start])
                    .count();
            if i < runs {
                for (j, interval) in intervals.iter().enumerate() {
                    times[i * m + j] =
                        time_through(&t_s[start..end], |k| speed(start + k), interval);
                }
            }
            start = end;
        }
        CoastTimes {
            times,
            intervals: m,
            runs,
        }
    }
}

/// The time of one run's samples (times `t_s`, measured speeds `speed(k)`) between its first
/// downward crossing of the interval's upper edge and its first crossing of the lower edge
/// after it \[s\]; NaN when it crosses not both.
fn time_through(t_s: &[f64], speed: impl Fn(usize) -> f64, interval: &SpeedInterval) -> f64 {
    let crossing = |from: usize, level: f64| -> Option<(usize, f64)> {
        // The first sample at or below the level that has a sample above it just before;
        // none when the run starts at or below it.
        if from == 0 && t_s.first().is_some_and(|_| speed(0) <= level) {
            return None;
        }
        let k = (from.max(1)..t_s.len()).find(|&k| speed(k) <= level)?;
        let (a, b) = (speed(k - 1), speed(k));
        if a <= level {
            // The run starts at or below the level: not a crossing.
            return None;
        }
        let fraction = (a - level) / (a - b);
        Some((k, t_s[k - 1] + fraction * (t_s[k] - t_s[k - 1])))
    };
    let Some((k, upper)) = crossing(0, interval.upper()) else {
        return f64::NAN;
    };
    match crossing(k, interval.lower()) {
        Some((_, lower)) => lower - upper,
        None => f64::NAN,
    }
}

/// What a criterion concludes of one campaign.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// Whether the campaign passes.
    pub passes: bool,
    /// The criterion's figure of merit where it has one: for a precision criterion, the
    /// worst interval's statistical accuracy p (a fraction of the mean time); NaN otherwise.
    pub precision: f64,
}

/// A standard's criterion on a campaign's runs.
pub trait Criterion: fmt::Debug + Send + Sync {
    /// Its name in a study (`campaign.criterion`).
    fn name(&self) -> &'static str;

    /// Whether it reads the coast-down times (else only the number of runs): a study then
    /// gives the speed intervals.
    fn reads_times(&self) -> bool;

    /// Judge a campaign of `runs` runs, `times` its coast-down times (empty when the
    /// criterion does not read them).
    fn judge(&self, runs: usize, times: &CoastTimes) -> Verdict;
}

/// A key of `[campaign]` with a bad value, and why.
pub type KeyError = (&'static str, String);

/// How an entry makes its criterion from its keys' values.
pub type MakeCriterion = fn(&[f64]) -> Result<Box<dyn Criterion>, KeyError>;

/// A criterion as a study names it: its name, what it is, its own keys of `[campaign]`
/// with their defaults, and how it is made from their values.
#[derive(Debug)]
pub struct CriterionEntry {
    /// `campaign.criterion`.
    pub name: &'static str,
    /// One line: the standard and its rule.
    pub description: &'static str,
    /// Its own keys and their defaults.
    pub keys: &'static [(&'static str, f64)],
    /// Make it from its keys' values (in the order of `keys`); an error names the key.
    pub make: MakeCriterion,
}

/// Every criterion a study can name.
pub static CRITERIA: [&CriterionEntry; 2] = [&eu_precision::ENTRY, &run_count::ENTRY];

/// A campaign: its criterion and, when the criterion reads them, the speed intervals.
#[derive(Debug)]
pub struct Campaign {
    /// The criterion.
    pub criterion: Box<dyn Criterion>,
    /// The speed intervals (empty when the criterion does not read the times).
    pub intervals: Vec<SpeedInterval>,
}

impl Campaign {
    /// The verdict on the first `runs` runs of samples at `t_s` of runs `run` whose measured
    /// speed at sample k is `speed(k)`.
    pub fn judge(
        &self,
        t_s: &[f64],
        run: &[u32],
        speed: impl Fn(usize) -> f64,
        runs: usize,
    ) -> Verdict {
        let times = match self.criterion.reads_times() {
            true => CoastTimes::measure(t_s, run, speed, runs, &self.intervals),
            false => CoastTimes::default(),
        };
        self.criterion.judge(runs, &times)
    }
}

#[cfg(test)]
mod tests;
