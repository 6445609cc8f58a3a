//! What an estimator is: the [`Estimator`] trait, what it reads from one realisation
//! ([`Realisation`], its own [`RowScan`] of the measured rows), what it gives ([`Estimate`],
//! its own columns) and how its first-order bias is predicted ([`FirstOrder`]). The
//! estimators themselves and their registry are in `estimators.rs` and beside it
//! (docs/model.md#estimators).

use std::any::Any;
use std::fmt;
use std::ops::Deref;

use nalgebra::{Matrix3, Vector3};

use super::bounds::{Bound, Spread};
use super::channels::NoiseLevels;
use super::filters::{FilterSettings, GradeSource};
use super::moments::{Moments, Rows, RowsView, noise_free_moments};
use super::parameters::Parameters;
use super::regression::Regression;
use crate::numeric::linalg::SolveError;

/// Everything an estimator may use from one realisation: what a real log would give (the
/// measured sums and rows, the sample times, the known noise levels), never the noise-free
/// signals; the truth only to score itself (the RLS settle time).
#[derive(Debug, Clone, Copy)]
pub struct Realisation<'a> {
    /// The sums of the measured rows.
    pub moments: &'a Moments,
    /// The measured rows (`Some` when an estimator of the study [reads them](Estimator::reads_rows)
    /// or [scans them](Estimator::scan)).
    pub rows: Option<&'a Rows>,
    /// The study's estimators' [scans](Estimator::scan) of the rows.
    pub scans: Option<&'a RowScans>,
    /// The condition's regression: only its sample times `t`, k = ½ρA and g are read.
    pub regression: &'a Regression,
    /// The condition's noise levels (known to the estimator, as in the thesis).
    pub noise: &'a NoiseLevels,
    /// The estimator settings of the study.
    pub settings: &'a EstimatorSettings,
    /// The true θ (for scores such as the settle time, never for the estimate).
    pub truth: &'a [f64; 3],
}

impl<'a> Realisation<'a> {
    /// The measured rows; an estimator that reads them says so in [`Estimator::reads_rows`],
    /// so the model always provides them.
    pub fn rows(&self) -> RowsView<'a> {
        self.rows
            .expect("the model provides the rows to an estimator that reads them")
            .view(self.regression)
    }

    /// This estimator's scan of the rows ([`Estimator::scan`]), of type `T`.
    pub fn scan<T: RowScan>(&self) -> &'a T {
        self.scans
            .and_then(RowScans::get)
            .expect("the model provides the scan to an estimator that has one")
    }
}

/// Study settings of the estimators (`[estimation]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorSettings {
    /// Exponential forgetting factor λ of `rls`, 0 < λ ≤ 1 (1: no forgetting).
    pub forgetting: f64,
    /// The parameters fitted: all three, or with `estimation.known_mass` \[Cd/M, Cr\] with
    /// the weighed 1/M known (docs/model.md#known-mass).
    pub parameters: Parameters,
    /// The rotating-mass factor δ̂ `road_load` assumes (`estimation.effective_mass_factor`;
    /// 0: none).
    pub effective_mass_factor: f64,
    /// Whether the estimators read a measured grade (`estimation.grade`).
    pub grade: GradeSource,
    /// The settings of the filters that estimate the grade with the mass.
    pub filter: FilterSettings,
}

impl Default for EstimatorSettings {
    fn default() -> Self {
        EstimatorSettings {
            forgetting: 1.0,
            parameters: Parameters::All,
            effective_mass_factor: 0.0,
            grade: GradeSource::Measured,
            filter: FilterSettings::default(),
        }
    }
}

impl EstimatorSettings {
    /// The solution of the normal equations `system` over the fitted parameters.
    pub fn solve(&self, system: &(Matrix3<f64>, Vector3<f64>)) -> Result<Vector3<f64>, SolveError> {
        self.parameters.solve(system)
    }
}

