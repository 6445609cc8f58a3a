//! Performance measures and their Monte Carlo standard errors (Morris, White & Crowther
//! 2019, "Using simulation studies to evaluate statistical methods", Stat Med 38:2074,
//! Table 6), computed from centred sums so that no large quantity is subtracted from
//! another.
//!
//! Notation: n realisations with estimates θ̂_i of a truth θ, mean θ̄, S² the sample
//! variance, d_i = θ̂_i − θ, b_i the per-realisation value of a bound (a model SE).

use statrs::distribution::{ChiSquared, ContinuousCDF};

/// The normal quantile of the nominal 95 % intervals θ̂ ± z·SE.
pub const Z_95: f64 = 1.959963984540054;

/// A value and its Monte Carlo standard error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The Monte Carlo estimate.
    pub value: f64,
    /// Its Monte Carlo standard error.
    pub mcse: f64,
}

impl Estimate {
    /// A value with its MCSE.
    pub fn new(value: f64, mcse: f64) -> Self {
        Estimate { value, mcse }
    }

    /// Both NaN: the measure is undefined here (e.g. n < 2).
    pub fn undefined() -> Self {
        Estimate::new(f64::NAN, f64::NAN)
    }
}

/// Sums of the estimates of one parameter over n realisations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimateSums {
    /// Number of realisations n.
    pub n: f64,
    /// Σ (θ̂_i − θ).
    pub sum_d: f64,
    /// Σ (θ̂_i − θ̄)².
    pub sum_centred_sq: f64,
    /// Σ (θ̂_i − θ)².
    pub sum_d_sq: f64,
    /// Σ ((θ̂_i − θ)² − MSE)².
    pub sum_sq_dev_sq: f64,
}

/// Mean of the estimates, MCSE S/√n.
pub fn mean(truth: f64, s: &EstimateSums) -> Estimate {
    Estimate::new(truth + s.sum_d / s.n, emp_se(s).value / s.n.sqrt())
}

/// Bias E[θ̂] − θ, MCSE √(S²/n).
pub fn bias(s: &EstimateSums) -> Estimate {
    Estimate::new(s.sum_d / s.n, emp_se(s).value / s.n.sqrt())
}

/// Relative bias (E[θ̂] − θ)/θ, MCSE √(S²/n)/|θ|.
pub fn relative_bias(truth: f64, s: &EstimateSums) -> Estimate {
    let b = bias(s);
    Estimate::new(b.value / truth, b.mcse / truth.abs())
}

/// Empirical SE, S = √(Σ(θ̂ − θ̄)²/(n − 1)), MCSE S/√(2(n − 1)).
pub fn emp_se(s: &EstimateSums) -> Estimate {
    if s.n < 2.0 {
        return Estimate::undefined();
    }
    let se = (s.sum_centred_sq / (s.n - 1.0)).sqrt();
    Estimate::new(se, se / (2.0 * (s.n - 1.0)).sqrt())
}

/// Mean squared error Σd²/n, MCSE √(Σ[d² − MSE]² / (n(n − 1))).
pub fn mse(s: &EstimateSums) -> Estimate {
    if s.n < 2.0 {
        return Estimate::undefined();
    }
    Estimate::new(
        s.sum_d_sq / s.n,
        (s.sum_sq_dev_sq / (s.n * (s.n - 1.0))).sqrt(),
    )
}

/// Root MSE, MCSE by the delta method: MCSE(MSE) / (2 RMSE).
pub fn rmse(s: &EstimateSums) -> Estimate {
    let m = mse(s);
    let r = m.value.sqrt();
    Estimate::new(r, m.mcse / (2.0 * r))
}

/// Sums of one bound's per-realisation values b_i over the n realisations where it exists.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundSums {
    /// Number of realisations with a bound value.
    pub n: f64,
    /// Σ b_i².
    pub sum_b_sq: f64,
    /// Σ (b_i² − mean b²)².
    pub sum_b_sq_dev_sq: f64,
}

impl BoundSums {
    /// Sample variance of b² over realisations (0 for a bound constant per condition).
    fn var_b_sq(&self) -> f64 {
        if self.n < 2.0 {
            0.0
        } else {
            self.sum_b_sq_dev_sq / (self.n - 1.0)
        }
    }
}

/// Model SE, ModSE = √(mean b²), MCSE √(Var(b²) / (4 n ModSE²)).
pub fn model_se(b: &BoundSums) -> Estimate {
    let se = (b.sum_b_sq / b.n).sqrt();
    Estimate::new(se, (b.var_b_sq() / (4.0 * b.n * se * se)).sqrt())
}

/// EmpSE / ModSE, MCSE by the delta method (the two MCSEs treated as independent):
/// ratio · √(1/(2(n − 1)) + Var(b²)/(4 n ModSE⁴)).
pub fn emp_over_model(s: &EstimateSums, b: &BoundSums) -> Estimate {
    let e = emp_se(s);
    let m = model_se(b);
    let ratio = e.value / m.value;
    let rel = (1.0 / (2.0 * (s.n - 1.0)) + b.var_b_sq() / (4.0 * b.n * m.value.powi(4))).sqrt();
    Estimate::new(ratio, ratio * rel)
}

/// Relative error of the model SE in percent, 100 (ModSE/EmpSE − 1), MCSE
/// 100 (ModSE/EmpSE) √(Var(b²)/(4 n ModSE⁴) + 1/(2(n − 1))) (Morris et al. Table 6).
pub fn model_se_relative_error(s: &EstimateSums, b: &BoundSums) -> Estimate {
    let e = emp_se(s);
    let m = model_se(b);
    let ratio = m.value / e.value;
    let rel = (b.var_b_sq() / (4.0 * b.n * m.value.powi(4)) + 1.0 / (2.0 * (s.n - 1.0))).sqrt();
    Estimate::new(100.0 * (ratio - 1.0), 100.0 * ratio * rel)
}

