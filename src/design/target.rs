//! The target of `design`: `PARAMETER:MEASURE<=VALUE`, a measure of one parameter's
//! estimates as a fraction of its true value.

use std::fmt;

use crate::model::vehicle::PARAMETERS;

/// A measure `design` can target, as a fraction of the parameter's true value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DesignMeasure {
    /// RMSE / |θ|.
    RelRmse,
    /// EmpSE / |θ|.
    RelEmpSe,
    /// |bias| / |θ|.
    AbsRelBias,
}

impl DesignMeasure {
    const ALL: [DesignMeasure; 3] = [
        DesignMeasure::RelRmse,
        DesignMeasure::RelEmpSe,
        DesignMeasure::AbsRelBias,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DesignMeasure::RelRmse => "rel_rmse",
            DesignMeasure::RelEmpSe => "rel_emp_se",
            DesignMeasure::AbsRelBias => "abs_rel_bias",
        }
    }

    /// The measure from a bias and an SE.
    pub(super) fn of(self, bias: f64, se: f64, truth: f64) -> f64 {
        match self {
            DesignMeasure::RelRmse => bias.hypot(se) / truth.abs(),
            DesignMeasure::RelEmpSe => se / truth.abs(),
            DesignMeasure::AbsRelBias => bias.abs() / truth.abs(),
        }
    }
}

/// `PARAMETER:MEASURE<=VALUE`.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignTarget {
    /// Index into θ.
    pub parameter: usize,
    /// The measure.
    pub measure: DesignMeasure,
    /// Its largest acceptable value (a fraction of the truth).
    pub value: f64,
}

impl DesignTarget {
    /// Parse `PARAMETER:MEASURE<=VALUE`.
    pub fn parse(text: &str) -> Result<DesignTarget, String> {
        let form = "expected PARAMETER:MEASURE<=VALUE, e.g. drag_over_mass:rel_rmse<=0.01";
        let (lhs, value) = text
            .split_once("<=")
            .ok_or_else(|| format!("{form}; got \"{text}\""))?;
        let (parameter, measure) = lhs
            .split_once(':')
            .ok_or_else(|| format!("{form}; got \"{text}\""))?;
        let parameter = PARAMETERS
            .iter()
            .position(|p| *p == parameter.trim())
            .ok_or_else(|| {
                format!("unknown parameter \"{parameter}\"; expected one of {PARAMETERS:?}")
            })?;
        let measure = DesignMeasure::ALL
            .into_iter()
            .find(|m| m.name() == measure.trim())
            .ok_or_else(|| {
                let names: Vec<&str> = DesignMeasure::ALL.map(DesignMeasure::name).to_vec();
                format!("unknown measure \"{measure}\"; expected one of {names:?}")
            })?;
        let value: f64 = value
            .trim()
            .parse()
            .map_err(|_| format!("the target \"{value}\" is not a number"))?;
        if !(value > 0.0 && value.is_finite()) {
            return Err(format!(
                "the target must be positive and finite, got {value}"
            ));
        }
        Ok(DesignTarget {
            parameter,
            measure,
            value,
        })
    }
}

impl fmt::Display for DesignTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}<={}",
            PARAMETERS[self.parameter],
            self.measure.name(),
            self.value
        )
    }
}