/// Room for an estimator's own columns in an [`Estimate`].
pub const ESTIMATE_COLUMNS: usize = 16;

/// One estimator's result on one realisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// θ̂, or why the normal equations could not be solved.
    pub theta: Result<Vector3<f64>, SolveError>,
    /// The values of the estimator's own columns ([`Estimator::columns`], in their
    /// order; NaN: none in this realisation, and after the last column).
    pub columns: [f64; ESTIMATE_COLUMNS],
}

impl Estimate {
    /// An estimate with nothing but θ̂.
    pub fn theta(theta: Result<Vector3<f64>, SolveError>) -> Self {
        Estimate {
            theta,
            columns: [f64::NAN; ESTIMATE_COLUMNS],
        }
    }

    /// θ̂ and the values of the estimator's own columns.
    pub fn with_columns(theta: Result<Vector3<f64>, SolveError>, values: &[f64]) -> Self {
        let mut columns = [f64::NAN; ESTIMATE_COLUMNS];
        columns[..values.len()].copy_from_slice(values);
        Estimate { theta, columns }
    }
}

/// A column of the realisation table that one estimator fills (NaN in the other
/// estimators' rows): one entry of its [`Estimator::columns`].
#[derive(Debug, Clone, Copy)]
pub struct EstimateColumn {
    /// Column name.
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Whether the column is in every study's tables, not only in those of a study that
    /// lists the estimator.
    pub in_every_study: bool,
}

/// An estimator of θ from one realisation.
pub trait Estimator: Sync + Send + fmt::Debug {
    /// Name in study files and in the `estimator` column.
    fn name(&self) -> &'static str;

    /// One line on what it is.
    fn description(&self) -> &'static str;

    /// Whether it reads the measured rows themselves (not only their sums and its
    /// [scan](Self::scan)): the kernel then keeps them.
    fn reads_rows(&self) -> bool {
        false
    }

    /// Its own scan of the measured rows, which the kernel takes block by block as it
    /// measures them (while they are in cache), and the estimate reads
    /// ([`Realisation::scan`]); `None`: none.
    fn scan(&self) -> Option<Box<dyn RowScan>> {
        None
    }

    /// Its own columns of the realisation table, filled from [`Estimate::columns`]
    /// (at most [`ESTIMATE_COLUMNS`]).
    fn columns(&self) -> &'static [EstimateColumn] {
        &[]
    }

    /// Its estimate from the realisation.
    fn estimate(&self, r: &Realisation<'_>) -> Estimate;

    /// Whether it reads `estimation.effective_mass_factor`
    /// ([`EstimatorSettings::effective_mass_factor`]): the key is refused when no listed
    /// estimator does.
    fn reads_effective_mass_factor(&self) -> bool {
        false
    }

    /// Whether it estimates the grade with the mass (a filter): it reads no measured grade,
    /// and the filters' keys of `[estimation]` apply to it.
    fn estimates_grade(&self) -> bool {
        false
    }

    /// Whether it needs the mass known (`estimation.known_mass = true`): the study is refused
    /// otherwise.
    fn needs_known_mass(&self) -> bool {
        false
    }

    /// Its bias to first order (docs/model.md#design): by default the
    /// [ratio of expected sums](expected_sums_bias) of an estimator that does not
    /// compensate the noise.
    fn first_order_bias(&self, at: &FirstOrder<'_>) -> [f64; 3] {
        expected_sums_bias(at)
    }
    /// Whether it reads `estimation.forgetting` ([`EstimatorSettings::forgetting`]): the key
    /// is refused when no listed estimator does.
    fn reads_forgetting(&self) -> bool {
        false
    }

    /// Whether it compensates the bias of the noise with the noise's moments (BCLS and its
    /// kin, every channel: docs/model.md#bcls), so that it reads the kernel's sums of the
    /// grade term (only the compensation of grade noise does).
    fn reads_grade_sums(&self) -> bool {
        false
    }

    /// Whether it needs evenly spaced samples under a differentiated acceleration with
    /// AR(1) speed noise (a compensating estimator stays unbiased there only then): the
    /// study is refused otherwise.
    fn needs_even_differentiation(&self) -> bool {
        false
    }

    /// What its spread is predicted from (the sandwich of its estimating function): the
    /// noisy sums as they are, by default.
    fn spread(&self) -> Spread {
        Spread::Plain
    }

    /// Whether `bound` is reported next to this estimator's estimates (where the bound
    /// applies to the noise at all): a bound that does not describe this estimator's
    /// spread is left out (NaN) rather than misread. Every bound by default.
    fn reports(&self, bound: &Bound, settings: &EstimatorSettings) -> bool {
        let _ = (bound, settings);
        true
    }
}

