//! The columns of `summary.parquet`, named once.
//!
//! [`SummaryColumn::all`] is the one definition of the summary table: the Parquet writer
//! builds its schema and arrays from it, the typed decoder reads rows back through it, and
//! the figures and the printed table get every measure from a [`SummaryRow`] through
//! [`Measure`] and [`BoundMeasure`] — no column name is spelled anywhere else, so renaming
//! one is a compile-time change here.

use super::measures::Estimate;
pub use super::summary::Measure;
use super::summary::filter::{FilterMeasure, INPUTS};
use super::summary::{BoundSummary, SummaryRow};
use crate::estimate::campaign::CAMPAIGN_PASS;
use crate::model::Layout;

/// A measure of one bound B in a summary row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoundMeasure {
    /// `B_se`: √ of the mean per-realisation variance.
    Se,
    /// `emp_over_B`: EmpSE / B_se.
    EmpOver,
    /// `B_rel_error`: 100 (B_se / EmpSE − 1) [%].
    RelError,
    /// `coverage_B`: of the truth by θ̂ ± z·B.
    Coverage,
    /// `be_coverage_B`: of the mean θ̄ by θ̂ ± z·B.
    BeCoverage,
    /// `B_chi2_p`: p-value of the variance-ratio test (no MCSE).
    Chi2P,
    /// `emp_over_B_cv`: EmpSE / B_se with the control-variate EmpSE.
    EmpOverCv,
    /// `B_p_cv`: p-value of the variance-ratio test with the control-variate variance
    /// (normal; no MCSE).
    PCv,
}

impl BoundMeasure {
    /// Every bound measure, in column order.
    pub const ALL: [BoundMeasure; 8] = [
        BoundMeasure::Se,
        BoundMeasure::EmpOver,
        BoundMeasure::RelError,
        BoundMeasure::Coverage,
        BoundMeasure::BeCoverage,
        BoundMeasure::Chi2P,
        BoundMeasure::EmpOverCv,
        BoundMeasure::PCv,
    ];

    /// Column name of the value for bound `bound`.
    pub fn column(self, bound: &str) -> String {
        match self {
            BoundMeasure::Se => format!("{bound}_se"),
            BoundMeasure::EmpOver => format!("emp_over_{bound}"),
            BoundMeasure::RelError => format!("{bound}_rel_error"),
            BoundMeasure::Coverage => format!("coverage_{bound}"),
            BoundMeasure::BeCoverage => format!("be_coverage_{bound}"),
            BoundMeasure::Chi2P => format!("{bound}_chi2_p"),
            BoundMeasure::EmpOverCv => format!("emp_over_{bound}_cv"),
            BoundMeasure::PCv => format!("{bound}_p_cv"),
        }
    }

    /// Whether it has an MCSE column.
    pub fn has_mcse(self) -> bool {
        !matches!(self, BoundMeasure::Chi2P | BoundMeasure::PCv)
    }

    /// Its value and MCSE (NaN where it has none).
    pub fn of(self, s: &BoundSummary) -> Estimate {
        match self {
            BoundMeasure::Se => s.se,
            BoundMeasure::EmpOver => s.emp_over,
            BoundMeasure::RelError => s.rel_error,
            BoundMeasure::Coverage => s.coverage,
            BoundMeasure::BeCoverage => s.be_coverage,
            BoundMeasure::Chi2P => Estimate::new(s.chi2_p, f64::NAN),
            BoundMeasure::EmpOverCv => s.emp_over_cv,
            BoundMeasure::PCv => Estimate::new(s.p_cv, f64::NAN),
        }
    }

    fn set(self, s: &mut BoundSummary, part: Part, v: f64) {
        let target = match self {
            BoundMeasure::Se => &mut s.se,
            BoundMeasure::EmpOver => &mut s.emp_over,
            BoundMeasure::RelError => &mut s.rel_error,
            BoundMeasure::Coverage => &mut s.coverage,
            BoundMeasure::BeCoverage => &mut s.be_coverage,
            BoundMeasure::Chi2P => {
                s.chi2_p = v;
                return;
            }
            BoundMeasure::EmpOverCv => &mut s.emp_over_cv,
            BoundMeasure::PCv => {
                s.p_cv = v;
                return;
            }
        };
        part.set(target, v);
    }
}

/// The value of a measure, or its Monte Carlo standard error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// The measure.
    Value,
    /// Its MCSE (column name `<measure>_mcse`).
    Mcse,
}

impl Part {
    fn get(self, e: Estimate) -> f64 {
        match self {
            Part::Value => e.value,
            Part::Mcse => e.mcse,
        }
    }

    fn set(self, e: &mut Estimate, v: f64) {
        match self {
            Part::Value => e.value = v,
            Part::Mcse => e.mcse = v,
        }
    }

    fn suffix(self) -> &'static str {
        match self {
            Part::Value => "",
            Part::Mcse => "_mcse",
        }
    }
}

