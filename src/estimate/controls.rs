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
mod tests {
    use super::*;
    use crate::estimate::channels::{Acceleration, BlockNoise};
    use crate::estimate::moments::MomentAccumulator;
    use crate::estimate::regression::test_regression as regression;
    use crate::noise::{BLOCK, NormalStream};

    /// The moments of realisation `r` with white noise on every channel that is on.
    fn moments(reg: &Regression, noise: NoiseLevels, r: u64) -> Moments {
        let mut acc = MomentAccumulator::new(reg, noise);
        let mut streams = Channel::ALL
            .map(|c| NormalStream::for_realisation(9, 0, c.stream(), r))
            .to_vec();
        let mut buffers = [[0.0; BLOCK]; 4];
        for start in (0..reg.len()).step_by(BLOCK) {
            let len = BLOCK.min(reg.len() - start);
            for (s, b) in streams.iter_mut().zip(&mut buffers) {
                s.fill_block(&mut b[..len]);
            }
            let draws = BlockNoise::from_fn(|c| noise.is_on(c).then(|| &buffers[c.index()][..len]));
            acc.add_block(start, len, draws, None);
        }
        acc.finish()
    }

    /// Every control variate has mean zero: for each channel alone and all together, over
    /// R realisations each control's mean is within 4.5 of its standard errors of 0 (one of
    /// 35 comparisons outside by chance: probability ≈ 2.4e-4). This catches an error in the
    /// speed, force and output terms (the σ² terms are ~N σ² while the SE is ~√N σ); the grade
    /// terms, whose errors would be of order σ_θ² Σ sin θ here, are checked by quadrature
    /// above.
    #[test]
    fn control_variates_have_mean_zero_on_every_channel() {
        let reg = regression();
        let mut cases = Vec::new();
        for (channel, sd) in [
            (Channel::Velocity, 0.8),
            (Channel::Output, 0.3),
            (Channel::Grade, 0.02),
            (Channel::Force, 40.0),
        ] {
            let mut noise = NoiseLevels::default();
            noise[channel] = sd;
            cases.push(noise);
        }
        let mut all = NoiseLevels::default();
        all[Channel::Velocity] = 0.8;
        all[Channel::Output] = 0.3;
        all[Channel::Grade] = 0.02;
        all[Channel::Force] = 40.0;
        cases.push(all);
        let r = 600;
        let mut compared = 0;
        for noise in cases {
            assert_eq!(noise.acceleration, Acceleration::Model);
            let e = Expectations::new(&reg, &noise, None);
            let samples: Vec<[f64; CONTROL_COUNT]> =
                (0..r).map(|k| e.centre(&moments(&reg, noise, k))).collect();
            for j in 0..CONTROL_COUNT {
                if e.0[j].is_none() {
                    assert!(samples.iter().all(|s| s[j].is_nan()));
                    continue;
                }
                let mean = samples.iter().map(|s| s[j]).sum::<f64>() / r as f64;
                let var =
                    samples.iter().map(|s| (s[j] - mean).powi(2)).sum::<f64>() / (r - 1) as f64;
                let se = (var / r as f64).sqrt();
                assert!(
                    se > 0.0,
                    "{} does not vary under {noise:?}",
                    CONTROLS[j].name
                );
                assert!(
                    mean.abs() <= 4.5 * se,
                    "{} under {noise:?}: mean {mean:e}, SE {se:e}",
                    CONTROLS[j].name
                );
                compared += 1;
            }
        }
        assert_eq!(compared, 5 + 4 + 8 + 5 + 13);
    }

    /// A product of two columns that one channel moves is not the product of their means:
    /// every such sum (a square, or a pair a channel's [`Channel::columns`] both list, or
    /// w ỹ, which speed noise shares through a differentiated acceleration) reads a joint
    /// moment. With every joint moment NaN, exactly those sums come out NaN, so a new
    /// channel that moves two columns without a joint moment fails here.
    #[test]
    fn a_product_of_columns_one_channel_moves_reads_its_joint_moment() {
        let e = ColumnMoments {
            mean: [2.0, 3.0, 5.0, 7.0],
            ff: f64::NAN,
            ww: f64::NAN,
            cc: f64::NAN,
            cy: f64::NAN,
            wy_neighbours: f64::NAN,
        };
        for s in Sum::ALL {
            let shared = match *s.factors() {
                [a, b] => {
                    a == b
                        || (a, b) == (Column::W, Column::Y)
                        || Channel::ALL
                            .iter()
                            .any(|c| c.columns().contains(&a) && c.columns().contains(&b))
                }
                _ => false,
            };
            assert_eq!(e.of(s).is_nan(), shared, "{s:?}");
        }
    }

    #[test]
    fn without_noise_nothing_is_a_control() {
        let e = Expectations::new(&regression(), &NoiseLevels::default(), None);
        assert_eq!(e.applies(), [false; CONTROL_COUNT]);
    }
}