/// What an estimator's first-order bias is predicted from (docs/model.md#design): the
/// condition's noise-free regression and noise levels, the fitted parameters and the truth,
/// and the estimator's estimate on the noise-free rows.
#[derive(Debug, Clone, Copy)]
pub struct FirstOrder<'a> {
    /// The condition's noise-free regression (the truth's logged rows: the model errors
    /// are in them).
    pub regression: &'a Regression,
    /// The condition's noise levels.
    pub noise: &'a NoiseLevels,
    /// The parameters fitted.
    pub parameters: Parameters,
    /// The true θ.
    pub truth: &'a [f64; 3],
    /// The estimator's estimate on the noise-free rows minus the truth, per θ component
    /// (the condition's `bias_model`).
    pub noise_free_bias: [f64; 3],
    /// Whether the condition has model errors.
    pub model_errors: bool,
}

/// The first-order bias of an estimator that does not compensate the noise (OLS, RLS): the
/// normal equations of the expected sums under the speed noise, solved, minus the truth
/// (E\[Ṽ²\] = V² + σ², E\[Ṽ⁴\] = V⁴ + 6σ²V² + 3σ⁴: docs/model.md#bcls, read backwards).
pub fn expected_sums_bias(at: &FirstOrder<'_>) -> [f64; 3] {
    let reg = at.regression;
    let s2 = at.noise.speed_sd().powi(2);
    let m = noise_free_moments(reg);
    let expected = Moments {
        s_1w: m.s_1w + s2 * m.s_1,
        s_3w: m.s_3w + s2 * m.s_3,
        s_ww: m.s_ww + 6.0 * s2 * m.s_w + 3.0 * s2 * s2 * m.n,
        s_wy: m.s_wy + s2 * m.s_y,
        s_w: m.s_w + s2 * m.n,
        ..m
    };
    match at.parameters.solve(&expected.ols_system(reg.k)) {
        Ok(theta) => [0, 1, 2].map(|p| theta[p] - at.truth[p]),
        Err(_) => [f64::NAN; 3],
    }
}

/// The first-order bias of an estimator that compensates the noise: the noise adds none,
/// so it is what the noise-free rows make it estimate — the model errors, and a
/// differentiated acceleration's central differences, which are not the acceleration where
/// the force changes within a step — and zero otherwise (that estimate is then the truth,
/// to rounding).
pub fn compensated_bias(at: &FirstOrder<'_>) -> [f64; 3] {
    match at.model_errors || at.regression.differentiation.is_some() {
        true => at.noise_free_bias,
        false => [0.0; 3],
    }
}