/// One column of `summary.parquet`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SummaryColumn {
    /// `condition` (int32).
    Condition,
    /// Condition axis `i` of the layout (its own name and type).
    Axis(usize),
    /// Condition metric `i` of the layout (f64).
    Metric(usize),
    /// `estimator` (text).
    Estimator,
    /// `parameter` (text).
    Parameter,
    /// `truth` (f64).
    Truth,
    /// `bias_model` (f64): the noise-free estimate minus the truth.
    BiasModel,
    /// `n`: realisations with a valid estimate (int64).
    N,
    /// `n_failed`: realisations where the estimator failed (int64).
    NFailed,
    /// `n_controls`: control variates in the regression estimates `*_cv` (int64; 0 where
    /// none applies).
    NControls,
    /// A measure or its MCSE (f64, null where undefined).
    Measure(Measure, Part),
    /// A measure of bound `b` of the layout, or its MCSE (f64, null where the bound does
    /// not apply).
    Bound(usize, BoundMeasure, Part),
    /// A filter's measure or its MCSE (f64, null but on a filter's `inv_mass` row; the
    /// columns only where the realisations have the filters' columns).
    Filter(FilterMeasure, Part),
    /// `pass_probability` or its MCSE (f64; the columns only where the realisations have
    /// a campaign's `campaign_pass`, docs/model.md#campaign).
    PassProbability(Part),
}

impl SummaryColumn {
    /// Every column of the summary of a model with `layout`, in table order.
    pub fn all(layout: &Layout) -> Vec<SummaryColumn> {
        let mut out = vec![SummaryColumn::Condition];
        out.extend((0..layout.axes.len()).map(SummaryColumn::Axis));
        out.extend((0..layout.condition_metrics.len()).map(SummaryColumn::Metric));
        out.extend([
            SummaryColumn::Estimator,
            SummaryColumn::Parameter,
            SummaryColumn::Truth,
            SummaryColumn::BiasModel,
            SummaryColumn::N,
            SummaryColumn::NFailed,
        ]);
        for &m in Measure::ALL {
            out.push(SummaryColumn::Measure(m, Part::Value));
            if m.has_mcse() {
                out.push(SummaryColumn::Measure(m, Part::Mcse));
            }
        }
        out.push(SummaryColumn::NControls);
        for b in 0..layout.bounds.len() {
            for m in BoundMeasure::ALL {
                out.push(SummaryColumn::Bound(b, m, Part::Value));
                if m.has_mcse() {
                    out.push(SummaryColumn::Bound(b, m, Part::Mcse));
                }
            }
        }
        if layout.extras.iter().any(|x| x.name == INPUTS[0]) {
            for m in FilterMeasure::ALL {
                out.push(SummaryColumn::Filter(m, Part::Value));
                out.push(SummaryColumn::Filter(m, Part::Mcse));
            }
        }
        if layout.extras.iter().any(|x| x.name == CAMPAIGN_PASS) {
            out.push(SummaryColumn::PassProbability(Part::Value));
            out.push(SummaryColumn::PassProbability(Part::Mcse));
        }
        out
    }

    /// The column's name.
    pub fn name(self, layout: &Layout) -> String {
        match self {
            SummaryColumn::Condition => "condition".into(),
            SummaryColumn::Axis(i) => layout.axes[i].name.into(),
            SummaryColumn::Metric(i) => layout.condition_metrics[i].into(),
            SummaryColumn::Estimator => "estimator".into(),
            SummaryColumn::Parameter => "parameter".into(),
            SummaryColumn::Truth => "truth".into(),
            SummaryColumn::BiasModel => "bias_model".into(),
            SummaryColumn::N => "n".into(),
            SummaryColumn::NFailed => "n_failed".into(),
            SummaryColumn::NControls => "n_controls".into(),
            SummaryColumn::Measure(m, part) => format!("{}{}", m.name(), part.suffix()),
            SummaryColumn::Bound(b, m, part) => {
                format!("{}{}", m.column(layout.bounds[b].name), part.suffix())
            }
            SummaryColumn::Filter(m, part) => format!("{}{}", m.name(), part.suffix()),
            SummaryColumn::PassProbability(part) => format!("pass_probability{}", part.suffix()),
        }
    }

    /// The value of a measure column in `row` (NaN where undefined or absent); `None` for
    /// the identifying and count columns.
    pub fn measure_value(self, row: &SummaryRow) -> Option<f64> {
        match self {
            SummaryColumn::Measure(m, part) => Some(part.get(row[m])),
            SummaryColumn::Bound(b, m, part) => Some(
                row.bounds[b]
                    .as_ref()
                    .map_or(f64::NAN, |s| part.get(m.of(s))),
            ),
            SummaryColumn::Filter(m, part) => Some(
                row.filter
                    .as_ref()
                    .map_or(f64::NAN, |f| part.get(f[m.index()])),
            ),
            SummaryColumn::PassProbability(part) => {
                Some(row.pass_probability.map_or(f64::NAN, |p| part.get(p)))
            }
            _ => None,
        }
    }

    /// Store the value of a measure column in `row` (a bound's summary is created on its
    /// first non-null value). Other columns are ignored.
    pub fn set_measure(self, row: &mut SummaryRow, v: Option<f64>) {
        match self {
            SummaryColumn::Measure(m, part) => part.set(&mut row[m], v.unwrap_or(f64::NAN)),
            SummaryColumn::Bound(b, m, part) => {
                if let Some(v) = v {
                    let s = row.bounds[b].get_or_insert_with(BoundSummary::undefined);
                    m.set(s, part, v);
                }
            }
            SummaryColumn::Filter(m, part) => {
                if let Some(v) = v {
                    let undefined = Estimate::new(f64::NAN, f64::NAN);
                    let f = row.filter.get_or_insert([undefined; 4]);
                    part.set(&mut f[m.index()], v);
                }
            }
            SummaryColumn::PassProbability(part) => {
                if let Some(v) = v {
                    let p = row
                        .pass_probability
                        .get_or_insert(Estimate::new(f64::NAN, f64::NAN));
                    part.set(p, v);
                }
            }
            _ => {}
        }
    }
}
