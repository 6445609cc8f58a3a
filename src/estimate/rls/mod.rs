//! `rls`: recursive least squares with exponential forgetting, run along the cycle (see
//! docs/model.md#rls).
//!
//! Computed in information form: the running sums A_t = λ A_{t−1} + x̃_t x̃_tᵀ and
//! b_t = λ b_{t−1} + x̃_t ỹ_t give the estimate θ̂_t = A_t⁻¹ b_t after every row, which is
//! what the covariance-form RLS update computes from an exact start, without its loss of
//! symmetry and its need for a large initial covariance. The reported estimate is θ̂ after
//! the last row, solved like OLS (with λ = 1 it is OLS); along the way only the 1/M
//! component is needed, for the settle time, and it comes from Cramer's rule without a
//! division, checked every 0.25 s of the cycle, or every four rows where they are further
//! apart (the sums run in four lanes).

use super::bounds::{Bound, BoundKind};
use super::estimators::{Estimate, Estimator, EstimatorSettings, Realisation};
use super::parameters::Parameters;
use super::row_sums::RowRead;

pub mod scan;

use scan::RlsTarget;

/// The band around the true 1/M within which the `rls` estimate counts as settled
/// (relative).
pub const SETTLE_BAND: f64 = 0.02;

/// What the kernel's scan of the rows needs for `rls` (docs/model.md#rls): the forgetting
/// λ, and the band of ±[`SETTLE_BAND`] around the true 1/M the settle time is scored in.
pub fn rls_target(settings: &EstimatorSettings, truth: &[f64; 3]) -> RlsTarget {
    RlsTarget {
        lambda: settings.forgetting,
        target: truth[0],
        band: SETTLE_BAND * truth[0].abs(),
    }
}

/// Recursive least squares with forgetting λ (`estimation.forgetting`).
#[derive(Debug, Clone, Copy)]
pub struct Rls;

impl Estimator for Rls {
    fn name(&self) -> &'static str {
        "rls"
    }

    fn description(&self) -> &'static str {
        "recursive least squares with forgetting λ run along the cycle: the estimate after the last row, and the time its 1/M settles within ±2 % of the truth"
    }

    fn reads(&self) -> RowRead {
        RowRead::Rls
    }

    fn reads_forgetting(&self) -> bool {
        true
    }

    fn estimate(&self, r: &Realisation<'_>) -> Estimate {
        let t = &r.regression.t;
        let (system, settle) = r.rls();
        Estimate {
            theta: r.settings.solve(&system),
            // With the mass known there is no 1/M estimate to settle.
            settle_time_s: settle
                .filter(|_| r.settings.parameters == Parameters::All)
                .map(|i| t[i] - t[0]),
            road_load: None,
        }
    }

    fn reports(&self, bound: &Bound, settings: &EstimatorSettings) -> bool {
        // With forgetting it weights the rows unequally: OLS's sandwich is not its spread.
        bound.kind != BoundKind::EivSandwich || settings.forgetting == 1.0
    }
}
