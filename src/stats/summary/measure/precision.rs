//! Precision relative to the reference estimator (OLS when run).

use super::{MeasureInputs, SummaryMeasure};
use crate::stats::measures::{Estimate, relative_precision};

/// Precision relative to the reference estimator, 100((S_ref/S)² − 1) [%].
pub struct RelPrecision;

impl SummaryMeasure for RelPrecision {
    fn name(&self) -> &'static str {
        "rel_precision"
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        relative_precision(m.reference, m.sums, m.sum_cross_reference)
    }
}
