//! A campaign's pass probability (docs/model.md#campaign): the share of a condition's
//! realisations whose campaign passes, from their `campaign_pass` column.

use super::super::measures::Estimate;

/// The verdicts of one estimator's rows of a condition.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct CampaignAcc {
    /// Rows with a verdict.
    n: u64,
    /// Those that pass.
    passed: u64,
}

impl CampaignAcc {
    /// Take one row's `campaign_pass` (1 pass, 0 fail, NaN none).
    pub(super) fn add(&mut self, pass: f64) {
        if !pass.is_nan() {
            self.n += 1;
            self.passed += u64::from(pass == 1.0);
        }
    }

    /// The share that passes, p, and its binomial MCSE √(p(1 − p)/n) (`None` without a
    /// verdict).
    pub(super) fn finish(self) -> Option<Estimate> {
        (self.n > 0).then(|| {
            let p = self.passed as f64 / self.n as f64;
            Estimate::new(p, (p * (1.0 - p) / self.n as f64).sqrt())
        })
    }
}
