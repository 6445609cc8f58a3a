//! The measures of the estimates' first two moments about the truth (Morris, White &
//! Crowther 2019, Table 6): mean, bias, relative bias, empirical SE, MSE and RMSE.

use super::{MeasureInputs, SummaryMeasure};
use crate::stats::measures::{self, Estimate};

/// Mean of θ̂.
pub struct Mean;

impl SummaryMeasure for Mean {
    fn name(&self) -> &'static str {
        "mean"
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        measures::mean(m.truth, m.sums)
    }
}

/// Bias: mean − truth.
pub struct Bias;

impl SummaryMeasure for Bias {
    fn name(&self) -> &'static str {
        "bias"
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        measures::bias(m.sums)
    }
}

/// Relative bias: bias / truth.
pub struct RelBias;

impl SummaryMeasure for RelBias {
    fn name(&self) -> &'static str {
        "rel_bias"
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        measures::relative_bias(m.truth, m.sums)
    }
}

/// Empirical SE: the SD of θ̂ over realisations.
pub struct EmpSe;

impl SummaryMeasure for EmpSe {
    fn name(&self) -> &'static str {
        "emp_se"
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        measures::emp_se(m.sums)
    }
}

/// Mean squared error.
pub struct Mse;

impl SummaryMeasure for Mse {
    fn name(&self) -> &'static str {
        "mse"
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        measures::mse(m.sums)
    }
}

/// Root mean squared error.
pub struct Rmse;

impl SummaryMeasure for Rmse {
    fn name(&self) -> &'static str {
        "rmse"
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        measures::rmse(m.sums)
    }
}
