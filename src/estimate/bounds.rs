//! The bounds and predicted spreads of the vehicle regression: `crlb_output` and
//! `thesis_bound` (σ² A⁻¹), `eiv_sandwich` and `eiv_crlb_linearized` from the first-order
//! equation-error variance Ω (see docs/model.md#bounds).

use nalgebra::Matrix3;

use super::channels::{
    Channel, GradeLoading, NoiseLevels, OmegaAt, RowCovariance, SecondOrder, Signal,
};
use super::parameters::Parameters;
use super::regression::Regression;
use crate::numeric::linalg::SolveError;
use crate::numeric::sum::ExactSum;

impl Regression {
    /// First-order variance Ω_i of the equation error u_i = ỹ_i − x̃_iᵀθ at each sample:
    /// `θ₂²k²(4V²σ_v² + 2σ_v⁴) + θ₁²σ_F² + g²(cos θ − θ₃ sin θ)²σ_θ² + σ_y²`, each channel's
    /// term its [`Channel::omega_term`].
    pub fn equation_error_variance(&self, theta: &[f64; 3], noise: &NoiseLevels) -> Vec<f64> {
        self.row_variance(theta, noise)
    }

    /// Ω_i under `noise` (whose channels' SDs may differ from the condition's: the
    /// sandwich zeroes those whose terms its banded part holds).
    fn row_variance(&self, theta: &[f64; 3], noise: &NoiseLevels) -> Vec<f64> {
        (0..self.len())
            .map(|i| {
                noise.omega(&OmegaAt {
                    theta: *theta,
                    k: self.k,
                    v2: self.v[i] * self.v[i],
                    grade: GradeLoading::Row {
                        g: self.g,
                        slope: self.cos_grade[i] - theta[2] * self.sin_grade[i],
                    },
                })
            })
            .collect()
    }

    /// Σ wᵢ xᵢ xᵢᵀ over the noise-free rows, with exactly rounded entries.
    pub(crate) fn weighted_gram(&self, weight: &[f64]) -> Matrix3<f64> {
        let mut sums: [ExactSum; 6] = Default::default();
        for (i, &w) in weight.iter().enumerate() {
            let x = [self.f[i], -self.k * self.v[i] * self.v[i], self.c[i]];
            sums[0].add(w * x[0] * x[0]);
            sums[1].add(w * x[0] * x[1]);
            sums[2].add(w * x[0] * x[2]);
            sums[3].add(w * x[1] * x[1]);
            sums[4].add(w * x[1] * x[2]);
            sums[5].add(w * x[2] * x[2]);
        }
        let s: Vec<f64> = sums.iter().map(ExactSum::value).collect();
        Matrix3::new(s[0], s[1], s[2], s[1], s[3], s[4], s[2], s[4], s[5])
    }

    /// `eiv_sandwich`: the first-order covariance of OLS (and BCLS) under regressor noise,
    /// (XᵀX)⁻¹ XᵀΩX (XᵀX)⁻¹ with the noise-free X, over the fitted `parameters`; returns the
    /// standard errors (0 for a known parameter).
    pub fn sandwich_se(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
        parameters: Parameters,
    ) -> Result<[f64; 3], SolveError> {
        let cov = self.sandwich_covariance(theta, noise, parameters)?;
        Ok([0, 1, 2].map(|i| cov[(i, i)].sqrt()))
    }

    /// The covariance matrix of [`Regression::sandwich_se`]: (XᵀX)⁻¹ XᵀΣX (XᵀX)⁻¹ with
    /// XᵀΣX = XᵀΩX plus each channel's [`Channel::row_covariance`]; (XᵀX)⁻¹ over the fitted
    /// `parameters` ([`Parameters::inverse`]: the equation error keeps the known θ₁'s
    /// term, the bread only the free block).
    pub fn sandwich_covariance(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
        parameters: Parameters,
    ) -> Result<Matrix3<f64>, SolveError> {
        let bread = parameters.inverse(&self.xtx)?;
        // The channels whose noise rows share add their banded parts of XᵀΣX
        // (docs/model.md#bounds), some in place of their diagonal Ω terms.
        let shared: Vec<(Channel, RowCovariance)> = Channel::ALL
            .into_iter()
            .filter_map(|c| c.row_covariance(self, theta, noise).map(|m| (c, m)))
            .collect();
        let mut diagonal = *noise;
        for (c, m) in &shared {
            if m.replaces_omega_term {
                diagonal[*c] = 0.0;
            }
        }
        let mut meat = self.weighted_gram(&self.row_variance(theta, &diagonal));
        for (_, m) in &shared {
            meat += m.meat;
        }
        Ok(bread * meat * bread)
    }

