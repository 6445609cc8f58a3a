//! The measures by control variates (docs/model.md#control-variates): the mean and bias by
//! the control-variate regression with its variance ratio, and the spread by the second
//! moment's control variates (docs/model.md#spread-control-variates).

use super::{MeasureInputs, SummaryMeasure};
use crate::stats::measures::Estimate;

/// Mean of θ̂ by the control-variate regression.
pub struct MeanCv;

impl SummaryMeasure for MeanCv {
    fn name(&self) -> &'static str {
        "mean_cv"
    }
    fn by_control_variates(&self) -> bool {
        true
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        m.control.map_or_else(Estimate::undefined, |f| {
            Estimate::new(m.truth + f.bias, f.mcse)
        })
    }
}

/// Bias by the control-variate regression.
pub struct BiasCv;

impl SummaryMeasure for BiasCv {
    fn name(&self) -> &'static str {
        "bias_cv"
    }
    fn by_control_variates(&self) -> bool {
        true
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        m.control
            .map_or_else(Estimate::undefined, |f| Estimate::new(f.bias, f.mcse))
    }
}

/// Var(θ̂) / residual variance of the control-variate regression (no MCSE).
pub struct CvVarianceRatio;

impl SummaryMeasure for CvVarianceRatio {
    fn name(&self) -> &'static str {
        "cv_variance_ratio"
    }
    fn has_mcse(&self) -> bool {
        false
    }
    fn by_control_variates(&self) -> bool {
        true
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        Estimate::new(m.control.map_or(f64::NAN, |f| f.variance_ratio), f64::NAN)
    }
}

/// Empirical SE by the second moment's control variates.
pub struct EmpSeCv;

impl SummaryMeasure for EmpSeCv {
    fn name(&self) -> &'static str {
        "emp_se_cv"
    }
    fn by_control_variates(&self) -> bool {
        true
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        m.spread.emp_se
    }
}

/// Mean squared error by the second moment's control variates.
pub struct MseCv;

impl SummaryMeasure for MseCv {
    fn name(&self) -> &'static str {
        "mse_cv"
    }
    fn by_control_variates(&self) -> bool {
        true
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        m.spread.mse
    }
}

/// Root mean squared error by the second moment's control variates.
pub struct RmseCv;

impl SummaryMeasure for RmseCv {
    fn name(&self) -> &'static str {
        "rmse_cv"
    }
    fn by_control_variates(&self) -> bool {
        true
    }
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate {
        m.spread.rmse
    }
}
