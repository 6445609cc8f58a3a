//! Each channel's terms of the covariance of the equation errors (docs/model.md#bounds):
//! its term of the first-order variance Ω of a row, and, for noise that rows share with
//! their neighbours, its part of XᵀΣX off the diagonal, the variance a differentiated
//! acceleration adds to ỹ and how far its correlation reaches. The sandwich, `eiv_crlb_linearized`
//! and `wbcls` ask these; none of them knows a channel's internals.

use nalgebra::{Matrix3, Vector3};

use super::{CHANNEL_COUNT, Channel, NoiseLevels};

/// Where the first-order equation-error variance Ω is evaluated (docs/model.md#bounds): the
/// estimate and the quantities of a row, or of a segment as local means, that the
/// channels' terms read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OmegaAt {
    /// θ = \[1/M, Cd/M, Cr\] at which Ω is evaluated.
    pub theta: [f64; 3],
    /// k of the regression's column 2 (−k w).
    pub k: f64,
    /// V² \[m²/s²\].
    pub v2: f64,
    /// What the grade noise's term is loaded with.
    pub grade: GradeLoading,
}

/// The loading of the grade noise's term of Ω.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GradeLoading {
    /// At a noise-free row: gravity g \[m/s²\] and the slope cos θ − θ₃ sin θ of
    /// d/dθ \[sin θ + θ₃ cos θ\]; the term is (g σ_θ)² slope².
    Row {
        /// Gravity \[m/s²\].
        g: f64,
        /// cos θ − θ₃ sin θ.
        slope: f64,
    },
    /// A local mean of x̃₃² = g² cos² θ̃ \[m²/s⁴\] (the θ₃ sin θ part, below 0.3 % of it,
    /// left out); the term is σ_θ² times it.
    MeanSquare(f64),
}

impl Channel {
    /// The channels in the order their terms of Ω are added (fixed: the bounds' and the
    /// weighted estimator's bits depend on it).
    pub const OMEGA_ORDER: [Channel; CHANNEL_COUNT] = {
        // Rank r's channel at r: every rank 0..CHANNEL_COUNT taken once (else no build).
        let mut order = [Channel::ALL[0]; CHANNEL_COUNT];
        let mut taken = [false; CHANNEL_COUNT];
        let mut i = 0;
        while i < CHANNEL_COUNT {
            let rank = Channel::ALL[i].omega_rank();
            assert!(
                rank < CHANNEL_COUNT && !taken[rank],
                "the Ω ranks are 0, 1, … once each"
            );
            taken[rank] = true;
            order[rank] = Channel::ALL[i];
            i += 1;
        }
        order
    };
}

/// A channel's part of the sandwich's XᵀΣX that a diagonal of Ω terms does not hold: the
/// covariance of rows that share its noise ([`Channel::row_covariance`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowCovariance {
    /// Its part of XᵀΣX, added to XᵀΩX.
    pub meat: Matrix3<f64>,
    /// True when `meat` holds the channel's diagonal too (its [`Channel::omega_term`] is
    /// then left out of Ω).
    pub replaces_omega_term: bool,
}

impl Channel {
    /// True when rows share this channel's noise under `noise` (correlated in time, or
    /// entering neighbouring rows).
    pub fn shares_rows(self, noise: &NoiseLevels) -> bool {
        self.correlation_time_s(noise) > 0.0 || self.enters_neighbours(noise)
    }
}

/// One channel's terms of the variance of the compensated estimating function
/// ψ = x̃ũ − E\[x̃ũ\] at a row beyond the first-order x xᵀ Ω (docs/model.md#compensated-sandwich).
/// A channel that moves a regressor by Δ (zero mean after compensation) and the equation
/// error by ε adds its own second-order variance, and, with every other channel c′,
/// E\[ΔΔᵀ\]·Ω_c′ and E\[Δε\]·E\[Δ′ε′\]ᵀ (the channels are independent).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SecondOrder {
    /// Var of its own second-order part, and that part's covariance with its first-order
    /// part (both ways).
    pub own: Matrix3<f64>,
    /// E\[ΔΔᵀ\]: the covariance of its perturbation of the compensated regressors.
    pub perturbation: Matrix3<f64>,
    /// E\[Δε\]: the perturbation's covariance with its equation error.
    pub loading: Vector3<f64>,
}

impl SecondOrder {
    /// No terms beyond the first order.
    pub const NONE: SecondOrder = SecondOrder {
        own: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        perturbation: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        loading: Vector3::new(0.0, 0.0, 0.0),
    };
}
