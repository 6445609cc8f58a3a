//! Control variates (docs/model.md#control-variates): each sum of a realisation's
//! [`Moments`] minus its exact expectation under the condition's noise.
//!
//! Every estimator's θ̂ is a smooth function of the moments (OLS and BCLS exactly; the
//! row-based ones closely), so these thirteen mean-zero quantities carry most of a
//! realisation's Monte Carlo noise. A sum the noise does not touch is constant and is not a
//! control; nor is a sum whose expectation is not known in closed form (Σwỹ when correlated
//! speed noise enters both w and a differentiated ỹ).

use super::channels::{Channel, NoiseLevels};
use super::moments::Moments;
use super::regression::Regression;
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

/// Number of control variates (one per sum of [`Moments`] except N).
pub const CONTROL_COUNT: usize = 13;

/// The control variates in column order, the order of [`Moments::sums`].
pub static CONTROLS: [Control; CONTROL_COUNT] = [
    control("cv_f_f", "N^2", "Σ x̃₁² − E"),
    control("cv_f_c", "N m/s^2", "Σ x̃₁ x̃₃ − E"),
    control("cv_c_c", "m^2/s^4", "Σ x̃₃² − E"),
    control("cv_f_y", "N m/s^2", "Σ x̃₁ ỹ − E"),
    control("cv_c_y", "m^2/s^4", "Σ x̃₃ ỹ − E"),
    control("cv_f_w", "N m^2/s^2", "Σ x̃₁ w − E"),
    control("cv_c_w", "m^3/s^4", "Σ x̃₃ w − E"),
    control("cv_w_w", "m^4/s^4", "Σ w² − E"),
    control("cv_w_y", "m^3/s^4", "Σ w ỹ − E"),
    control("cv_w", "m^2/s^2", "Σ w − E"),
    control("cv_f", "N", "Σ x̃₁ − E"),
    control("cv_c", "m/s^2", "Σ x̃₃ − E"),
    control("cv_y", "m/s^2", "Σ ỹ − E"),
];

const fn control(name: &'static str, unit: &'static str, description: &'static str) -> Control {
    Control {
        name,
        unit,
        description,
    }
}

impl Moments {
    /// The thirteen sums in the order of [`CONTROLS`].
    pub fn sums(&self) -> [f64; CONTROL_COUNT] {
        [
            self.s_11, self.s_13, self.s_33, self.s_1y, self.s_3y, self.s_1w, self.s_3w, self.s_ww,
            self.s_wy, self.s_w, self.s_1, self.s_3, self.s_y,
        ]
    }
}

/// The expectations of a condition's moments over its noise, for the sums that are control
/// variates in it (`None` for the others).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Expectations(pub [Option<f64>; CONTROL_COUNT]);

impl Expectations {
    /// The expected moments of `reg` under `noise`: per sample, the measured values are
    /// functions of independent channels' draws (docs/model.md#control-variates), so each
    /// expected product is a product of expectations or a closed-form moment of one channel.
    pub fn new(reg: &Regression, noise: &NoiseLevels) -> Self {
        let sd_v = noise[Channel::Velocity];
        let sd_f = noise[Channel::Force];
        let sd_g = noise[Channel::Grade];
        let (s2, s2f) = (sd_v * sd_v, sd_f * sd_f);
        // E[cos δ] and E[cos 2δ] for δ ~ N(0, σ_θ²).
        let rho = (-0.5 * sd_g * sd_g).exp();
        let rho4 = (-2.0 * sd_g * sd_g).exp();
        let g = reg.g;
        let mut sums: [ExactSum; CONTROL_COUNT] = Default::default();
        for i in 0..reg.len() {
            let (f, v, a) = (reg.f[i], reg.v[i], reg.accel[i]);
            let (sn, cs) = (reg.sin_grade[i], reg.cos_grade[i]);
            let v2 = v * v;
            // E[x̃₁], E[x̃₁²], E[w], E[w²], E[x̃₃], E[x̃₃²], E[ỹ], E[x̃₃ỹ]
            let e1 = f;
            let e11 = f * f + s2f;
            let ew = v2 + s2;
            let eww = v2 * v2 + 6.0 * s2 * v2 + 3.0 * s2 * s2;
            let e3 = -g * cs * rho;
            let e33 = g * g * 0.5 * (cs * cs * (1.0 + rho4) + sn * sn * (1.0 - rho4));
            let ey = a + g * sn * rho;
            let e3y = -g * a * cs * rho - g * g * sn * cs * rho4;
            let terms = [
                e11,
                e1 * e3,
                e33,
                e1 * ey,
                e3y,
                e1 * ew,
                e3 * ew,
                eww,
                ew * ey,
                ew,
                e1,
                e3,
                ey,
            ];
            for (sum, t) in sums.iter_mut().zip(terms) {
                sum.add(t);
            }
        }
        let force = noise.is_on(Channel::Force);
        let speed = noise.is_on(Channel::Velocity);
        let grade = noise.is_on(Channel::Grade);
        let output = noise.is_on(Channel::Output) || grade || noise.speed_noise_differentiated();
        // Which factors vary: x̃₁ (force), w (speed), x̃₃ (grade), ỹ (output, grade, or
        // speed through a differentiated acceleration).
        let varies = [
            force,
            force || grade,
            grade,
            force || output,
            grade || output,
            force || speed,
            grade || speed,
            speed,
            // With correlated speed noise a differentiated ỹ is correlated with w.
            (speed || output)
                && !(noise.speed_noise_differentiated() && noise.velocity_correlated()),
            speed,
            force,
            grade,
            output,
        ];
        let mut out = [None; CONTROL_COUNT];
        for ((o, sum), varies) in out.iter_mut().zip(&sums).zip(varies) {
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
    /// 45 comparisons outside by chance: probability ≈ 3e-4). A wrong expectation of any
    /// order σ² would be off by hundreds of standard errors (the σ² terms are ~N σ² while
    /// the SE is ~√N σ).
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
            let e = Expectations::new(&reg, &noise);
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

    #[test]
    fn without_noise_nothing_is_a_control() {
        let e = Expectations::new(&regression(), &NoiseLevels::default());
        assert_eq!(e.applies(), [false; CONTROL_COUNT]);
    }
}
