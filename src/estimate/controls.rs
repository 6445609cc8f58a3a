//! Control variates (docs/model.md#control-variates): each sum of a realisation's
//! [`Moments`] minus its exact expectation under the condition's noise.
//!
//! Every estimator's θ̂ is a smooth function of the moments (OLS and BCLS exactly; the
//! row-based ones closely), so these mean-zero quantities carry most of a
//! realisation's Monte Carlo noise. A sum the noise does not touch is constant and is not a
//! control.

use super::channels::{Channel, ColumnMoments, NoiseLevels, TrueRow};
use super::regression::Regression;
use super::sums::{Column, Moments, SUM_COUNT, Sum};
use crate::numeric::sum::ExactSum;

/// One control variate: a column of `realisations.parquet`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Control {
    /// Column name.
    pub name: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// The sum it centres, in words.
    pub description: &'static str,
}

/// Number of control variates (one per [`Sum`]).
pub const CONTROL_COUNT: usize = SUM_COUNT;

/// The control variates in column order, the order of [`Sum::ALL`] and [`Moments::sums`].
pub static CONTROLS: [Control; CONTROL_COUNT] = controls();

const fn controls() -> [Control; CONTROL_COUNT] {
    let mut out = [Control {
        name: "",
        unit: "",
        description: "",
    }; CONTROL_COUNT];
    let mut i = 0;
    while i < CONTROL_COUNT {
        let s = Sum::ALL[i];
        out[i] = Control {
            name: s.control_name(),
            unit: s.unit(),
            description: s.control_description(),
        };
        i += 1;
    }
    out
}

/// The expectations of a condition's moments over its noise, for the sums that are control
/// variates in it (`None` for the others).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Expectations(pub [Option<f64>; CONTROL_COUNT]);

impl Expectations {
    /// The expected moments of `reg` under `noise`, with `ar1` the AR(1) coefficients of
    /// correlated speed noise over [`Regression::noise_times`] (`None` when white): per
    /// sample, the measured values are functions of independent channels' draws
    /// (docs/model.md#control-variates), so each expected product is a product of
    /// expectations or a closed-form moment of one channel ([`Channel::expect`]) — but
    /// where rows share a channel's noise, which adds its covariance with the neighbours'
    /// ([`Channel::expect_shared`]: w ỹ under a differentiated acceleration with correlated
    /// speed noise).
    pub fn new(reg: &Regression, noise: &NoiseLevels, ar1: Option<&[[f64; 2]]>) -> Self {
        let mut sums: [ExactSum; CONTROL_COUNT] = Default::default();
        for i in 0..reg.len() {
            let r = TrueRow::of(reg, i);
            let mut row = ColumnMoments::noise_free(&r);
            for (c, &sd) in noise.iter() {
                if sd > 0.0 {
                    c.expect(sd, &r, &mut row);
                }
            }
            for c in Channel::ALL {
                c.expect_shared(reg, noise, ar1, i, &mut row);
            }
            let terms = Sum::ALL.map(|s| row.of(s));
            for (sum, t) in sums.iter_mut().zip(terms) {
                sum.add(t);
            }
        }
        let mut out = [None; CONTROL_COUNT];
        for ((o, sum), varies) in out.iter_mut().zip(&sums).zip(varies(noise)) {
            *o = varies.then(|| sum.value());
        }
        Expectations(out)
    }

    /// Which sums are control variates.
    pub fn applies(&self) -> [bool; CONTROL_COUNT] {
        self.0.map(|e| e.is_some())
    }

    /// A realisation's control variates: its sums minus their expectations (NaN for a sum
    /// that is not a control).
    pub fn centre(&self, m: &Moments) -> [f64; CONTROL_COUNT] {
        let sums = m.sums();
        std::array::from_fn(|j| self.0[j].map_or(f64::NAN, |e| sums[j] - e))
    }
}

/// Which of the sums vary under `noise` (and so are control variates): those with a factor
/// that a channel which is on moves ([`NoiseLevels::moves`]).
pub fn varies(noise: &NoiseLevels) -> [bool; CONTROL_COUNT] {
    Sum::ALL.map(|s| s.factors().iter().any(|&c| noise.moves(c)))
}

impl ColumnMoments {
    /// E of `sum`'s term at this row: a product of expectations where its factors carry
    /// independent noise, a joint moment where they share a channel.
    fn of(&self, sum: Sum) -> f64 {
        let mean = |c: Column| self.mean[c.index()];
        match *sum.factors() {
            [a] => mean(a),
            [Column::F, Column::F] => self.ff,
            [Column::W, Column::W] => self.ww,
            [Column::C, Column::C] => self.cc,
            [Column::C, Column::Y] => self.cy,
            [Column::W, Column::Y] => mean(Column::W) * mean(Column::Y) + self.wy_neighbours,
            // Independent noise (pinned by
            // `a_product_of_columns_one_channel_moves_reads_its_joint_moment`).
            [a, b] => mean(a) * mean(b),
            _ => unreachable!("a sum has one or two factors"),
        }
    }
}

#[cfg(test)]
mod tests;
