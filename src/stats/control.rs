//! The control-variate (regression) estimator of a mean (docs/model.md#control-variates).
//!
//! With controls c (known mean 0) and estimates θ̂ over n realisations, the mean is
//! estimated as θ̄ − βᵀc̄, β the least-squares coefficients of θ̂ on c with an intercept. Its
//! MCSE is the residual SD over √n, inflated by (n − 2)/(n − q − 2) for the q fitted
//! coefficients (Lavenberg & Welch 1981; Nelson 1990, exact under joint normality). The
//! sums arrive as exact sums of centred products, so the result does not depend on the
//! order of the realisations; the fit is done in double-double arithmetic because the
//! residual is often a millionth of the variance it is the difference from.

use crate::numeric::dd::Dd;
use crate::numeric::sum::ExactSum;

/// The resolution of the sums: each cross-product is an exact sum of products rounded to
/// `f64`, so it is known to 2⁻⁵³ of the sum of their magnitudes. The residual sum of squares
/// RSS = S_dd − 2βᵀs + βᵀGβ is then known to about 2⁻⁵²·(√S_dd + Σ|β_j|√G_jj)², and is not
/// reported below that. An estimate that is an exact linear function of the controls (OLS
/// under output noise alone) has a true residual far below it; its MCSE is then this
/// resolution, not a Monte Carlo error.
const RESOLUTION: f64 = f64::EPSILON;

/// A control's unexplained variance, relative to its own, below which it is taken as a
/// combination of the controls before it and left out. A control that is one in exact
/// arithmetic keeps an unexplained part of about 2⁻⁵² relative (the rounding of the Gram
/// matrix), times its conditioning; informative but nearly collinear controls keep far
/// more (on the thesis cycle all five speed controls stay in down to σ_v = 0.001 m/s), so
/// 1e-12 tells them apart.
const DEPENDENT: f64 = 1e-12;

/// The control variates of one condition: which of the layout's are active, their sums
/// (pass one), means, and the centred cross-products between them (pass two).
#[derive(Debug, Clone, Default)]
pub(super) struct ControlAcc {
    /// Layout indices of the active controls.
    pub(super) active: Vec<usize>,
    /// Realisations added in pass one.
    n: u64,
    /// Σ c_j (pass one).
    sums: Vec<ExactSum>,
    /// c̄_j, fixed at the end of pass one.
    means: Vec<f64>,
    /// Σ (c_j − c̄_j)(c_k − c̄_k), j ≤ k, packed row by row (pass two).
    gram: Vec<ExactSum>,
    /// The current realisation's centred controls (pass two).
    pub(super) centred: Vec<f64>,
}

impl ControlAcc {
    /// Accumulators for the controls `applies` marks.
    pub(super) fn new(applies: &[bool]) -> Self {
        let active: Vec<usize> = (0..applies.len()).filter(|&j| applies[j]).collect();
        let q = active.len();
        ControlAcc {
            sums: vec![ExactSum::new(); q],
            means: vec![f64::NAN; q],
            gram: vec![ExactSum::new(); q * (q + 1) / 2],
            centred: vec![f64::NAN; q],
            active,
            n: 0,
        }
    }

    /// Number of active controls.
    pub(super) fn len(&self) -> usize {
        self.active.len()
    }

    /// The exact accumulators held (sums and Gram entries).
    pub(super) fn accumulators(&self) -> usize {
        self.sums.len() + self.gram.len()
    }

    /// Σ c_j (exact) of pass one.
    pub(super) fn sums_dd(&self) -> Vec<Dd> {
        self.sums.iter().map(ExactSum::value_dd).collect()
    }

    /// c̄_j, the centres of pass two (after pass one).
    pub(super) fn means(&self) -> &[f64] {
        &self.means
    }

    /// Realisations added in pass one.
    pub(super) fn count(&self) -> u64 {
        self.n
    }

    /// Pass one: a realisation's controls (all of the layout's).
    pub(super) fn first(&mut self, controls: &[f64]) {
        self.n += 1;
        for (sum, &j) in self.sums.iter_mut().zip(&self.active) {
            sum.add(controls[j]);
        }
    }

    /// End of pass one.
    pub(super) fn end_first(&mut self) {
        let n = self.n as f64;
        for (mean, sum) in self.means.iter_mut().zip(&self.sums) {
            *mean = sum.value() / n;
        }
    }

