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
    /// expectations or a closed-form moment of one channel — but for w ỹ under a
    /// differentiated acceleration with correlated speed noise, which adds the covariance
    /// of the row's speed noise with its neighbours'.
    pub fn new(reg: &Regression, noise: &NoiseLevels, ar1: Option<&[[f64; 2]]>) -> Self {
        let sd_v = noise[Channel::Velocity];
        // ỹ's derivative noise σ_v (e_{s+1} − e_{s−1}) / Δt against w = (V + σ_v e_s)².
        let neighbours = match (&reg.differentiation, ar1) {
            (Some(d), Some(ar1)) if noise.speed_noise_differentiated() => Some((d, ar1)),
            _ => None,
        };
        let mut sums: [ExactSum; CONTROL_COUNT] = Default::default();
        for i in 0..reg.len() {
            let r = TrueRow {
                f: reg.f[i],
                v: reg.v[i],
                accel: reg.accel[i],
                sin_grade: reg.sin_grade[i],
                cos_grade: reg.cos_grade[i],
                g: reg.g,
            };
            let mut row = ColumnMoments::noise_free(&r);
            for (c, &sd) in noise.iter() {
                if sd > 0.0 {
                    c.expect(sd, &r, &mut row);
                }
            }
            if let Some((d, ar1)) = neighbours {
                row.wy_neighbours = neighbour_covariance(r.v, sd_v, ar1, d.sample[i], d.inv_dt[i]);
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

/// E[w σ(e_{s+1} − e_{s−1})/Δt] for w = (V + σe_s)², e the stationary AR(1) noise with
/// coefficients `ar1` over the span (e_j = φ_j e_{j−1} + √(1 − φ_j²) z_j, so E[e_{j−1} e_j] =
/// φ_j) and `inv_dt` = 1/Δt: 2Vσ² (φ_{s+1} − φ_s)/Δt, the third moments vanishing.
fn neighbour_covariance(v: f64, sd: f64, ar1: &[[f64; 2]], s: usize, inv_dt: f64) -> f64 {
    2.0 * v * sd * sd * (ar1[s + 1][0] - ar1[s][0]) * inv_dt
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::channels::{Acceleration, BlockNoise, grade_moments};
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

    /// The grade moments against the integrals themselves: the trapezoid rule over
    /// δ ∈ [−12σ, 12σ] with 4001 points (spectrally accurate for these smooth, rapidly
    /// decaying integrands: agreement to 1e-12) at σ = 0.3 rad, where ρ = 0.956 and
    /// ρ⁴ = 0.835 differ clearly from 1, and at grades of either sign.
    #[test]
    fn grade_moments_are_the_gaussian_integrals() {
        let sd = 0.3;
        for theta in [-0.4f64, -0.05, 0.0, 0.1, 0.7] {
            let (n, half) = (4001, 12.0 * sd);
            let h = 2.0 * half / (n - 1) as f64;
            let mut q = [0.0; 4];
            for k in 0..n {
                let d = -half + k as f64 * h;
                let w = h * (-0.5 * (d / sd).powi(2)).exp()
                    / (sd * (2.0 * std::f64::consts::PI).sqrt());
                let (s, c) = (theta + d).sin_cos();
                for (q, v) in q.iter_mut().zip([c, c * c, s, s * c]) {
                    *q += w * v;
                }
            }
            let e = grade_moments(theta.sin(), theta.cos(), sd);
            for j in 0..4 {
                assert!(
                    (e[j] - q[j]).abs() <= 1e-12,
                    "θ = {theta}, moment {j}: {} vs {}",
                    e[j],
                    q[j]
                );
            }
        }
    }

    /// The covariance of a row's w with the derivative noise of its differentiated ỹ,
    /// against a Monte Carlo of the AR(1) recursion the kernel runs, on steps of 0.1 s and
    /// 1 s around the row (τ = 0.5 s: φ = 0.82 before, 0.14 after), 400 000 draws: within
    /// 4.5 standard errors, and the term is > 20 of them (so an error of sign or index would
    /// show).
    #[test]
    fn neighbour_covariance_is_the_ar1_expectation() {
        use crate::estimate::regression::ar1_coefficients;
        let t = [0.0, 0.1, 1.1];
        let ar1 = ar1_coefficients(&t, 0.5);
        let (v, sd, inv_dt) = (12.0, 0.8, 1.0 / (t[2] - t[0]));
        let expected = neighbour_covariance(v, sd, &ar1, 1, inv_dt);
        let n = 400_000;
        let mut z = vec![0.0; 3 * n];
        NormalStream::for_realisation(3, 0, 7, 0).fill(&mut z);
        let values: Vec<f64> = z
            .chunks_exact(3)
            .map(|z| {
                let mut e = [z[0], 0.0, 0.0];
                for j in 1..3 {
                    e[j] = ar1[j][0] * e[j - 1] + ar1[j][1] * z[j];
                }
                (v + sd * e[1]).powi(2) * sd * (e[2] - e[0]) * inv_dt
            })
            .collect();
        let mean = values.iter().sum::<f64>() / n as f64;
        let se =
            (values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0) / n as f64)
                .sqrt();
        assert!(
            (mean - expected).abs() <= 4.5 * se,
            "{mean} vs {expected} (SE {se})"
        );
        assert!(expected.abs() > 20.0 * se, "{expected} vs SE {se}");
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
