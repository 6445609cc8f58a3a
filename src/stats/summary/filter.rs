//! The measures of a filter that estimates the grade with the mass (`ekf`, `rls_mf`), on
//! its `inv_mass` row of the summary: its RMSE of 1/M over the condition's PCRLB and over
//! the bound along the realisations' own paths, the coverage of its own 95 % interval and
//! its mean NEES, each with its MCSE (docs/model.md#filter-measures). Read from the filter's
//! own columns of each realisation, against each realisation's own truth.

use super::super::measures::Estimate;
use crate::estimate::filtering::{FILTER_SD_INV_MASS, INV_MASS_ERROR, NEES, PATH_BOUND_INV_MASS};
use crate::numeric::sum::ExactSum;

/// The realisation columns the measures read, in the order of a record's `filter` values.
pub const INPUTS: [&str; 4] = [
    INV_MASS_ERROR,
    PATH_BOUND_INV_MASS,
    FILTER_SD_INV_MASS,
    NEES,
];

/// The z of the filter's own 95 % interval.
const Z_95: f64 = 1.959_963_984_540_054;

/// One measure of a filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FilterMeasure {
    /// `rmse_over_pcrlb`: √(mean e²) / the condition's `pcrlb_inv_mass`.
    RmseOverPcrlb,
    /// `rmse_over_path_bound`: √(mean e² / mean b²), b the path bound's SD.
    RmseOverPathBound,
    /// `coverage_filter`: the share of realisations with |e| ≤ z·(its own SD).
    CoverageFilter,
    /// `nees_mean`: the mean NEES (χ²₃'s mean 3 for a consistent filter).
    NeesMean,
}

impl FilterMeasure {
    /// Every one, in column order.
    pub const ALL: [FilterMeasure; 4] = [
        FilterMeasure::RmseOverPcrlb,
        FilterMeasure::RmseOverPathBound,
        FilterMeasure::CoverageFilter,
        FilterMeasure::NeesMean,
    ];

    /// Its column.
    pub fn name(self) -> &'static str {
        match self {
            FilterMeasure::RmseOverPcrlb => "rmse_over_pcrlb",
            FilterMeasure::RmseOverPathBound => "rmse_over_path_bound",
            FilterMeasure::CoverageFilter => "coverage_filter",
            FilterMeasure::NeesMean => "nees_mean",
        }
    }

    /// Its slot.
    pub fn index(self) -> usize {
        self as usize
    }
}

/// The sums of one estimator's filter columns over a condition's realisations.
#[derive(Debug, Clone, Default)]
pub(super) struct FilterAcc {
    /// [e²], [e⁴] over the realisations with e.
    error: [ExactSum; 2],
    n_error: u64,
    /// [e²], [e⁴], [b²], [b⁴], [e²b²] over the realisations with both e and b.
    paired: [ExactSum; 5],
    n_paired: u64,
    /// Realisations with e and the filter's SD, and those covered.
    n_interval: u64,
    covered: u64,
    /// [nees], [nees²].
    nees: [ExactSum; 2],
    n_nees: u64,
}

impl FilterAcc {
    /// Take one realisation's `values` (in the order of [`INPUTS`]; NaN where absent).
    pub(super) fn add(&mut self, values: &[f64; 4]) {
        let [e, b, sd, nees] = *values;
        if e.is_finite() {
            let e2 = e * e;
            self.error[0].add(e2);
            self.error[1].add(e2 * e2);
            self.n_error += 1;
        }
        if e.is_finite() && b.is_finite() {
            let (e2, b2) = (e * e, b * b);
            for (s, v) in self
                .paired
                .iter_mut()
                .zip([e2, e2 * e2, b2, b2 * b2, e2 * b2])
            {
                s.add(v);
            }
            self.n_paired += 1;
        }
        if e.is_finite() && sd.is_finite() {
            self.n_interval += 1;
            if e.abs() <= Z_95 * sd {
                self.covered += 1;
            }
        }
        if nees.is_finite() {
            self.nees[0].add(nees);
            self.nees[1].add(nees * nees);
            self.n_nees += 1;
        }
    }

    /// Whether any realisation had a filter's values.
    pub(super) fn seen(&self) -> bool {
        self.n_error + self.n_paired + self.n_interval + self.n_nees > 0
    }

    /// The measures, `pcrlb` the condition's bound's SD of 1/M (NaN: none). MCSEs by the
    /// delta method from the realisations' own spread (docs/model.md#filter-measures).
    pub(super) fn finish(&self, pcrlb: f64) -> [Estimate; 4] {
        let undefined = Estimate::new(f64::NAN, f64::NAN);
        let mut out = [undefined; 4];
        if self.n_error >= 2 {
            let n = self.n_error as f64;
            let (me, me2) = (self.error[0].value() / n, self.error[1].value() / n);
            let var_e = (me2 - me * me) * n / (n - 1.0);
            // √(m_e)/pcrlb: d√m = dm/(2√m).
            let rmse = me.sqrt();
            out[FilterMeasure::RmseOverPcrlb.index()] =
                Estimate::new(rmse / pcrlb, (var_e / n).sqrt() / (2.0 * rmse) / pcrlb);
        }
        if self.n_paired >= 2 {
            let n = self.n_paired as f64;
            let s: Vec<f64> = self.paired.iter().map(ExactSum::value).collect();
            let (me, me2, mb, mb2, meb) = (s[0] / n, s[1] / n, s[2] / n, s[3] / n, s[4] / n);
            let var_e = (me2 - me * me) * n / (n - 1.0);
            let var_b = (mb2 - mb * mb) * n / (n - 1.0);
            let cov = (meb - me * mb) * n / (n - 1.0);
            // √(m_e/m_b): the ratio r's variance by the delta method, then d√r = dr/(2√r).
            let r = me / mb;
            let var_r = (var_e / (mb * mb) - 2.0 * me * cov / mb.powi(3)
                + me * me * var_b / mb.powi(4))
                / n;
            out[FilterMeasure::RmseOverPathBound.index()] =
                Estimate::new(r.sqrt(), var_r.max(0.0).sqrt() / (2.0 * r.sqrt()));
        }
        if self.n_interval > 0 {
            let m = self.n_interval as f64;
            let p = self.covered as f64 / m;
            out[FilterMeasure::CoverageFilter.index()] =
                Estimate::new(p, (p * (1.0 - p) / m).sqrt());
        }
        if self.n_nees >= 2 {
            let m = self.n_nees as f64;
            let mean = self.nees[0].value() / m;
            let var = (self.nees[1].value() / m - mean * mean) * m / (m - 1.0);
            out[FilterMeasure::NeesMean.index()] = Estimate::new(mean, (var / m).sqrt());
        }
        out
    }
}