    /// Pass two: centre a realisation's controls and add their cross-products.
    pub(super) fn second(&mut self, controls: &[f64]) {
        for ((c, &j), mean) in self.centred.iter_mut().zip(&self.active).zip(&self.means) {
            *c = controls[j] - mean;
        }
        let mut k = 0;
        for a in 0..self.centred.len() {
            for b in a..self.centred.len() {
                self.gram[k].add(self.centred[a] * self.centred[b]);
                k += 1;
            }
        }
    }
}

/// The result of the control-variate regression for one estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlFit {
    /// Bias estimate: mean(θ̂ − θ) − βᵀ c̄.
    pub bias: f64,
    /// Its MCSE.
    pub mcse: f64,
    /// Var(θ̂) / residual variance: the factor by which the realisations needed for a
    /// given MCSE shrink.
    pub variance_ratio: f64,
    /// Controls used (active ones not a combination of others).
    pub used: usize,
}

/// The LDLᵀ factorisation of a condition's Gram matrix of centred controls, leaving out
/// controls that are combinations of those before them: computed once per condition, used
/// for every estimator and parameter.
#[derive(Debug, Clone)]
pub(super) struct Factor {
    q: usize,
    /// Realisations the Gram matrix is over.
    n: u64,
    /// The Gram matrix's L D Lᵀ (its kept rows: the controls in the regression).
    ldl: Ldl,
    /// √G_kk, for the resolution floor.
    root_g: Vec<f64>,
    /// Σ c_k.
    sums: Vec<Dd>,
}

impl ControlAcc {
    /// The factorisation of the Gram matrix (after pass two); `None` without controls.
    pub(super) fn factor(&self) -> Option<Factor> {
        let q = self.len();
        if q == 0 {
            return None;
        }
        let g = |a: usize, b: usize| {
            let (a, b) = (a.min(b), a.max(b));
            // packed index of (a, b), a ≤ b
            self.gram[a * q - a * (a + 1) / 2 + b].value_dd()
        };
        Some(Factor {
            q,
            n: self.n,
            root_g: (0..q).map(|k| g(k, k).to_f64().sqrt()).collect(),
            sums: self.sums.iter().map(ExactSum::value_dd).collect(),
            ldl: Ldl::new(q, g),
        })
    }
}

/// The LDLᵀ factorisation of a symmetric positive semi-definite q × q matrix in
/// double-double arithmetic, leaving out each row that is a combination of those before it
/// (its unexplained part below [`DEPENDENT`] of its diagonal).
#[derive(Debug, Clone)]
pub(super) struct Ldl {
    q: usize,
    /// Unit lower triangle, row-major q × q.
    l: Vec<Dd>,
    /// The diagonal D.
    d: Vec<Dd>,
    /// Which rows are kept.
    kept: Vec<bool>,
}

impl Ldl {
    /// The factorisation of the matrix with entries `g(a, b)`.
    pub(super) fn new(q: usize, g: impl Fn(usize, usize) -> Dd) -> Self {
        let mut l = vec![Dd::default(); q * q];
        let mut d = vec![Dd::default(); q];
        let mut kept = vec![false; q];
        for k in 0..q {
            let gkk = g(k, k);
            let mut dk = gkk;
            for j in (0..k).filter(|&j| kept[j]) {
                dk = dk - l[k * q + j] * l[k * q + j] * d[j];
            }
            if !gkk.is_positive() || !(dk - gkk * Dd::from(DEPENDENT)).is_positive() {
                continue;
            }
            kept[k] = true;
            d[k] = dk;
            for i in k + 1..q {
                let mut s = g(i, k);
                for j in (0..k).filter(|&j| kept[j]) {
                    s = s - l[i * q + j] * l[k * q + j] * d[j];
                }
                l[i * q + k] = s / dk;
            }
        }
        Ldl { q, l, d, kept }
    }

    /// Which rows are kept.
    pub(super) fn kept(&self) -> &[bool] {
        &self.kept
    }

    /// x = G⁻¹ s over the kept rows (0 at the others).
    pub(super) fn solve(&self, s: &[Dd]) -> Vec<Dd> {
        self.backward(&self.forward(s))
    }

    /// z = L⁻¹ s (its entries at rows not kept are not used).
    fn forward(&self, s: &[Dd]) -> Vec<Dd> {
        let (q, l, kept) = (self.q, &self.l, &self.kept);
        let mut z = s.to_vec();
        for i in 0..q {
            for j in (0..i).filter(|&j| kept[j]) {
                z[i] = z[i] - l[i * q + j] * z[j];
            }
        }
        z
    }

