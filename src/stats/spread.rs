//! The spread of the estimates by control variates (docs/model.md#spread-control-variates).
//!
//! With u = d − d̄ regressed on the centred controls c̃ (u = α + βᵀc̃ + r, r uncorrelated
//! with the controls), Var u = βᵀΣβ + Var r, Σ the exact covariance of the controls. The
//! estimate V̂ = β̂ᵀΣβ̂ + s²(1 − tr ΣG⁻¹) is the sample variance of u minus the products of
//! the controls, Σⱼₖ β̂ⱼβ̂ₖ (Ĉov(cⱼ, cₖ) − Σⱼₖ), each of mean zero, and s² the residual
//! variance: only the residual's part of the spread is left to Monte Carlo. β̂ is known at
//! the end of pass one (from the uncentred Gram matrix there), so pass two has every
//! realisation's residual and leverage, and the MCSE is a sandwich (heteroscedasticity-
//! consistent, HC2: each squared residual over 1 − hᵢᵢ) one.

use super::control::Ldl;
use crate::estimate::channels::SumCovariances;
use crate::numeric::dd::Dd;
use crate::numeric::sum::ExactSum;

/// Pass one of a condition's spread: the uncentred Gram matrix Σ c cᵀ of its active
/// controls, with their exact covariances.
#[derive(Debug, Clone)]
pub(super) struct SpreadGram {
    /// Layout indices of the active controls.
    active: Vec<usize>,
    /// Σ cⱼcₖ, packed j ≤ k.
    gram: Vec<ExactSum>,
    /// Cov(cⱼ, cₖ), packed j ≤ k.
    covariance: Vec<f64>,
    /// The rounding each may carry.
    resolution: Vec<f64>,
}

/// Index of (a, b), a ≤ b, packed row by row in a q × q symmetric matrix.
fn packed(a: usize, b: usize, q: usize) -> usize {
    let (a, b) = (a.min(b), a.max(b));
    a * q - a * (a + 1) / 2 + b
}

impl SpreadGram {
    /// For the layout's controls that `applies` marks, with exact covariances `covariance`
    /// (packed over them).
    pub(super) fn new(applies: &[bool], covariance: &SumCovariances) -> Self {
        let active: Vec<usize> = (0..applies.len()).filter(|&j| applies[j]).collect();
        let q = active.len();
        assert_eq!(
            covariance.value.len(),
            q * (q + 1) / 2,
            "one covariance per pair"
        );
        SpreadGram {
            active,
            gram: vec![ExactSum::new(); covariance.value.len()],
            covariance: covariance.value.clone(),
            resolution: covariance.resolution.clone(),
        }
    }

    /// The exact accumulators held.
    pub(super) fn accumulators(&self) -> usize {
        self.gram.len()
    }

    /// Pass one: a realisation's controls (all of the layout's).
    pub(super) fn first(&mut self, controls: &[f64]) {
        let q = self.active.len();
        let mut k = 0;
        for a in 0..q {
            for b in a..q {
                self.gram[k].add(controls[self.active[a]] * controls[self.active[b]]);
                k += 1;
            }
        }
    }

    /// End of pass one, over `n` realisations whose controls sum to `sums` (Σc, exact)
    /// and are centred in pass two on `means` (c̄, rounded): the factorised Gram matrix
    /// Σ(c − c̄)(c − c̄)ᵀ; `None` when no control is independent of the others.
    pub(super) fn solver(&self, n: u64, sums: &[Dd], means: &[f64]) -> Option<SpreadSolver> {
        let q = self.active.len();
        let nf = Dd::from(n as f64);
        let g = |a: usize, b: usize| {
            let (ma, mb) = (Dd::from(means[a]), Dd::from(means[b]));
            self.gram[packed(a, b, q)].value_dd() - sums[a] * mb - sums[b] * ma + nf * ma * mb
        };
        let ldl = Ldl::new(q, g);
        let used = ldl.kept().iter().filter(|&&k| k).count();
        if used == 0 {
            return None;
        }
        // tr(ΣG⁻¹) over the kept controls: Σⱼ (G⁻¹Σ)ⱼⱼ.
        let mut trace = 0.0;
        for j in (0..q).filter(|&j| ldl.kept()[j]) {
            let column: Vec<Dd> = (0..q)
                .map(|i| Dd::from(self.covariance[packed(i, j, q)]))
                .collect();
            trace += ldl.solve(&column)[j].to_f64();
        }
        // G⁻¹ in f64 (0 at the dropped controls), for the leverages.
        let mut inverse = vec![0.0; q * q];
        for j in (0..q).filter(|&j| ldl.kept()[j]) {
            let unit: Vec<Dd> = (0..q).map(|i| Dd::from(f64::from(i == j))).collect();
            for (i, x) in ldl.solve(&unit).iter().enumerate() {
                inverse[i * q + j] = x.to_f64();
            }
        }
        Some(SpreadSolver {
            q,
            n,
            used,
            ldl,
            inverse,
            covariance: self.covariance.clone(),
            resolution: self.resolution.clone(),
            sums: sums.to_vec(),
            means: means.to_vec(),
            trace,
        })
    }
}