    /// The sandwich of an estimator that compensates the noise's bias with its moments
    /// (BCLS): [`Regression::sandwich_covariance`] with, in XᵀΣX, the variance the
    /// compensation leaves beyond the first order ([`Regression::compensation_meat`]).
    /// Returns the standard errors.
    pub fn compensated_sandwich_se(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
        parameters: Parameters,
    ) -> Result<[f64; 3], SolveError> {
        let cov = self.compensated_sandwich_covariance(theta, noise, parameters)?;
        Ok([0, 1, 2].map(|i| cov[(i, i)].sqrt()))
    }

    /// The covariance matrix of [`Regression::compensated_sandwich_se`].
    pub fn compensated_sandwich_covariance(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
        parameters: Parameters,
    ) -> Result<Matrix3<f64>, SolveError> {
        let bread = parameters.inverse(&self.xtx)?;
        let first = self.sandwich_covariance(theta, noise, parameters)?;
        Ok(first + bread * self.compensation_meat(theta, noise) * bread)
    }

    /// Σᵢ of each row's terms of the compensated estimating function's variance beyond the
    /// first order (docs/model.md#compensated-sandwich): every channel's own
    /// [`SecondOrder`] terms, and for every pair of channels c ≠ c′ E\[Δ_cΔ_cᵀ\] Ω_c′ +
    /// E\[Δ_c ε_c\] E\[Δ_c′ ε_c′\]ᵀ. Second order in the noise: it matters where a regressor's
    /// own spread along the rows is not large against its noise (force noise on a nearly
    /// constant F).
    pub fn compensation_meat(&self, theta: &[f64; 3], noise: &NoiseLevels) -> Matrix3<f64> {
        // AR(1) speed noise whose correlation does not reach the next sample (φ = 0 at
        // every step) is white noise, and has white noise's terms.
        let mut noise = *noise;
        if noise.velocity_correlated()
            && !noise.speed_noise_differentiated()
            && self
                .ar1_coefficients(noise.velocity_correlation_s)
                .iter()
                .all(|[phi, _]| *phi == 0.0)
        {
            noise.velocity_correlation_s = 0.0;
        }
        let noise = &noise;
        let mut meat = Matrix3::zeros();
        for i in 0..self.len() {
            let at = OmegaAt {
                theta: *theta,
                k: self.k,
                v2: self.v[i] * self.v[i],
                grade: GradeLoading::Row {
                    g: self.g,
                    slope: self.cos_grade[i] - theta[2] * self.sin_grade[i],
                },
            };
            let x = [self.f[i], -self.k * self.v[i] * self.v[i], self.c[i]];
            let mut omega_total = 0.0;
            let mut terms: Vec<(SecondOrder, f64)> = Vec::new();
            for c in Channel::OMEGA_ORDER {
                let sd = noise[c];
                if sd > 0.0 {
                    let omega = c.omega_term(sd, &at);
                    omega_total += omega;
                    terms.push((c.second_order(sd, noise, &at, &x), omega));
                }
            }
            let loading_sum = terms
                .iter()
                .fold(nalgebra::Vector3::zeros(), |l, (t, _)| l + t.loading);
            for (t, omega) in &terms {
                meat += t.own + t.perturbation * (omega_total - omega)
                    - t.loading * t.loading.transpose();
            }
            meat += loading_sum * loading_sum.transpose();
        }
        meat
    }

    /// `eiv_crlb_linearized`: (XᵀΩ⁻¹X)⁻¹, the Cramér–Rao bound of the linearised
    /// equation-error model with independent Gaussian errors of variance Ω_i (the best a
    /// weighted, unbiased estimator could do), over the fitted `parameters`; returns the
    /// standard errors.
    pub fn linearized_crlb_se(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
        parameters: Parameters,
    ) -> Result<[f64; 3], SolveError> {
        let cov = self.linearized_crlb_covariance(theta, noise, parameters)?;
        Ok([0, 1, 2].map(|i| cov[(i, i)].sqrt()))
    }

