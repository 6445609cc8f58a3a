//! How many realisations a target Monte Carlo standard error needs (Morris, White &
//! Crowther 2019, §5.3): every measure's MCSE falls as 1/√R, so from a pilot of R₀
//! realisations with MCSE s₀ the target s needs R = ⌈R₀ (s₀ / s)²⌉.

use super::columns::Measure;
use super::summary::SummaryRow;
use crate::study::MAX_REALISATIONS;

/// The measures of the summary whose MCSE can be planned: every one with an MCSE column.
pub fn measures() -> impl Iterator<Item = Measure> {
    Measure::ALL.iter().copied().filter(|m| m.has_mcse())
}

/// Their names, as `--replications-for` takes them.
pub fn measure_names() -> Vec<&'static str> {
    measures().map(Measure::name).collect()
}

/// A target `[PARAMETER:]MEASURE=MCSE` of `--replications-for`.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// Only this parameter (`None`: every parameter).
    pub parameter: Option<String>,
    /// One of [`measures`].
    pub measure: Measure,
    /// The wanted MCSE, in the measure's unit.
    pub mcse: f64,
}

impl Target {
    /// Parse `[PARAMETER:]MEASURE=MCSE`.
    pub fn parse(text: &str) -> Result<Target, String> {
        let (lhs, value) = text
            .split_once('=')
            .ok_or_else(|| format!("expected [PARAMETER:]MEASURE=MCSE, got \"{text}\""))?;
        let (parameter, measure) = match lhs.split_once(':') {
            Some((p, m)) => (Some(p.trim().to_string()), m.trim()),
            None => (None, lhs.trim()),
        };
        let Some(measure) = measures().find(|m| m.name() == measure) else {
            return Err(format!(
                "unknown measure \"{measure}\"; expected one of {:?}",
                measure_names()
            ));
        };
        let mcse: f64 = value
            .trim()
            .parse()
            .map_err(|_| format!("the MCSE \"{value}\" is not a number"))?;
        if !(mcse > 0.0 && mcse.is_finite()) {
            return Err(format!("the MCSE must be positive and finite, got {mcse}"));
        }
        Ok(Target {
            parameter,
            measure,
            mcse,
        })
    }
}

/// What a pilot run says about reaching a target MCSE.
#[derive(Debug, Clone, PartialEq)]
pub enum Plan<'a> {
    /// `realisations` per condition reach the target; `row` is the one that needs the most.
    Reach {
        /// Realisations per condition.
        realisations: u64,
        /// The row that needs them.
        row: &'a SummaryRow,
    },
    /// More realisations than a study accepts ([`MAX_REALISATIONS`]) would be needed.
    OutOfReach {
        /// The realisations per condition the target would need.
        needed: f64,
        /// The row that needs them.
        row: &'a SummaryRow,
        /// The smallest MCSE of that row reachable with [`MAX_REALISATIONS`].
        best_mcse: f64,
    },
    /// Every row the target covers has an MCSE of exactly 0 (e.g. `rel_precision` of the
    /// reference estimator against itself): the measure has no Monte Carlo error to plan.
    Exact,
    /// No row the target covers has a finite MCSE.
    Undefined,
}

/// The realisations `target` needs: the largest over the rows it covers (of parameters
/// named in `parameters`), and the row that needs them. Rows whose MCSE is exactly 0 carry
/// no Monte Carlo error and need none.
pub fn replications_for<'a>(
    rows: &'a [SummaryRow],
    parameters: &[&str],
    pilot_r: u64,
    target: &Target,
) -> Plan<'a> {
    let covered: Vec<(f64, &SummaryRow)> = rows
        .iter()
        .filter(|r| {
            target
                .parameter
                .as_deref()
                .is_none_or(|p| parameters.get(r.parameter) == Some(&p))
        })
        .filter_map(|r| {
            let m = r[target.measure];
            m.mcse.is_finite().then_some((m.mcse, r))
        })
        .collect();
    if covered.is_empty() {
        return Plan::Undefined;
    }
    let Some((mcse, row)) = covered
        .into_iter()
        .filter(|(m, _)| *m > 0.0)
        .max_by(|a, b| a.0.total_cmp(&b.0))
    else {
        return Plan::Exact;
    };
    let needed = pilot_r as f64 * (mcse / target.mcse).powi(2);
    if needed > MAX_REALISATIONS as f64 {
        return Plan::OutOfReach {
            needed,
            row,
            best_mcse: mcse * (pilot_r as f64 / MAX_REALISATIONS as f64).sqrt(),
        };
    }
    // A control-variate estimate is defined from q + 3 realisations on.
    let least = match target.measure.by_control_variates() {
        true => row.n_controls + 3,
        false => 2,
    };
    Plan::Reach {
        realisations: (needed.ceil() as u64).max(least),
        row,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_parse_with_and_without_a_parameter() {
        assert_eq!(
            Target::parse("drag_over_mass:bias=1e-9").unwrap(),
            Target {
                parameter: Some("drag_over_mass".into()),
                measure: Measure::Bias,
                mcse: 1e-9
            }
        );
        assert_eq!(Target::parse("emp_se=0.5").unwrap().parameter, None);
        assert!(
            Target::parse("coverage=0.01")
                .unwrap_err()
                .contains("unknown measure")
        );
        assert!(Target::parse("bias=-1").unwrap_err().contains("positive"));
        assert!(Target::parse("bias").unwrap_err().contains("expected"));
        assert_eq!(
            Target::parse("bias_cv=1e-12").unwrap().measure,
            Measure::BiasCv
        );
        assert!(
            Target::parse("cv_variance_ratio=0.1")
                .unwrap_err()
                .contains("unknown measure"),
            "a measure without an MCSE cannot be planned"
        );
    }
}