/// A coverage proportion from `covered` of `n`, MCSE √(p(1 − p)/n).
pub fn coverage(covered: f64, n: f64) -> Estimate {
    let p = covered / n;
    Estimate::new(p, (p * (1.0 - p) / n).sqrt())
}

/// Relative precision of estimator B against reference A in percent,
/// 100 ((S_A/S_B)² − 1), MCSE ≈ 200 (S_A/S_B)² √((1 − ρ²)/(n − 1)) with ρ the correlation
/// of the two estimators over realisations (Morris et al. Table 6).
pub fn relative_precision(a: &EstimateSums, b: &EstimateSums, sum_cross: f64) -> Estimate {
    let va = a.sum_centred_sq;
    let vb = b.sum_centred_sq;
    let ratio = va / vb;
    let rho = sum_cross / (va * vb).sqrt();
    let n = a.n.min(b.n);
    Estimate::new(
        100.0 * (ratio - 1.0),
        200.0 * ratio * ((1.0 - rho * rho).max(0.0) / (n - 1.0)).sqrt(),
    )
}

/// Two-sided p-value of the variance-ratio test of H₀: Var(θ̂) = ModSE²:
/// T = (n − 1) S² / ModSE² ~ χ²(n − 1) under normal estimates.
pub fn variance_ratio_p(s: &EstimateSums, b: &BoundSums) -> f64 {
    if s.n < 2.0 {
        return f64::NAN;
    }
    let m = model_se(b).value;
    let t = s.sum_centred_sq / (m * m);
    let Ok(chi2) = ChiSquared::new(s.n - 1.0) else {
        return f64::NAN;
    };
    let lower = chi2.cdf(t);
    let upper = chi2.sf(t);
    (2.0 * lower.min(upper)).min(1.0)
}

/// The spread of the estimates by the second moment's control variates
/// (docs/model.md#spread-control-variates), from the estimate V̂ of Var θ̂ and b̂ of the bias,
/// their MCSEs squared and their covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpreadCv {
    /// Var θ̂.
    pub variance: Estimate,
    /// EmpSE = √Var, MCSE MCSE(Var)/(2 EmpSE).
    pub emp_se: Estimate,
    /// MSE = Var + b̂² − MCSE(b̂)² (b̂² less its own noise), MCSE
    /// √(Var(V̂) + 4b̂² Var(b̂) + 4b̂ Cov(V̂, b̂)).
    pub mse: Estimate,
    /// RMSE = √MSE, MCSE MCSE(MSE)/(2 RMSE).
    pub rmse: Estimate,
}

impl SpreadCv {
    /// From V̂ = `variance` and b̂ = `bias`, their MCSEs squared (`variance_var`,
    /// `bias_var`) and covariance; EmpSE and RMSE undefined where their square is not
    /// positive.
    pub fn new(
        variance: f64,
        variance_var: f64,
        bias: f64,
        bias_var: f64,
        covariance: f64,
    ) -> Self {
        let mse = variance + bias * bias - bias_var;
        // Rounding can take the sum a hair below 0; NaN stays NaN.
        let mse_var = variance_var + 4.0 * bias * bias * bias_var + 4.0 * bias * covariance;
        let mse_var = if mse_var < 0.0 { 0.0 } else { mse_var };
        let root = |e: Estimate| {
            if e.value > 0.0 {
                let r = e.value.sqrt();
                Estimate::new(r, e.mcse / (2.0 * r))
            } else {
                Estimate::undefined()
            }
        };
        let variance = Estimate::new(variance, variance_var.sqrt());
        let mse = Estimate::new(mse, mse_var.sqrt());
        SpreadCv {
            variance,
            emp_se: root(variance),
            mse,
            rmse: root(mse),
        }
    }

    /// Every measure undefined.
    pub fn undefined() -> Self {
        SpreadCv {
            variance: Estimate::undefined(),
            emp_se: Estimate::undefined(),
            mse: Estimate::undefined(),
            rmse: Estimate::undefined(),
        }
    }

    /// EmpSE / ModSE with the control-variate EmpSE, MCSE
    /// ratio · √((MCSE(EmpSE)/EmpSE)² + Var(b²)/(4 n ModSE⁴)) (the two independent).
    pub fn emp_over_model(&self, b: &BoundSums) -> Estimate {
        let e = self.emp_se;
        let m = model_se(b);
        let ratio = e.value / m.value;
        let rel =
            ((e.mcse / e.value).powi(2) + b.var_b_sq() / (4.0 * b.n * m.value.powi(4))).sqrt();
        Estimate::new(ratio, ratio * rel)
    }

    /// Two-sided p of H₀: Var θ̂ = ModSE², from the control-variate variance and the mean
    /// of b² (normal): z = (Var − ModSE²) / √(MCSE(Var)² + Var(b²)/n).
    pub fn variance_ratio_p(&self, b: &BoundSums) -> f64 {
        let m = model_se(b).value;
        let se = (self.variance.mcse.powi(2) + b.var_b_sq() / b.n).sqrt();
        let z = (self.variance.value - m * m) / se;
        if !z.is_finite() {
            return f64::NAN;
        }
        statrs::function::erf::erfc(z.abs() / std::f64::consts::SQRT_2).min(1.0)
    }
}