    /// The covariance matrix of [`Regression::linearized_crlb_se`].
    pub fn linearized_crlb_covariance(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
        parameters: Parameters,
    ) -> Result<Matrix3<f64>, SolveError> {
        let inv_omega: Vec<f64> = self
            .equation_error_variance(theta, noise)
            .iter()
            .map(|o| 1.0 / o)
            .collect();
        let info = self.weighted_gram(&inv_omega);
        parameters.inverse(&info)
    }

    /// The covariance matrix of the first bound among `crlb_output`, `eiv_sandwich` and
    /// `eiv_crlb_linearized` that applies to `noise` and for which `reports` holds (an
    /// estimator's spread: what `design` predicts it by), and which bound it is; `None`
    /// where none applies or its matrix is singular.
    pub fn predicted_covariance(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
        parameters: Parameters,
        spread: Spread,
        reports: impl Fn(&Bound) -> bool,
    ) -> Option<(BoundKind, Matrix3<f64>)> {
        [
            BoundKind::CrlbOutput,
            BoundKind::EivSandwich,
            BoundKind::EivCrlbLinearized,
        ]
        .into_iter()
        .find(|&k| {
            let bound = &BOUNDS[k.index()];
            (bound.applies)(noise) && reports(bound)
        })
        .and_then(|kind| {
            let cov = match (kind, spread) {
                (BoundKind::CrlbOutput, _) => parameters
                    .inverse(&self.xtx)
                    .map(|inv| inv * noise.sd_of(Signal::Acceleration).powi(2)),
                (BoundKind::EivSandwich, Spread::Plain) => {
                    self.sandwich_covariance(theta, noise, parameters)
                }
                (BoundKind::EivSandwich, Spread::Compensated) => {
                    self.compensated_sandwich_covariance(theta, noise, parameters)
                }
                _ => self.linearized_crlb_covariance(theta, noise, parameters),
            };
            cov.ok().map(|c| (kind, c))
        })
    }
}

/// sqrt(diag(σ² A⁻¹)) for a normal matrix `a`, A⁻¹ over the fitted `parameters`: the
/// standard errors of a covariance σ² A⁻¹.
pub fn scaled_inverse_sd(
    a: &Matrix3<f64>,
    sd: f64,
    parameters: Parameters,
) -> Result<[f64; 3], SolveError> {
    let inv = parameters.inverse(a)?;
    Ok([0, 1, 2].map(|i| sd * inv[(i, i)].sqrt()))
}

/// The thesis's bound sqrt(diag((X̃ᵀX̃/σ_v²)⁻¹)) from a realisation's noisy X̃ᵀX̃ (`None`
/// without speed noise, or when X̃ᵀX̃ is singular), over the fitted `parameters`; σ_v is the
/// noise in w ([`NoiseLevels::speed_sd`]: the air-speed sensor's where it is measured).
pub fn thesis_bound(
    noisy_xtx: &Matrix3<f64>,
    noise: &NoiseLevels,
    parameters: Parameters,
) -> Option<[f64; 3]> {
    if noise.speed_sd() > 0.0 {
        scaled_inverse_sd(noisy_xtx, noise.speed_sd(), parameters).ok()
    } else {
        None
    }
}

/// A bound's standard errors from the noise-free regression, the truth θ, the noise levels,
/// the fitted parameters and the estimator's [`Spread`] (`None` where they cannot be
/// computed).
pub type ConstantBound =
    fn(&Regression, &[f64; 3], &NoiseLevels, Parameters, Spread) -> Option<[f64; 3]>;

/// What an estimator's spread is predicted from: the sandwich of its estimating function
/// differs between an estimator that takes the noisy sums as they are and one that
/// compensates them with the noise's moments, whose compensation adds variance of its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Spread {
    /// The noisy sums as they are (OLS and its kin): the first-order sandwich.
    Plain,
    /// The sums compensated by the noise's moments (BCLS): the first-order sandwich plus
    /// what the compensation adds (docs/model.md#compensated-sandwich).
    Compensated,
}

