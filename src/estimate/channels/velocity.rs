//! The speed sensor (docs/model.md#noise-channels): white or correlated noise on the
//! measured speed, which enters the regressor w = Ṽ². Its noise may be correlated in time (a
//! stationary AR(1) process with correlation time `noise.velocity_correlation_s`) and may
//! enter the output through an acceleration differentiated from the measured speed, so rows
//! share it with their neighbours: besides its per-row terms, the off-diagonal part of the
//! sandwich's XᵀΣX, the variance a differentiated acceleration adds to ỹ, how far its
//! correlation reaches, and the covariance of a row's w with its differentiated ỹ.

use nalgebra::{Matrix3, Vector3};

use super::covariance::{
    AcrossRows, ColumnPowers, gaussian_moment, hermite_coefficients, packed, powers_of,
};
use super::{
    Channel, ChannelTerms, ColumnMoments, NoiseLevels, OmegaAt, Part, Powers, RowCovariance,
    RowMoments, Sample, SecondOrder, Signal, TrueRow,
};
use crate::estimate::regression::Regression;
use crate::estimate::sums::{Column, Sum};
use crate::estimate::sums::{GradeSums, Moments};
use crate::numeric::simd::Lanes;

/// The off-diagonal part of XᵀΣX for AR(1) speed noise: the equation errors of samples
/// i ≠ j covary as (kθ₂)² (4 V_i V_j ρ_ij σ² + 2 ρ_ij² σ⁴), ρ_ij = Π φ_k between them
/// (Gaussian e: Cov(e_i², e_j²) = 2ρ²σ⁴, Cov(e_i, e_j²) = 0). Summed in O(N) by the
/// recursion G_i = φ_i (G_{i−1} + a_{i−1} x_{i−1}) = Σ_{j<i} ρ_ij a_j x_j. `sd` is the
/// noise's SD, `tau` its correlation time \[s\] (the speed sensor's or the air-speed
/// sensor's: the noise in w either way).
pub(super) fn correlated_meat(reg: &Regression, theta: &[f64; 3], sd: f64, tau: f64) -> Matrix3<f64> {
    let scale = (theta[1] * reg.k).powi(2);
    let phi = reg.row_ar1_coefficients(tau);
    let x = |i: usize| Vector3::new(reg.f[i], -reg.k * reg.v[i] * reg.v[i], reg.c[i]);
    // (weight a_i, per-step factor, coefficient): the ρ term and the ρ² term.
    let mut total = Matrix3::zeros();
    for (square, coefficient) in [(false, 4.0 * sd * sd), (true, 2.0 * sd.powi(4))] {
        let a = |i: usize| if square { 1.0 } else { reg.v[i] };
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
/// summed in O(N) by the recursion of [`correlated_meat`]).
fn differentiated_meat(reg: &Regression, theta: &[f64; 3], noise: &NoiseLevels) -> Matrix3<f64> {
    let d = reg
        .differentiation
        .as_ref()
        .expect("a differentiated acceleration has its span");
    let sd = noise[Channel::Velocity];
    let kt = reg.k * theta[1];
    let x = |i: usize| Vector3::new(reg.f[i], -reg.k * reg.v[i] * reg.v[i], reg.c[i]);
    let mut g = vec![Vector3::zeros(); d.span_t.len()];
    for i in 0..reg.len() {
        let (s, xi) = (d.sample[i], x(i));
        g[s] += 2.0 * kt * reg.v[i] * xi;
        g[s + 1] += d.inv_dt[i] * xi;
        g[s - 1] -= d.inv_dt[i] * xi;
    }
    // The correlation between neighbours of a sequence with AR(1) coefficients `ar1` (ρ,
    // or ρ² for the squares); none for white noise.
    let steps = |ar1: &dyn Fn(f64) -> Vec<[f64; 2]>, square: bool| -> Option<Vec<f64>> {
        correlated_in_time(noise, Channel::Velocity).then(|| {
            ar1(noise.velocity_correlation_s)
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
    let linear = banded(
        &|j| g[j],
        g.len(),
        steps(&|tau| reg.ar1_coefficients(tau), false),
    );
    let square = banded(
        &x,
        reg.len(),
        steps(&|tau| reg.row_ar1_coefficients(tau), true),
    );
    sd * sd * linear + 2.0 * sd.powi(4) * kt * kt * square
}

/// E[w σ(e_{s+1} − e_{s−1})/Δt] for w = (V + σe_s)², e the stationary AR(1) noise with
/// coefficients `ar1` over the span (e_j = φ_j e_{j−1} + √(1 − φ_j²) z_j, so E[e_{j−1} e_j] =
/// φ_j) and `inv_dt` = 1/Δt: 2Vσ² (φ_{s+1} − φ_s)/Δt, the third moments vanishing.
fn neighbour_covariance(v: f64, sd: f64, ar1: &[[f64; 2]], s: usize, inv_dt: f64) -> f64 {
    2.0 * v * sd * sd * (ar1[s + 1][0] - ar1[s][0]) * inv_dt
}

/// True when `channel`'s noise (in w) is on and correlated in time under `noise`.
pub(super) fn correlated_in_time(noise: &NoiseLevels, channel: Channel) -> bool {
    noise.is_on(channel) && noise.velocity_correlation_s > 0.0
}

/// The terms beyond the first order of white noise in w on rows that hold one sample each
/// (a model acceleration): with s = 2Ve + e² and d = s − σ², the compensated ψ is
/// kθ₂\[x d − k e₂ (s² − 6σ²s − E\[·\])\] (BCLS's unbiased Ṽ⁴ − 6σ²Ṽ² + 3σ⁴ and Ṽ² − σ²), so
/// beyond x xᵀ Ω its own part has variance k²(kθ₂)²(32V⁴σ⁴ + 96V²σ⁶ + 24σ⁸) and
/// covariance −k(kθ₂)²·8V²σ⁴ with x d; Δ = −k d e₂, ε = kθ₂ d.
pub(super) fn white_second_order(sd: f64, at: &OmegaAt, x: &[f64; 3]) -> SecondOrder {
    let (s2, v2, k) = (sd * sd, at.v2, at.k);
    let a2 = (k * at.theta[1]).powi(2);
    let var_d = 4.0 * v2 * s2 + 2.0 * s2 * s2;
    let e2 = Vector3::new(0.0, 1.0, 0.0);
    let x = Vector3::from(*x);
    let cross = x * e2.transpose() + e2 * x.transpose();
    let var_q = 32.0 * v2 * v2 * s2 * s2 + 96.0 * v2 * s2 * s2 * s2 + 24.0 * s2.powi(4);
    SecondOrder {
        own: e2 * e2.transpose() * (k * k * a2 * var_q) - cross * (k * a2 * 8.0 * v2 * s2 * s2),
        perturbation: e2 * e2.transpose() * (k * k * var_d),
        loading: Vector3::new(0.0, -k * k * at.theta[1] * var_d, 0.0),
    }
}

/// The speed-noise channel.
#[derive(Debug, Clone, Copy)]
pub struct Speed;

/// The measured speed Ṽ of noise-free speeds `v` with draws `e` at SD `sd`: [`Speed`]'s
/// [`measure`](ChannelTerms::measure) of the speed alone (the fast path, which moves
/// nothing else).
#[inline(always)]
pub fn measured_speed<L: Lanes>(l: L, v: L::F64, sd: f64, e: L::F64) -> L::F64 {
    let zero = l.splat(0.0);
    let mut x = Sample {
        force: zero,
        speed: v,
        c: zero,
        s: zero,
        output_noise: None,
    };
    Speed::measure(l, &mut x, sd, e);
    x.speed
}

impl ChannelTerms for Speed {
    const KEY: &'static str = "velocity_sd";
    const UNIT: &'static str = "m/s";
    const DESCRIPTION: &'static str = "speed-measurement noise σ_v";
    const DEFAULT_LEVELS: Option<&'static [f64]> = None;
    const STREAM: crate::noise::Stream = crate::noise::Stream::Channel(1);
    const IN_REGRESSORS: bool = true;
    const COLUMNS: &'static [Column] = &[Column::W];
    const SIGNAL: Signal = Signal::Speed;
    const OMEGA_RANK: usize = 0;
    const PARTS: &'static [Part] = &[Part::W, Part::D];
    const ON_FAST_PATH: bool = true;

    /// Ṽ = V + σe.
    #[inline(always)]
    fn measure<L: Lanes>(l: L, x: &mut Sample<L::F64>, sd: f64, e: L::F64) {
        x.speed = x.speed + l.splat(sd) * e;
    }

    /// Ṽ² − V² = 2Ve + e² has variance 4V²σ² + 2σ⁴ and enters through −kθ₂.
    fn omega_term(sd: f64, at: &OmegaAt) -> f64 {
        let s2 = sd.powi(2);
        (at.theta[1] * at.k).powi(2) * (4.0 * at.v2 * s2 + 2.0 * s2 * s2)
    }

    /// White noise on rows that hold one sample each (a model acceleration): with
    /// s = 2Ve + e² and d = s − σ², the compensated ψ is kθ₂\[x d − k e₂ (s² − 6σ²s − E\[·\])\]
    /// (BCLS's unbiased Ṽ⁴ − 6σ²Ṽ² + 3σ⁴ and Ṽ² − σ²), so beyond x xᵀ Ω its own part has
    /// variance k²(kθ₂)²(32V⁴σ⁴ + 96V²σ⁶ + 24σ⁸) and covariance −k(kθ₂)²·8V²σ⁴ with x d;
    /// Δ = −k d e₂, ε = kθ₂ d. Rows that share the noise (AR(1), differentiated): not
    /// derived.
    fn second_order(sd: f64, noise: &NoiseLevels, at: &OmegaAt, x: &[f64; 3]) -> SecondOrder {
        if Channel::Velocity.shares_rows(noise) {
            return SecondOrder::NONE;
        }
        white_second_order(sd, at, x)
    }

    /// E\[Ṽ²\] = V² + σ², E\[Ṽ⁴\] = V⁴ + 6σ²V² + 3σ⁴.
    fn expect(sd: f64, r: &TrueRow, e: &mut ColumnMoments) {
        let s2 = sd * sd;
        let v2 = r.v * r.v;
        e.mean[Column::W.index()] = v2 + s2;
        e.ww = v2 * v2 + 6.0 * s2 * v2 + 3.0 * s2 * s2;
    }

    /// `V² → Ṽ² − σ²` and `V⁴ → Ṽ⁴ − 6σ²Ṽ² + 3σ⁴` wherever w = Ṽ² appears.
    fn compensate(m: &Moments, sd: f64, _g: f64) -> Moments {
        let s2 = sd * sd;
        Moments {
            s_1w: m.s_1w - s2 * m.s_1,
            s_3w: m.s_3w - s2 * m.s_3,
            s_ww: m.s_ww - 6.0 * s2 * m.s_w + 3.0 * s2 * s2 * m.n,
            s_wy: m.s_wy - s2 * m.s_y,
            s_w: m.s_w - s2 * m.n,
            grade: m.grade.map(|gs| GradeSums {
                s_ws: gs.s_ws - s2 * gs.s_s,
                ..gs
            }),
            ..*m
        }
    }

    /// The speed noise's part of the sandwich's XᵀΣX beyond its diagonal Ω terms (`None`:
    /// rows independent).
    fn row_covariance(
        reg: &Regression,
        theta: &[f64; 3],
        noise: &NoiseLevels,
    ) -> Option<RowCovariance> {
        if noise.speed_noise_differentiated() {
            Some(RowCovariance {
                meat: differentiated_meat(reg, theta, noise),
                replaces_omega_term: true,
            })
        } else if correlated_in_time(noise, Channel::Velocity) {
            Some(RowCovariance {
                meat: correlated_meat(reg, theta, noise[Channel::Velocity], noise.velocity_correlation_s),
                replaces_omega_term: false,
            })
        } else {
            None
        }
    }

    /// Per segment, the variance a differentiated acceleration adds to ỹ:
    /// σ_v² Var(e_{s+1} − e_{s−1}) / Δt² = 2σ_v² (1 − ρ) / Δt² with ρ = exp(−Δt/τ) (0 for white
    /// noise), at the segment's mean Δt = t_{s+1} − t_{s−1} (noise-free sample times); `None`
    /// when the acceleration is not differentiated.
    fn derivative_variance(
        reg: &Regression,
        noise: &NoiseLevels,
        segments: &[(usize, usize)],
    ) -> Option<Vec<f64>> {
        if !noise.speed_noise_differentiated() {
            return None;
        }
        let d = reg.differentiation.as_ref()?;
        let s2 = noise[Channel::Velocity].powi(2);
        let tau = noise.velocity_correlation_s;
        Some(
            d.mean_spans(segments)
                .iter()
                .map(|&dt| {
                    let rho = if tau > 0.0 { (-dt / tau).exp() } else { 0.0 };
                    2.0 * s2 * (1.0 - rho) / (dt * dt)
                })
                .collect(),
        )
    }

    /// The correlation time of the speed noise \[s\] (0: white or off).
    fn correlation_time_s(noise: &NoiseLevels) -> f64 {
        if correlated_in_time(noise, Channel::Velocity) {
            noise.velocity_correlation_s
        } else {
            0.0
        }
    }

    fn enters_neighbours(noise: &NoiseLevels) -> bool {
        noise.speed_noise_differentiated()
    }

    /// Under a differentiated acceleration with correlated speed noise, row `i`'s Cov(w, ỹ)
    /// through the noise it shares with its neighbours ([`ColumnMoments::wy_neighbours`]);
    /// `ar1` the AR(1) coefficients over [`Regression::noise_times`] (`None` when white).
    fn expect_shared(
        reg: &Regression,
        noise: &NoiseLevels,
        ar1: Option<&[[f64; 2]]>,
        i: usize,
        e: &mut ColumnMoments,
    ) {
        // ỹ's derivative noise σ_v (e_{s+1} − e_{s−1}) / Δt against w = (V + σ_v e_s)².
        if let (Some(d), Some(ar1)) = (&reg.differentiation, ar1)
            && noise.speed_noise_differentiated()
        {
            let sd = noise[Channel::Velocity];
            e.wy_neighbours = neighbour_covariance(reg.v[i], sd, ar1, d.sample[i], d.inv_dt[i]);
        }
    }

    /// E\[wᵏ dʲ\] = E\[(V + σe)²ᵏ\] E\[dʲ\]: a differentiated acceleration's
    /// d = σ(e₊ − e₋)/Δt is N(0, 2σ²/Δt²) and independent of the row's e when the noise is
    /// white; not derived for correlated noise through a differentiated acceleration.
    fn raw_moment(noise: &NoiseLevels, r: &TrueRow, k: &Powers) -> Option<f64> {
        let sd = noise[Channel::Velocity];
        let (kw, kd) = (k[Part::W as usize], k[Part::D as usize]);
        let differentiated = noise.speed_noise_differentiated();
        if differentiated && correlated_in_time(noise, Channel::Velocity) && kd > 0 {
            return None;
        }
        let d_sd = if differentiated {
            std::f64::consts::SQRT_2 * sd * r.inv_dt
        } else {
            0.0
        };
        Some(gaussian_moment(r.v, sd, 2 * kw) * gaussian_moment(0.0, d_sd, kd))
    }

    /// Correlated noise (model acceleration): Σ_k k! ρᵢⱼᵏ of the rows' Hermite
    /// coefficients ([`correlated_across_rows`]); white noise through a differentiated
    /// acceleration: the neighbours that share a draw ([`differentiated_across_rows`]); both
    /// together: not derived.
    fn covariance_across_rows(
        reg: &Regression,
        noise: &NoiseLevels,
        ar1: Option<&[[f64; 2]]>,
        rows: &dyn Fn(usize) -> RowMoments,
        sums: &[Sum],
    ) -> AcrossRows {
        match (noise.speed_noise_differentiated(), ar1) {
            (true, Some(_)) => AcrossRows::NotDerived,
            (true, None) => {
                AcrossRows::Covariance(differentiated_across_rows(reg, noise, rows, sums))
            }
            (false, Some(ar1)) => AcrossRows::Covariance(correlated_across_rows(
                reg,
                Channel::Velocity,
                noise,
                ar1,
                rows,
                sums,
            )),
            (false, None) => AcrossRows::Nothing,
        }
    }
}

/// The powers of a sum's term without w (and without ỹ when `drop_y`).
fn without_w(sum: Sum, drop_y: bool) -> ColumnPowers {
    let mut p = powers_of(sum);
    p[Column::W.index()] = 0;
    if drop_y {
        p[Column::Y.index()] = 0;
    }
    p
}

/// Σ_{i≠j} Cov(aᵢ, bⱼ) under correlated speed noise with the model's acceleration. Row i's
/// term of a sum is oᵢ(V + σeᵢ)²ᵖ, oᵢ independent of the speed noise and of other rows, so
/// with Corr(eᵢ, eⱼ) = ρᵢⱼ (the product of the AR(1) coefficients between them) and h_k the
/// Hermite coefficients of the speed factor (Mehler's formula),
/// Cov(aᵢ, bⱼ) = E\[oᵢ\] E\[o′ⱼ\] Σ_{k≥1} k! hₖ(aᵢ) hₖ(bⱼ) ρᵢⱼᵏ, summed in O(N) per k by the
/// recursion Gⱼ = ρ_{j−1,j}ᵏ (G_{j−1} + hₖ(a_{j−1})).
/// `channel` is the one whose noise is in w (the speed sensor's or the air-speed sensor's).
pub(super) fn correlated_across_rows(
    reg: &Regression,
    channel: Channel,
    noise: &NoiseLevels,
    ar1: &[[f64; 2]],
    rows: &dyn Fn(usize) -> RowMoments,
    sums: &[Sum],
) -> Vec<f64> {
    let sd = noise[channel];
    let q = sums.len();
    // h[i][a][k]: row i's Hermite coefficients of sum a's term (k = 1..=4).
    let h: Vec<Vec<[f64; 5]>> = (0..reg.len())
        .map(|i| {
            let row = rows(i);
            sums.iter()
                .map(|&a| {
                    let p = powers_of(a)[Column::W.index()];
                    let mut out = [0.0; 5];
                    if p > 0 {
                        let other =
                            row.moment_without(without_w(a, false), Some(channel));
                        let hk = hermite_coefficients(reg.v[i], sd, 2 * p);
                        for k in 1..5 {
                            out[k] = other * hk[k];
                        }
                    }
                    out
                })
                .collect()
        })
        .collect();
    let mut total = vec![0.0; q * (q + 1) / 2];
    for (k, kf) in [(1usize, 1.0), (2, 2.0), (3, 6.0), (4, 24.0)] {
        for a in 0..q {
            for b in a..q {
                // Σ_{i<j} ρᵢⱼᵏ [hₖ(aᵢ) hₖ(bⱼ) + hₖ(bᵢ) hₖ(aⱼ)]
                let (mut carried_a, mut carried_b, mut sum) = (0.0, 0.0, 0.0);
                for j in 1..reg.len() {
                    let step = ar1[j][0].powi(k as i32);
                    carried_a = step * (carried_a + h[j - 1][a][k]);
                    carried_b = step * (carried_b + h[j - 1][b][k]);
                    sum += carried_a * h[j][b][k] + carried_b * h[j][a][k];
                }
                total[packed(a, b, q)] += kf * sum;
            }
        }
    }
    total
}

/// Σ_{i≠j} Cov(aᵢ, bⱼ) under white speed noise through a differentiated acceleration. Row i
/// at span sample s reads eₛ through w and σ(eₛ₊₁ − eₛ₋₁)κᵢ (κᵢ = 1/Δtᵢ) through ỹ, which a
/// sum's term holds at most once: aᵢ = pᵢ(eₛ) + qᵢ(eₛ) σκᵢ(eₛ₊₁ − eₛ₋₁). With the other
/// channels' noise independent across rows, and P₁ = E\[e p\], Q₀ = E\[q\], Q₁ = E\[e q\]
/// (each the speed factor's moment times the other channels' mean), rows one sample apart
/// (sⱼ = sᵢ + 1) covary by −σκⱼP₁(aᵢ)Q₀(bⱼ) + σκᵢQ₀(aᵢ)P₁(bⱼ) − σ²κᵢκⱼQ₁(aᵢ)Q₁(bⱼ), rows
/// two apart by −σ²κᵢκⱼQ₀(aᵢ)Q₀(bⱼ), and rows further apart not at all.
fn differentiated_across_rows(
    reg: &Regression,
    noise: &NoiseLevels,
    rows: &dyn Fn(usize) -> RowMoments,
    sums: &[Sum],
) -> Vec<f64> {
    let d = reg
        .differentiation
        .as_ref()
        .expect("a differentiated acceleration has its span");
    let sd = noise[Channel::Velocity];
    let q = sums.len();
    // [P₁, Q₀, Q₁] per row and sum.
    let terms: Vec<Vec<[f64; 3]>> = (0..reg.len())
        .map(|i| {
            let row = rows(i);
            sums.iter()
                .map(|&a| {
                    let p = powers_of(a);
                    let h = hermite_coefficients(reg.v[i], sd, 2 * p[Column::W.index()]);
                    // p without d: E over the other channels of the term with ỹ's d left out.
                    let skip = Some(Channel::Velocity);
                    let p1 = row.moment_without(without_w(a, false), skip) * h[1];
                    if p[Column::Y.index()] == 0 {
                        return [p1, 0.0, 0.0];
                    }
                    let other = row.moment_without(without_w(a, true), skip);
                    [p1, other * h[0], other * h[1]]
                })
                .collect()
        })
        .collect();
    let mut total = vec![0.0; q * (q + 1) / 2];
    let cov = |i: usize, j: usize, a: usize, b: usize, gap: usize| -> f64 {
        let (ki, kj) = (sd * d.inv_dt[i], sd * d.inv_dt[j]);
        let ([pa, q0a, q1a], [pb, q0b, q1b]) = (terms[i][a], terms[j][b]);
        match gap {
            1 => -kj * pa * q0b + ki * q0a * pb - ki * kj * q1a * q1b,
            2 => -ki * kj * q0a * q0b,
            _ => 0.0,
        }
    };
    for i in 0..reg.len() {
        for j in i + 1..reg.len() {
            debug_assert!(d.sample[j] > d.sample[i], "rows in time order");
            let gap = d.sample[j] - d.sample[i];
            if gap > 2 {
                break;
            }
            for a in 0..q {
                for b in a..q {
                    total[packed(a, b, q)] += cov(i, j, a, b, gap) + cov(i, j, b, a, gap);
                }
            }
        }
    }
    total
}

#[cfg(test)]
mod tests;