/// A condition's factorised Gram matrix of its controls, at the end of pass one.
#[derive(Debug, Clone)]
pub(super) struct SpreadSolver {
    q: usize,
    /// Realisations the Gram matrix is over.
    n: u64,
    /// Controls kept (independent of those before them).
    used: usize,
    ldl: Ldl,
    /// G⁻¹, row-major.
    inverse: Vec<f64>,
    covariance: Vec<f64>,
    /// The rounding each covariance may carry.
    resolution: Vec<f64>,
    /// Σc.
    sums: Vec<Dd>,
    /// c̄ (rounded), the centre of pass two.
    means: Vec<f64>,
    /// tr(ΣG⁻¹).
    trace: f64,
}

/// One estimate's regression on the controls, fixed at the end of pass one: β̂ and
/// a = G⁻¹Σβ̂ (the sensitivity of β̂ᵀΣβ̂ to the residuals).
#[derive(Debug, Clone)]
pub(super) struct Coefficients {
    beta: Vec<f64>,
    a: Vec<f64>,
}

impl SpreadSolver {
    /// The HC2 weight 1/(1 − hᵢᵢ) of a realisation with centred controls `centred`, its
    /// leverage hᵢᵢ = 1/n + c̃ᵀG⁻¹c̃.
    pub(super) fn weight(&self, centred: &[f64]) -> f64 {
        let q = self.q;
        let mut h = 1.0 / self.n as f64;
        for i in 0..q {
            for k in 0..q {
                h += centred[i] * self.inverse[i * q + k] * centred[k];
            }
        }
        1.0 / (1.0 - h)
    }

    /// The coefficients of an estimate's d = θ̂ − θ over the condition's `n` realisations
    /// with Σd = `sum_d`, its rounded mean `mean_d` and Σ d cⱼ = `cross`; `None` when the
    /// estimate is missing in some realisation.
    pub(super) fn coefficients(
        &self,
        n: u64,
        sum_d: &ExactSum,
        mean_d: f64,
        cross: &[ExactSum],
    ) -> Option<Coefficients> {
        if n != self.n || n < self.used as u64 + 3 {
            return None;
        }
        let nf = Dd::from(n as f64);
        let (sd, md) = (sum_d.value_dd(), Dd::from(mean_d));
        // Σ(d − d̄)(cⱼ − c̄ⱼ)
        let s: Vec<Dd> = (0..self.q)
            .map(|j| {
                let mc = Dd::from(self.means[j]);
                cross[j].value_dd() - md * self.sums[j] - mc * sd + nf * md * mc
            })
            .collect();
        let beta = self.ldl.solve(&s);
        let sigma_beta: Vec<Dd> = (0..self.q)
            .map(|i| {
                (0..self.q).fold(Dd::default(), |t, k| {
                    t + Dd::from(self.covariance[packed(i, k, self.q)]) * beta[k]
                })
            })
            .collect();
        let a = self.ldl.solve(&sigma_beta);
        Some(Coefficients {
            beta: beta.iter().map(|b| b.to_f64()).collect(),
            a: a.iter().map(|x| x.to_f64()).collect(),
        })
    }
}

/// Pass two of one estimate's spread: sums of its residuals r = u − β̂ᵀc̃, of
/// A = 2(aᵀc̃)r and of their products weighted by v = 1/(1 − hᵢᵢ), each exact.
#[derive(Debug, Clone, Default)]
pub(super) struct Residuals {
    r: ExactSum,
    r2: ExactSum,
    /// Σ v r^k, k = 0..=4.
    vr: [ExactSum; 5],
    va: ExactSum,
    va2: ExactSum,
    var: ExactSum,
    var2: ExactSum,
}