/// How a bound's standard errors are obtained.
#[derive(Debug, Clone, Copy)]
pub enum BoundValue {
    /// The same in every realisation of a condition: from the noise-free regression, the
    /// truth θ, the noise levels and the fitted parameters.
    Constant(ConstantBound),
    /// Per realisation, from the noisy X̃ᵀX̃ of the realisation, the noise levels and the
    /// fitted parameters.
    PerRealisation(fn(&Matrix3<f64>, &NoiseLevels, Parameters) -> Option<[f64; 3]>),
}

/// A bound or predicted standard error of the vehicle regression: one entry of [`BOUNDS`].
#[derive(Debug, Clone, Copy)]
pub struct Bound {
    /// Which bound it is, for the code that treats one bound apart.
    pub kind: BoundKind,
    /// Column prefix, e.g. `thesis_bound`.
    pub name: &'static str,
    /// What it is and when it is valid.
    pub description: &'static str,
    /// Whether it applies (and is reported) under these noise levels.
    pub applies: fn(&NoiseLevels) -> bool,
    /// How its standard errors are computed.
    pub value: BoundValue,
    /// Why, where it applies, it is not a bound on the estimates' spread (a clause that
    /// follows "is not a valid bound"); `None` for a valid one.
    pub not_valid: Option<&'static str>,
}

/// The bounds of [`BOUNDS`], by name in the code (their names in tables are the entries').
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoundKind {
    /// The thesis's bound, reported for fidelity.
    Thesis,
    /// The Cramér–Rao bound under output noise alone.
    CrlbOutput,
    /// The first-order sandwich covariance of OLS and BCLS.
    EivSandwich,
    /// The bound of the linearised equation-error model.
    EivCrlbLinearized,
}

impl BoundKind {
    /// Its position in [`BOUNDS`] (its columns' order).
    pub fn index(self) -> usize {
        BOUNDS
            .iter()
            .position(|b| b.kind == self)
            .expect("every kind has its entry in BOUNDS")
    }
}

/// Every bound of the vehicle model, in column order (see docs/model.md#bounds).
pub static BOUNDS: [Bound; 4] = [
    Bound {
        kind: BoundKind::Thesis,
        name: "thesis_bound",
        description: "sqrt(diag((X̃ᵀX̃/σ_v²)⁻¹)) with the noisy regressors (thesis eqs. 21, 40); reported under speed noise, where it is not a valid bound",
        applies: |n| n.speed_sd() > 0.0,
        value: BoundValue::PerRealisation(thesis_bound),
        not_valid: Some(
            " under speed noise: the noise is in the regressors, not in the output, and σ_v \
             [m/s] is not in the output's units",
        ),
    },
    Bound {
        kind: BoundKind::CrlbOutput,
        name: "crlb_output",
        description: "sqrt(diag(σ_y² (XᵀX)⁻¹)), noise-free X: the Cramér–Rao bound when output noise is the only noise",
        applies: NoiseLevels::output_only,
        value: BoundValue::Constant(|reg, _, n, p, _| {
            scaled_inverse_sd(&reg.xtx, n.sd_of(Signal::Acceleration), p).ok()
        }),
        not_valid: None,
    },
    Bound {
        kind: BoundKind::EivSandwich,
        name: "eiv_sandwich",
        description: "covariance (XᵀX)⁻¹ XᵀΣX (XᵀX)⁻¹ of OLS/BCLS under regressor noise, Σ the covariance of the equation errors (diagonal Ω; banded for AR(1) speed noise and for a differentiated acceleration); for BCLS with the variance its compensation adds (second order in the noise: force noise, and white speed noise with a model acceleration)",
        applies: NoiseLevels::in_regressors,
        value: BoundValue::Constant(|reg, theta, n, p, spread| match spread {
            Spread::Plain => reg.sandwich_se(theta, n, p).ok(),
            Spread::Compensated => reg.compensated_sandwich_se(theta, n, p).ok(),
        }),
        not_valid: None,
    },
    Bound {
        kind: BoundKind::EivCrlbLinearized,
        name: "eiv_crlb_linearized",
        description: "(XᵀΩ⁻¹X)⁻¹: the bound of the linearised equation-error model (what a weighted unbiased estimator could reach); independent rows only (not reported under correlated or differentiated speed noise)",
        applies: |n| n.in_regressors() && n.independent_rows(),
        value: BoundValue::Constant(|reg, theta, n, p, _| reg.linearized_crlb_se(theta, n, p).ok()),
        not_valid: None,
    },
];