/// A scan of the measured rows that an estimator reads ([`Estimator::scan`]): the kernel
/// resets it for each realisation and advances it block by block as it measures the rows;
/// taken in pieces it gives the same bits as in one pass over all rows.
pub trait RowScan: Any + Send + Sync + fmt::Debug {
    /// Start a realisation of `reg`'s rows (keeping the memory of earlier ones).
    fn reset(&mut self, reg: &Regression, start: &ScanStart<'_>);

    /// Take the measured rows up to `end` (exclusive; a multiple of four or the row
    /// count).
    fn advance(&mut self, rows: RowsView<'_>, end: usize);

    /// Whether, after [`reset`](Self::reset), the scan reads the lane sums of the rows'
    /// chunks ([`RowsView::chunks`]), holding the grade term's where `grade`, in place of
    /// the rows inside them: the kernel's pass then takes them (and where every scan reads
    /// them and nothing else reads the rows, writes only the rows after the chunks).
    fn reads_chunks(&self, grade: bool) -> bool {
        let _ = grade;
        false
    }
}

/// What a scan starts a realisation from besides its regression.
#[derive(Debug, Clone, Copy)]
pub struct ScanStart<'a> {
    /// The condition's noise levels.
    pub noise: &'a NoiseLevels,
    /// The estimator settings of the study.
    pub settings: &'a EstimatorSettings,
    /// The true θ (for scores such as the settle time).
    pub truth: &'a [f64; 3],
    /// Whether the regression serves many realisations (a condition's), so that what they
    /// share is worth keeping with it ([`Regression::derived`]); otherwise it is a
    /// realisation's own.
    pub shared: bool,
}

/// The scans of a study's estimators ([`Estimator::scan`]), one per estimator that has
/// one, kept by a thread from one realisation to the next.
#[derive(Debug, Default)]
pub struct RowScans {
    /// The names of the estimators the scans were made for (all of them, in order).
    made_for: Vec<&'static str>,
    scans: Vec<Box<dyn RowScan>>,
}

impl RowScans {
    /// Empty scans of `reg`'s rows for `estimators`, keeping those made for the same
    /// estimators in an earlier realisation (and their memory).
    pub fn reset(&mut self, estimators: &[EstimatorRef], reg: &Regression, start: &ScanStart<'_>) {
        if !self
            .made_for
            .iter()
            .copied()
            .eq(estimators.iter().map(|e| e.name()))
        {
            self.made_for = estimators.iter().map(|e| e.name()).collect();
            self.scans = estimators.iter().filter_map(|e| e.scan()).collect();
        }
        for scan in &mut self.scans {
            scan.reset(reg, start);
        }
    }

    /// Take the measured rows up to `end` (exclusive; a multiple of four or the row count).
    pub fn advance(&mut self, rows: RowsView<'_>, end: usize) {
        for scan in &mut self.scans {
            scan.advance(rows, end);
        }
    }

    /// Whether some scan reads the lane sums of the rows' chunks, and whether every scan
    /// reads them in place of the rows inside them ([`RowScan::reads_chunks`]).
    pub fn reads_chunks(&self, grade: bool) -> [bool; 2] {
        let mut reads = self.scans.iter().map(|scan| scan.reads_chunks(grade));
        [reads.clone().any(|r| r), reads.all(|r| r)]
    }

    /// The scan of type `T` (`None`: no estimator has one).
    pub fn get<T: RowScan>(&self) -> Option<&T> {
        self.scans
            .iter()
            .find_map(|scan| (&**scan as &dyn Any).downcast_ref::<T>())
    }
}

/// Whether any of `estimators` reads the measured rows or has a scan of them: the kernel
/// keeps the rows only then.
pub fn reads_rows(estimators: &[EstimatorRef]) -> bool {
    estimators
        .iter()
        .any(|e| e.reads_rows() || e.scan().is_some())
}

/// A registered estimator, compared by name.
#[derive(Debug, Clone, Copy)]
pub struct EstimatorRef(pub &'static dyn Estimator);

impl Deref for EstimatorRef {
    type Target = dyn Estimator;

    fn deref(&self) -> &Self::Target {
        self.0
    }
}

impl PartialEq for EstimatorRef {
    fn eq(&self, other: &Self) -> bool {
        self.name() == other.name()
    }
}

impl Eq for EstimatorRef {}
