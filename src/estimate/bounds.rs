//! The bounds and predicted spreads of the vehicle regression: `crlb_output` and
//! `thesis_bound` (σ² A⁻¹), `eiv_sandwich` and `eiv_crlb_linearized` from the first-order
//! equation-error variance Ω (see docs/model.md#bounds).

use nalgebra::{Matrix3, Vector3};

use super::channels::{Channel, GradeLoading, NoiseLevels, OmegaAt};
use super::regression::{Regression, ar1_coefficients};
use crate::numeric::linalg::{SolveError, inverse_spd};
use crate::numeric::sum::ExactSum;

impl Regression {
    /// First-order variance Ω_i of the equation error u_i = ỹ_i − x̃_iᵀθ at each sample:
    /// `θ₂²k²(4V²σ_v² + 2σ_v⁴) + θ₁²σ_F² + g²(cos θ − θ₃ sin θ)²σ_θ² + σ_y²`, each channel's
    /// term its [`Channel::omega_term`].
    pub fn equation_error_variance(&self, theta: &[f64; 3], noise: &NoiseLevels) -> Vec<f64> {
        self.row_variance(theta, noise, true)
    }

    /// Ω_i, with or without the speed noise's term.
    fn row_variance(&self, theta: &[f64; 3], noise: &NoiseLevels, with_speed: bool) -> Vec<f64> {
        let mut noise = *noise;
        if !with_speed {
            noise[Channel::Velocity] = 0.0;
        }
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
    /// (XᵀX)⁻¹ XᵀΩX (XᵀX)⁻¹ with the noise-free X; returns the standard errors.
    pub fn sandwich_se(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
    ) -> Result<[f64; 3], SolveError> {
        let cov = self.sandwich_covariance(theta, noise)?;
        Ok([0, 1, 2].map(|i| cov[(i, i)].sqrt()))
    }

    /// The covariance matrix of [`Regression::sandwich_se`].
    pub fn sandwich_covariance(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
    ) -> Result<Matrix3<f64>, SolveError> {
        let bread = inverse_spd(&self.xtx)?;
        let meat = if noise.speed_noise_differentiated() {
            self.weighted_gram(&self.row_variance(theta, noise, false))
                + self.differentiated_speed_meat(theta, noise)
        } else {
            let omega = self.equation_error_variance(theta, noise);
            let mut meat = self.weighted_gram(&omega);
            if noise.velocity_correlated() {
                meat += self.correlated_speed_meat(theta, noise);
            }
            meat
        };
        Ok(bread * meat * bread)
    }

    /// The off-diagonal part of XᵀΣX for AR(1) speed noise: the equation errors of samples
    /// i ≠ j covary as (kθ₂)² (4 V_i V_j ρ_ij σ² + 2 ρ_ij² σ⁴), ρ_ij = Π φ_k between them
    /// (Gaussian e: Cov(e_i², e_j²) = 2ρ²σ⁴, Cov(e_i, e_j²) = 0). Summed in O(N) by the
    /// recursion G_i = φ_i (G_{i−1} + a_{i−1} x_{i−1}) = Σ_{j<i} ρ_ij a_j x_j.
    fn correlated_speed_meat(&self, theta: &[f64; 3], noise: &NoiseLevels) -> Matrix3<f64> {
        let sd = noise[Channel::Velocity];
        let scale = (theta[1] * self.k).powi(2);
        let phi = ar1_coefficients(&self.t, noise.velocity_correlation_s);
        let x = |i: usize| Vector3::new(self.f[i], -self.k * self.v[i] * self.v[i], self.c[i]);
        // (weight a_i, per-step factor, coefficient): the ρ term and the ρ² term.
        let mut total = Matrix3::zeros();
        for (square, coefficient) in [(false, 4.0 * sd * sd), (true, 2.0 * sd.powi(4))] {
            let a = |i: usize| if square { 1.0 } else { self.v[i] };
            let mut g = Vector3::zeros();
            let mut half = Matrix3::zeros();
            for (i, [p, _]) in phi.iter().enumerate().skip(1) {
                let step = if square { p * p } else { *p };
                g = step * (g + a(i - 1) * x(i - 1));
                half += a(i) * x(i) * g.transpose();
            }
            total += coefficient * (half + half.transpose());
        }
        scale * total
    }

    /// The speed noise's part of XᵀΣX when the acceleration is differentiated from the
    /// measured speed. Row i's equation error carries σ_v Σ_j L_ij e_j with
    /// L_{i,s} = 2kθ₂V_i (through Ṽ²), L_{i,s±1} = ±1/Δt_i (through ỹ), s the row's sample,
    /// plus kθ₂σ_v²(e_s² − 1). With loadings g_j = Σ_i L_ij x_i per logged sample j:
    ///
    /// ```text
    /// σ_v² Σ_jl ρ_jl g_j g_lᵀ + 2 σ_v⁴ (kθ₂)² Σ_ii' ρ_ss'² x_i x_i'ᵀ
    /// ```
    ///
    /// (ρ = 1 on the diagonal and 0 off it for white noise; for AR(1) the products of φ,
    /// summed in O(N) by the recursion of [`correlated_speed_meat`](Self::correlated_speed_meat)).
    fn differentiated_speed_meat(&self, theta: &[f64; 3], noise: &NoiseLevels) -> Matrix3<f64> {
        let d = self
            .differentiation
            .as_ref()
            .expect("a differentiated acceleration has its span");
        let sd = noise[Channel::Velocity];
        let kt = self.k * theta[1];
        let x = |i: usize| Vector3::new(self.f[i], -self.k * self.v[i] * self.v[i], self.c[i]);
        let mut g = vec![Vector3::zeros(); d.span_t.len()];
        for i in 0..self.len() {
            let (s, xi) = (d.sample[i], x(i));
            g[s] += 2.0 * kt * self.v[i] * xi;
            g[s + 1] += d.inv_dt[i] * xi;
            g[s - 1] -= d.inv_dt[i] * xi;
        }
        // The correlation between neighbours of a sequence at times `t` (ρ, or ρ² for the
        // squares); none for white noise.
        let steps = |t: &[f64], square: bool| -> Option<Vec<f64>> {
            noise.velocity_correlated().then(|| {
                ar1_coefficients(t, noise.velocity_correlation_s)
                    .iter()
                    .map(|[phi, _]| if square { phi * phi } else { *phi })
                    .collect()
            })
        };
        // Σ_jl ρ_jl a_j a_lᵀ over a sequence with correlation `steps` between neighbours.
        let banded = |a: &dyn Fn(usize) -> Vector3<f64>, n: usize, steps: Option<Vec<f64>>| {
            let mut total = Matrix3::zeros();
            for j in 0..n {
                total += a(j) * a(j).transpose();
            }
            if let Some(steps) = steps {
                let mut carried = Vector3::zeros();
                for (j, &step) in steps.iter().enumerate().skip(1) {
                    carried = step * (carried + a(j - 1));
                    let half = a(j) * carried.transpose();
                    total += half + half.transpose();
                }
            }
            total
        };
        let linear = banded(&|j| g[j], g.len(), steps(&d.span_t, false));
        let square = banded(&x, self.len(), steps(&self.t, true));
        sd * sd * linear + 2.0 * sd.powi(4) * kt * kt * square
    }

    /// `eiv_crlb_linearized`: (XᵀΩ⁻¹X)⁻¹, the Cramér–Rao bound of the linearised
    /// equation-error model with independent Gaussian errors of variance Ω_i (the best a
    /// weighted, unbiased estimator could do); returns the standard errors.
    pub fn linearized_crlb_se(
        &self,
        theta: &[f64; 3],
        noise: &NoiseLevels,
    ) -> Result<[f64; 3], SolveError> {
        let inv_omega: Vec<f64> = self
            .equation_error_variance(theta, noise)
            .iter()
            .map(|o| 1.0 / o)
            .collect();
        let info = self.weighted_gram(&inv_omega);
        let cov = inverse_spd(&info)?;
        Ok([0, 1, 2].map(|i| cov[(i, i)].sqrt()))
    }
}

/// sqrt(diag(σ² A⁻¹)) for a normal matrix `a`: the standard errors of a covariance σ² A⁻¹.
pub fn scaled_inverse_sd(a: &Matrix3<f64>, sd: f64) -> Result<[f64; 3], SolveError> {
    let inv = inverse_spd(a)?;
    Ok([0, 1, 2].map(|i| sd * inv[(i, i)].sqrt()))
}

/// The thesis's bound sqrt(diag((X̃ᵀX̃/σ_v²)⁻¹)) from a realisation's noisy X̃ᵀX̃ (`None`
/// without speed noise, or when X̃ᵀX̃ is singular).
pub fn thesis_bound(noisy_xtx: &Matrix3<f64>, noise: &NoiseLevels) -> Option<[f64; 3]> {
    if noise.is_on(Channel::Velocity) {
        scaled_inverse_sd(noisy_xtx, noise[Channel::Velocity]).ok()
    } else {
        None
    }
}

/// How a bound's standard errors are obtained.
#[derive(Debug, Clone, Copy)]
pub enum BoundValue {
    /// The same in every realisation of a condition: from the noise-free regression, the
    /// truth θ and the noise levels.
    Constant(fn(&Regression, &[f64; 3], &NoiseLevels) -> Option<[f64; 3]>),
    /// Per realisation, from the noisy X̃ᵀX̃ of the realisation and the noise levels.
    PerRealisation(fn(&Matrix3<f64>, &NoiseLevels) -> Option<[f64; 3]>),
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
        applies: |n| n.is_on(Channel::Velocity),
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
        value: BoundValue::Constant(|reg, _, n| {
            scaled_inverse_sd(&reg.xtx, n[Channel::Output]).ok()
        }),
        not_valid: None,
    },
    Bound {
        kind: BoundKind::EivSandwich,
        name: "eiv_sandwich",
        description: "first-order covariance (XᵀX)⁻¹ XᵀΣX (XᵀX)⁻¹ of OLS/BCLS under regressor noise, Σ the covariance of the equation errors (diagonal Ω; banded for AR(1) speed noise and for a differentiated acceleration)",
        applies: NoiseLevels::in_regressors,
        value: BoundValue::Constant(|reg, theta, n| reg.sandwich_se(theta, n).ok()),
        not_valid: None,
    },
    Bound {
        kind: BoundKind::EivCrlbLinearized,
        name: "eiv_crlb_linearized",
        description: "(XᵀΩ⁻¹X)⁻¹: the bound of the linearised equation-error model (what a weighted unbiased estimator could reach); independent rows only (not reported under correlated or differentiated speed noise)",
        applies: |n| n.in_regressors() && n.independent_rows(),
        value: BoundValue::Constant(|reg, theta, n| reg.linearized_crlb_se(theta, n).ok()),
        not_valid: None,
    },
];
