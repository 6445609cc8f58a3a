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

use std::sync::Arc;

use super::bounds::{Bound, BoundKind};
use super::estimator::{
    Estimate, EstimateColumn, Estimator, EstimatorSettings, Realisation, RowScan, ScanStart,
};
use super::moments::RowsView;
use super::parameters::Parameters;
use super::regression::Regression;

pub mod scan;

use scan::{RlsPlan, RlsScan, RlsTarget};

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

/// Its own column: the settle time (in every study's tables, NaN in other estimators'
/// rows).
static COLUMNS: [EstimateColumn; 1] = [EstimateColumn {
    name: "rls_settle_time",
    unit: "s",
    description: "rls only: time from the first row after which the 1/M estimate stays within ±2 % of its truth (null if never)",
    in_every_study: true,
}];

/// The kernel's scan of the rows for `rls` ([`RlsScan`]), made anew for each realisation.
#[derive(Debug)]
struct RlsRowScan(Option<RlsScan>);

impl RlsRowScan {
    fn finish(&self) -> scan::RlsResult {
        self.0
            .as_ref()
            .expect("the scan is reset before it is read")
            .finish()
    }
}

impl RowScan for RlsRowScan {
    /// Where `reg` serves many realisations (a condition's), the scan takes what they share
    /// from its plan ([`RlsPlan::shared`], made once); otherwise (a realisation's own
    /// regression) it sums every term itself, the same bits without a plan to make per
    /// realisation.
    fn reset(&mut self, reg: &Regression, start: &ScanStart<'_>) {
        let target = rls_target(start.settings, start.truth);
        let plan = match start.shared {
            true => RlsPlan::shared(reg, target.lambda),
            false => Arc::new(RlsPlan::new(&reg.t, None, target.lambda)),
        };
        self.0 = Some(RlsScan::new(
            reg.k,
            plan,
            target.target,
            target.band,
            reg.len(),
        ));
    }

    fn advance(&mut self, rows: RowsView<'_>, end: usize) {
        self.0
            .as_mut()
            .expect("the scan is reset before it advances")
            .advance(rows, end);
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

    fn scan(&self) -> Option<Box<dyn RowScan>> {
        Some(Box::new(RlsRowScan(None)))
    }

    fn columns(&self) -> &'static [EstimateColumn] {
        &COLUMNS
    }

    fn reads_forgetting(&self) -> bool {
        true
    }

    fn estimate(&self, r: &Realisation<'_>) -> Estimate {
        let t = &r.regression.t;
        let (system, settle) = r.scan::<RlsRowScan>().finish();
        // With the mass known there is no 1/M estimate to settle.
        let settle_time_s = settle
            .filter(|_| r.settings.parameters == Parameters::All)
            .map_or(f64::NAN, |i| t[i] - t[0]);
        Estimate::with_columns(r.settings.solve(&system), &[settle_time_s])
    }

    fn reports(&self, bound: &Bound, settings: &EstimatorSettings) -> bool {
        // With forgetting it weights the rows unequally: OLS's sandwich is not its spread.
        bound.kind != BoundKind::EivSandwich || settings.forgetting == 1.0
    }
}