    /// x = L⁻ᵀ D⁻¹ z over the kept rows (0 at the others).
    fn backward(&self, z: &[Dd]) -> Vec<Dd> {
        let (q, l, d, kept) = (self.q, &self.l, &self.d, &self.kept);
        let mut x = vec![Dd::default(); q];
        for k in (0..q).filter(|&k| kept[k]) {
            x[k] = z[k] / d[k];
        }
        for k in (0..q).rev().filter(|&k| kept[k]) {
            for i in (k + 1..q).filter(|&i| kept[i]) {
                x[k] = x[k] - l[i * q + k] * x[i];
            }
        }
        x
    }
}

impl Factor {
    /// The regression estimate of the mean of d = θ̂ − θ over `n` realisations, from Σd,
    /// the centred Σ(d − d̄)² and the centred cross-products Σ(d − d̄)(c_j − c̄_j)
    /// (`cross`). `None` when it is undefined: n is not every realisation of the condition
    /// (the estimator failed in some, and the Gram matrix is over all), or n ≤ q + 2.
    pub(super) fn fit(
        &self,
        n: u64,
        sum_d: &ExactSum,
        sum_centred_sq: &ExactSum,
        cross: &[ExactSum],
    ) -> Option<ControlFit> {
        let (q, ldl) = (self.q, &self.ldl);
        let (d, kept) = (&ldl.d, &ldl.kept);
        let used = kept.iter().filter(|&&k| k).count();
        if n != self.n || used == 0 || n < used as u64 + 3 {
            return None;
        }
        let nf = Dd::from(n as f64);
        // z = L⁻¹ s_cd; the explained sum of squares is Σ z_k² / D_k; β = L⁻ᵀ D⁻¹ z.
        let cross: Vec<Dd> = cross.iter().map(ExactSum::value_dd).collect();
        let z = ldl.forward(&cross);
        let mut explained = Dd::default();
        for k in (0..q).filter(|&k| kept[k]) {
            explained = explained + z[k] * z[k] / d[k];
        }
        let beta = ldl.backward(&z);
        let s_dd = sum_centred_sq.value_dd();
        let spread: f64 = (0..q)
            .filter(|&k| kept[k])
            .map(|k| beta[k].to_f64().abs() * self.root_g[k])
            .sum();
        let floor = RESOLUTION * (s_dd.to_f64().sqrt() + spread).powi(2);
        let rss = (s_dd - explained).to_f64().max(floor);
        let mut adjustment = Dd::default();
        for (k, b) in beta.iter().enumerate().filter(|(k, _)| kept[*k]) {
            adjustment = adjustment + *b * self.sums[k] / nf;
        }
        let bias = (sum_d.value_dd() / nf - adjustment).to_f64();
        let (n, qf) = (n as f64, used as f64);
        let residual_variance = rss / (n - qf - 1.0);
        let mcse = (residual_variance / n * (n - 2.0) / (n - qf - 2.0)).sqrt();
        let variance_ratio = s_dd.to_f64() / (n - 1.0) / residual_variance;
        Some(ControlFit {
            bias,
            mcse,
            variance_ratio,
            used,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sums of a data set as the summarizer builds them.
    fn fit_of(d: &[f64], c: &[Vec<f64>]) -> Option<ControlFit> {
        let q = c[0].len();
        let mut acc = ControlAcc::new(&vec![true; q]);
        let mut sum_d = ExactSum::new();
        for (di, ci) in d.iter().zip(c) {
            acc.first(ci);
            sum_d.add(*di);
        }
        acc.end_first();
        let mean_d = sum_d.value() / d.len() as f64;
        let mut sq = ExactSum::new();
        let mut cross = vec![ExactSum::new(); q];
        for (di, ci) in d.iter().zip(c) {
            acc.second(ci);
            let e = di - mean_d;
            sq.add(e * e);
            for (x, cc) in cross.iter_mut().zip(&acc.centred) {
                x.add(e * cc);
            }
        }
        acc.factor()?.fit(d.len() as u64, &sum_d, &sq, &cross)
    }

    #[test]
    fn an_exact_linear_relation_leaves_the_known_mean_and_the_resolution_as_mcse() {
        // d = 3 + 2 c₁ − 5 c₂ exactly (values chosen to be exact in binary): the
        // estimate is 3 + 2 c̄₁ − 5 c̄₂ − (2 c̄₁ − 5 c̄₂) = 3 (the control means are 0), and the
        // residual variance 0, reported as the resolution (q + 2)·2⁻⁵²·Σ(d − d̄)².
        let c: Vec<Vec<f64>> = (0..40)
            .map(|i| {
                let x = (i as f64 - 19.5) * 0.25;
                vec![x, (i % 7) as f64 - 3.0]
            })
            .collect();
        let d: Vec<f64> = c.iter().map(|c| 3.0 + 2.0 * c[0] - 5.0 * c[1]).collect();
        let f = fit_of(&d, &c).unwrap();
        assert!((f.bias - 3.0).abs() <= 1e-14, "{f:?}");
        let n = d.len() as f64;
        let centred_sq = |v: &dyn Fn(usize) -> f64| {
            let mean = (0..d.len()).map(v).sum::<f64>() / n;
            (0..d.len()).map(|i| (v(i) - mean).powi(2)).sum::<f64>()
        };
        let s_dd = centred_sq(&|i| d[i]);
        let (g1, g2) = (centred_sq(&|i| c[i][0]), centred_sq(&|i| c[i][1]));
        let floor = f64::EPSILON * (s_dd.sqrt() + 2.0 * g1.sqrt() + 5.0 * g2.sqrt()).powi(2);
        let mcse = (floor / (n - 3.0) / n * (n - 2.0) / (n - 4.0)).sqrt();
        assert!(
            (f.mcse - mcse).abs() <= 1e-12 * mcse,
            "{} vs {mcse}",
            f.mcse
        );
        assert_eq!(f.used, 2);
    }

    #[test]
    fn a_dependent_control_is_left_out_and_the_fit_matches_ordinary_least_squares() {
        // c₃ = 0.1 c₁ + 0.3 c₂ up to rounding (not exact in binary, so the Gram matrix
        // sees a rounding-sized independent part); d has a residual. Compared with the
        // textbook solution from the two independent controls computed in f64 (agreement to
        // 1e-10 relative: 40 well-conditioned values).
        let c: Vec<Vec<f64>> = (0..40)
            .map(|i| {
                let a = ((i * 37) % 11) as f64 * 0.7 - 3.3;
                let b = ((i * 13) % 7) as f64 * 1.9 - 5.1;
                vec![a, b, 0.1 * a + 0.3 * b]
            })
            .collect();
        let d: Vec<f64> = c
            .iter()
            .enumerate()
            .map(|(i, c)| 1.0 + 0.5 * c[0] + 0.25 * c[1] + ((i * 29) % 5) as f64 * 0.1)
            .collect();
        let f = fit_of(&d, &c).unwrap();
        assert_eq!(f.used, 2);
        // Reference: solve the 2×2 centred normal equations directly.
        let n = d.len() as f64;
        let mean = |v: &dyn Fn(usize) -> f64| (0..d.len()).map(v).sum::<f64>() / n;
        let (ma, mb, md) = (mean(&|i| c[i][0]), mean(&|i| c[i][1]), mean(&|i| d[i]));
        let s = |x: &dyn Fn(usize) -> f64, y: &dyn Fn(usize) -> f64| {
            (0..d.len()).map(|i| x(i) * y(i)).sum::<f64>()
        };
        let a = |i: usize| c[i][0] - ma;
        let b = |i: usize| c[i][1] - mb;
        let e = |i: usize| d[i] - md;
        let (saa, sab, sbb, sad, sbd, sdd) = (
            s(&a, &a),
            s(&a, &b),
            s(&b, &b),
            s(&a, &e),
            s(&b, &e),
            s(&e, &e),
        );
        let det = saa * sbb - sab * sab;
        let (ba, bb) = ((sbb * sad - sab * sbd) / det, (saa * sbd - sab * sad) / det);
        let bias = md - ba * ma - bb * mb;
        let rss = sdd - ba * sad - bb * sbd;
        let mcse = (rss / (n - 3.0) / n * (n - 2.0) / (n - 4.0)).sqrt();
        assert!(
            (f.bias - bias).abs() <= 1e-10 * bias.abs(),
            "{} vs {bias}",
            f.bias
        );
        assert!(
            (f.mcse - mcse).abs() <= 1e-10 * mcse,
            "{} vs {mcse}",
            f.mcse
        );
        assert!(
            (f.variance_ratio - sdd / (n - 1.0) / (rss / (n - 3.0))).abs()
                <= 1e-9 * f.variance_ratio
        );
    }

    #[test]
    fn too_few_realisations_for_the_controls_give_nothing() {
        let c: Vec<Vec<f64>> = (0..4).map(|i| vec![i as f64, (i * i) as f64]).collect();
        let d = [0.1, 0.4, 0.2, 0.9];
        assert_eq!(fit_of(&d, &c), None);
    }
}
