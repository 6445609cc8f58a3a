//! The target of `design`: `PARAMETER:MEASURE<=VALUE`, a measure of one parameter's
//! estimates as a fraction of its true value, or `pass_probability>=VALUE`, the chance that
//! a coast-down campaign passes its criterion (docs/model.md#campaign).

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
    /// The share of realisations whose campaign passes (`pass_probability`), which must be
    /// at least the target; no parameter's.
    PassProbability,
}

impl DesignMeasure {
    const ALL: [DesignMeasure; 3] = [
        DesignMeasure::RelRmse,
        DesignMeasure::RelEmpSe,
        DesignMeasure::AbsRelBias,
    ];

    /// The name of [`DesignMeasure::PassProbability`].
    const PASS_PROBABILITY: &'static str = "pass_probability";

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DesignMeasure::RelRmse => "rel_rmse",
            DesignMeasure::RelEmpSe => "rel_emp_se",
            DesignMeasure::AbsRelBias => "abs_rel_bias",
            DesignMeasure::PassProbability => Self::PASS_PROBABILITY,
        }
    }

    /// Whether the measure is of one parameter's estimates (a fraction of its truth).
    pub fn of_parameter(self) -> bool {
        self != DesignMeasure::PassProbability
    }

    /// The measure from a bias and an SE.
    pub(super) fn of(self, bias: f64, se: f64, truth: f64) -> f64 {
        match self {
            DesignMeasure::RelRmse => bias.hypot(se) / truth.abs(),
            DesignMeasure::RelEmpSe => se / truth.abs(),
            DesignMeasure::AbsRelBias => bias.abs() / truth.abs(),
            // No first-order prediction: decided by Monte Carlo alone.
            DesignMeasure::PassProbability => f64::NAN,
        }
    }
}

/// `PARAMETER:MEASURE<=VALUE` or `pass_probability>=VALUE`.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignTarget {
    /// Index into θ (0, and unread, for `pass_probability`).
    pub parameter: usize,
    /// The measure.
    pub measure: DesignMeasure,
    /// Its largest acceptable value (a fraction of the truth), or, for `pass_probability`,
    /// its smallest.
    pub value: f64,
}

impl DesignTarget {
    /// Whether a measure of `m` meets the target: at most its value, or, for
    /// `pass_probability`, at least.
    pub fn holds(&self, m: f64) -> bool {
        match self.measure {
            DesignMeasure::PassProbability => m >= self.value,
            _ => m <= self.value,
        }
    }

    /// Parse `PARAMETER:MEASURE<=VALUE` or `pass_probability>=VALUE`.
    pub fn parse(text: &str) -> Result<DesignTarget, String> {
        let form = "expected PARAMETER:MEASURE<=VALUE, e.g. drag_over_mass:rel_rmse<=0.01, or \
                    pass_probability>=P, e.g. pass_probability>=0.95";
        if let Some(rest) = text.trim().strip_prefix(DesignMeasure::PASS_PROBABILITY) {
            let value = rest
                .trim()
                .strip_prefix(">=")
                .ok_or_else(|| format!("{form}; got \"{text}\""))?;
            let value: f64 = value
                .trim()
                .parse()
                .map_err(|_| format!("the target \"{value}\" is not a number"))?;
            if !(value > 0.0 && value <= 1.0) {
                return Err(format!(
                    "a pass probability target must be in (0, 1], got {value}"
                ));
            }
            return Ok(DesignTarget {
                parameter: 0,
                measure: DesignMeasure::PassProbability,
                value,
            });
        }
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
        if !self.measure.of_parameter() {
            return write!(f, "{}>={}", self.measure.name(), self.value);
        }
        write!(
            f,
            "{}:{}<={}",
            PARAMETERS[self.parameter],
            self.measure.name(),
            self.value
        )
    }
}