impl Residuals {
    /// The exact accumulators held.
    pub(super) const ACCUMULATORS: usize = 11;

    /// Add a realisation's u = d − d̄ with its centred controls `centred` and HC2 weight
    /// `v` ([`SpreadSolver::weight`]).
    pub(super) fn add(&mut self, c: &Coefficients, u: f64, centred: &[f64], v: f64) {
        let (mut fitted, mut lever) = (0.0, 0.0);
        for ((&x, b), a) in centred.iter().zip(&c.beta).zip(&c.a) {
            fitted += b * x;
            lever += a * x;
        }
        let r = u - fitted;
        let a = 2.0 * lever * r;
        let r2 = r * r;
        self.r.add(r);
        self.r2.add(r2);
        let mut power = v;
        for sum in &mut self.vr {
            sum.add(power);
            power *= r;
        }
        let va = v * a;
        self.va.add(va);
        self.va2.add(va * a);
        self.var.add(va * r);
        self.var2.add(va * r2);
    }
}

/// The control-variate estimates of one estimate's spread.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpreadFit {
    /// V̂ of Var θ̂.
    pub variance: f64,
    /// Its MCSE squared.
    pub variance_var: f64,
    /// The bias E\[θ̂\] − θ by the same regression.
    pub bias: f64,
    /// Its MCSE squared.
    pub bias_var: f64,
    /// The covariance of the two estimates.
    pub covariance: f64,
}

impl SpreadSolver {
    /// The spread of an estimate with coefficients `c`, residual sums `s`, its rounded
    /// mean d̄ = `mean_d` and Σu = Σd − n d̄ (`sum_u`), over the condition's n realisations
    /// (docs/model.md#spread-control-variates):
    ///
    /// - V̂ = β̂ᵀΣβ̂ + s²(1 − tr ΣG⁻¹), s² = Σ(r − r̄)²/(n − q − 1), whose second term removes
    ///   E\[β̂ᵀΣβ̂\] − βᵀΣβ = tr(Σ Var β̂);
    /// - V̂ − V ≈ Σᵢ wᵢ, wᵢ = Aᵢ + (rᵢ² − s²)/n, so Var V̂ = Σ vᵢwᵢ² (HC2);
    /// - the bias b̂ = d̄ + ū − β̂ᵀc̄ with Var b̂ = Σ vᵢrᵢ²/n² and Cov(V̂, b̂) = Σ vᵢrᵢwᵢ/n.
    pub(super) fn fit(&self, c: &Coefficients, s: &Residuals, mean_d: f64, sum_u: Dd) -> SpreadFit {
        let n = self.n as f64;
        let q = self.used as f64;
        let dof = n - q - 1.0;
        let (r, r2) = (s.r.value(), s.r2.value());
        let s2 = (r2 - r * r / n) / dof;
        let (mut quadratic, mut rounding) = (0.0, 0.0);
        for i in 0..self.q {
            for k in 0..self.q {
                let ik = packed(i, k, self.q);
                quadratic += c.beta[i] * self.covariance[ik] * c.beta[k];
                rounding += (c.beta[i] * c.beta[k]).abs() * self.resolution[ik];
            }
        }
        let variance = quadratic + s2 * (1.0 - self.trace);
        let vr = s.vr.each_ref().map(ExactSum::value);
        let w2 = s.va2.value()
            + 2.0 / n * (s.var2.value() - s2 * s.va.value())
            + (vr[4] - 2.0 * s2 * vr[2] + s2 * s2 * vr[0]) / (n * n);
        // Never below the arithmetic's resolution of β̂ᵀΣβ̂: the rounding of the covariances
        // and of the products (an estimate exactly linear in its controls has no residual
        // and would otherwise report none). NaN stays NaN.
        let floor = (rounding + 4.0 * f64::EPSILON * variance.abs()).powi(2);
        let variance_var = if w2.is_nan() { w2 } else { w2.max(floor) };
        let mut adjustment = Dd::default();
        for (b, sum) in c.beta.iter().zip(&self.sums) {
            adjustment = adjustment + Dd::from(*b) * *sum;
        }
        let bias = (Dd::from(mean_d) + (sum_u - adjustment) / Dd::from(n)).to_f64();
        let covariance = (s.var.value() + (vr[3] - s2 * vr[1]) / n) / n;
        SpreadFit {
            variance,
            variance_var,
            bias,
            bias_var: vr[2] / (n * n),
            covariance,
        }
    }
}
