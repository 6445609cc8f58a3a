//! The normal equations of a realisation's [`Moments`]: OLS's on the measured sums, and
//! BCLS's on the sums compensated for the noise (docs/model.md#bcls).

use nalgebra::{Matrix3, Vector3};

use super::channels::{Channel, NoiseLevels};
use super::sums::Moments;

impl Moments {
    /// OLS normal equations X̃ᵀX̃ θ = X̃ᵀỹ (thesis eq. 20).
    pub fn ols_system(&self, k: f64) -> (Matrix3<f64>, Vector3<f64>) {
        self.system(k, self.s_1w, self.s_3w, self.s_ww, self.s_wy)
    }

    /// BCLS normal equations: the OLS system of the [compensated](Self::compensated) moments.
    pub fn bcls_system(&self, k: f64, g: f64, noise: &NoiseLevels) -> (Matrix3<f64>, Vector3<f64>) {
        self.compensated(g, noise).ols_system(k)
    }

    /// Every sum replaced by an unbiased estimate of its value without the noise of `noise`
    /// (known SDs), from measured quantities only: each channel that is on corrects the sums
    /// its noise enters ([`Moments::compensate`]). The channels are independent and each
    /// correction is linear in the sums with constant coefficients, so applied one after
    /// the other they stay unbiased (docs/model.md#bcls). `g` \[m/s²\] is gravity.
    pub fn compensated(&self, g: f64, noise: &NoiseLevels) -> Moments {
        let mut m = *self;
        for (channel, &sd) in noise.iter() {
            if sd > 0.0 {
                m = m.compensate(channel, sd, g);
            }
        }
        m
    }

    /// The sums corrected for `channel`'s noise at SD `sd` (docs/model.md#bcls): each sum
    /// gets the expectation it would have without that channel's noise, the other channels
    /// left as they are (the channel's [`ChannelTerms::compensate`](super::channels::ChannelTerms::compensate)).
    pub fn compensate(&self, channel: Channel, sd: f64, g: f64) -> Moments {
        channel.compensate(self, sd, g)
    }

    fn system(
        &self,
        k: f64,
        s_1w: f64,
        s_3w: f64,
        s_ww: f64,
        s_wy: f64,
    ) -> (Matrix3<f64>, Vector3<f64>) {
        let a = Matrix3::new(
            self.s_11,
            -k * s_1w,
            self.s_13,
            -k * s_1w,
            k * k * s_ww,
            -k * s_3w,
            self.s_13,
            -k * s_3w,
            self.s_33,
        );
        let b = Vector3::new(self.s_1y, -k * s_wy, self.s_3y);
        (a, b)
    }
}
