//! The measures of every summary row, one entry each (docs/model.md#measures): a measure is
//! a type implementing [`SummaryMeasure`] in its own file, listed once in the
//! `summary_measures!` registry below, which declares its module and gives it its
//! [`Measure`] variant, its place among the columns of `summary.parquet` (registry order) and
//! its slot in [`SummaryRow`](super::SummaryRow).

use crate::stats::control::ControlFit;
use crate::stats::measures::{Estimate, EstimateSums, SpreadCv};

/// What a measure of one condition × estimator × parameter is computed from: the sums of
/// the estimates, the reference estimator's, and the control-variate fits.
#[derive(Debug, Clone, Copy)]
pub struct MeasureInputs<'a> {
    /// The true value of the parameter.
    pub truth: f64,
    /// Sums of the estimates over the realisations.
    pub sums: &'a EstimateSums,
    /// The same sums of the reference estimator (the first, OLS when run).
    pub reference: &'a EstimateSums,
    /// Σ (θ̂ − θ̄)(θ̂_ref − θ̄_ref) over the realisations.
    pub sum_cross_reference: f64,
    /// The spread by the second moment's control variates (undefined where none applies).
    pub spread: &'a SpreadCv,
    /// The mean's control-variate regression (`None` where none applies).
    pub control: Option<&'a ControlFit>,
}

/// One measure of the summary: its column and how it is computed.
pub trait SummaryMeasure: Sync {
    /// The column of its value (its MCSE's is `<name>_mcse`).
    fn name(&self) -> &'static str;

    /// Whether it has an MCSE column.
    fn has_mcse(&self) -> bool {
        true
    }

    /// Whether it comes from a control-variate regression, defined from q + 3 realisations
    /// on (q the number of controls).
    fn by_control_variates(&self) -> bool {
        false
    }

    /// Its value and MCSE (NaN where undefined; the MCSE NaN where it has none).
    fn compute(&self, m: &MeasureInputs<'_>) -> Estimate;
}

/// The registry: `module => [Type, …],` declares `module` (a file beside this one) and
/// makes each type a [`Measure`] variant of the same name, in column order.
macro_rules! summary_measures {
    ($($module:ident => [$($measure:ident),+ $(,)?]),+ $(,)?) => {
        $(mod $module;)+

        /// A measure of every summary row, in column order (one variant per entry of the
        /// registry in `stats/summary/measure/mod.rs`).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub enum Measure {
            $($(
                #[doc = concat!("The measure `", stringify!($module), "::", stringify!($measure), "`.")]
                $measure,
            )+)+
        }

        impl Measure {
            /// Every measure, in column order.
            pub const ALL: &'static [Measure] = &[$($(Measure::$measure),+),+];

            /// Its definition.
            pub fn definition(self) -> &'static dyn SummaryMeasure {
                match self {
                    $($(Measure::$measure => &$module::$measure,)+)+
                }
            }
        }
    };
}

summary_measures! {
    moments => [Mean, Bias, RelBias, EmpSe, Mse, Rmse],
    precision => [RelPrecision],
    control_variates => [MeanCv, BiasCv, CvVarianceRatio, EmpSeCv, MseCv, RmseCv],
}

/// The number of measures.
pub const MEASURE_COUNT: usize = Measure::ALL.len();

impl Measure {
    /// Column name of the value.
    pub fn name(self) -> &'static str {
        self.definition().name()
    }

    /// Whether it has an MCSE column.
    pub fn has_mcse(self) -> bool {
        self.definition().has_mcse()
    }

    /// Whether it is estimated by a control-variate regression.
    pub fn by_control_variates(self) -> bool {
        self.definition().by_control_variates()
    }

    /// Its slot in a row's measures.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Every measure computed from `inputs`, in column order.
    pub fn compute_all(inputs: &MeasureInputs<'_>) -> [Estimate; MEASURE_COUNT] {
        std::array::from_fn(|i| Measure::ALL[i].definition().compute(inputs))
    }
}
