//! The vehicle regression (thesis eqs. 32–37), its per-realisation sufficient statistics,
//! its estimators and its bounds (SPEC §3–§4).
//!
//! One row per sample i:
//!
//! ```text
//! y_i = dV/dt_i + g sin θ_i
//! x_i = [ F_prop,i , −k V_i² , −g cos θ_i ],   k = ½ ρ A
//! θ   = [ 1/M , Cd/M , Cr ]                     y = X θ
//! ```
//!
//! A realisation is summarised by the [`Moments`] of its noisy columns: with w = Ṽ² the
//! middle column is −k w, so XᵀX and Xᵀy need only sums of products of (x₁, w, x₃, y). The
//! kernel never forms the N×3 matrix.
//!
//! Noise channels and what they do to OLS (each a condition axis, σ = 0 means off):
//!
//! | channel | enters | effect on OLS | bounds that apply |
//! |---|---|---|---|
//! | speed, σ_v [m/s] | Ṽ² in column 2 | errors-in-variables: Cd/M biased low (attenuation), Cr biased high (the lost drag is absorbed by the constant-like column 3) | `thesis_bound` (not a real bound), `eiv_sandwich`, `eiv_crlb_linearized` |
//! | output, σ_y [m/s²] | y | none: OLS unbiased and efficient | `crlb_output` (when alone) |
//! | grade, σ_θ [rad] | sin θ̃ in y, cos θ̃ in column 3 | mostly output-like (y gets ≈ g σ_θ of noise); E cos θ̃ = cos θ e^(−σ_θ²/2) shrinks column 3, so Cr is biased up by ≈ σ_θ²/2 relative | `eiv_sandwich`, `eiv_crlb_linearized` (first order) |
//! | force, σ_F [N] | F̃ in column 1 | errors-in-variables in column 1: 1/M attenuated towards the part of F that column 3 cannot absorb (F varies only ±10 % about its mean, so even σ_F ≈ 50 N gives a large bias) | `eiv_sandwich`, `eiv_crlb_linearized` (first order) |

use nalgebra::{Matrix3, Vector3};

use super::linalg::{SolveError, inverse_spd, solve_spd};
use crate::noise::BLOCK;
pub use crate::noise::NoiseLevels;
use crate::stats::sum::{ExactSum, exact_sum};
use crate::vehicle::{DriveCycle, VehicleParams};

/// The noise-free regression of one drive cycle and its constant sums.
#[derive(Debug, Clone)]
pub struct Regression {
    /// Column 1: F_prop [N].
    pub f: Vec<f64>,
    /// Column 3: c = −g cos θ [m/s²].
    pub c: Vec<f64>,
    /// Speed V [m/s] (column 2 is −k V²).
    pub v: Vec<f64>,
    /// Output y = dV/dt + g sin θ [m/s²].
    pub y: Vec<f64>,
    /// Model acceleration dV/dt [m/s²] (y without the grade term).
    pub accel: Vec<f64>,
    /// sin θ of each sample.
    pub sin_grade: Vec<f64>,
    /// cos θ of each sample.
    pub cos_grade: Vec<f64>,
    /// k = ½ ρ A [kg/m].
    pub k: f64,
    /// g [m/s²].
    pub g: f64,
    /// Noise-free XᵀX.
    pub xtx: Matrix3<f64>,
    /// Noise-free Xᵀy.
    pub xty: Vector3<f64>,
    /// Σ F.
    pub sum_f: f64,
    /// Σ c.
    pub sum_c: f64,
    /// Σ y.
    pub sum_y: f64,
    /// Σw, ΣwF, Σwc, Σw², Σwy with w = V², summed per block of [`BLOCK`] samples and then
    /// over blocks, exactly as a realisation without speed noise would sum them: such a
    /// realisation starts from these instead of recomputing them.
    speed_sums_noise_free: [f64; 5],
}

impl Regression {
    /// The regression of `cycle` for `vehicle`; constant sums are exactly rounded.
    pub fn new(cycle: &DriveCycle, vehicle: &VehicleParams) -> Self {
        let g = vehicle.gravity_m_s2;
        let k = vehicle.drag_factor_kg_m();
        let sin_grade: Vec<f64> = cycle.grade_rad.iter().map(|t| t.sin()).collect();
        let cos_grade: Vec<f64> = cycle.grade_rad.iter().map(|t| t.cos()).collect();
        let f = cycle.f_prop_n.clone();
        let c: Vec<f64> = cos_grade.iter().map(|cs| -g * cs).collect();
        let v = cycle.v_m_s.clone();
        let y: Vec<f64> = cycle
            .accel_m_s2
            .iter()
            .zip(&sin_grade)
            .map(|(a, s)| a + g * s)
            .collect();
        let dot = |a: &[f64], b: &[f64]| exact_sum(a.iter().zip(b).map(|(p, q)| p * q));
        let x2: Vec<f64> = v.iter().map(|v| -k * v * v).collect();
        let cols = [&f, &x2, &c];
        let mut xtx = Matrix3::zeros();
        let mut xty = Vector3::zeros();
        for i in 0..3 {
            for j in 0..3 {
                xtx[(i, j)] = dot(cols[i], cols[j]);
            }
            xty[i] = dot(cols[i], &y);
        }
        let sum = |a: &[f64]| exact_sum(a.iter().copied());
        let mut speed_sums_noise_free = [0.0; 5];
        for start in (0..v.len()).step_by(BLOCK) {
            let range = start..(start + BLOCK).min(v.len());
            let cols = Columns {
                v: &v[range.clone()],
                f: &f[range.clone()],
                c: &c[range.clone()],
                y: &y[range.clone()],
            };
            let block = speed_sums(&cols, &ZEROS[..range.len()], 0.0);
            for (total, b) in speed_sums_noise_free.iter_mut().zip(block) {
                *total += b;
            }
        }
        Regression {
            speed_sums_noise_free,
            sum_f: sum(&f),
            sum_c: sum(&c),
            sum_y: sum(&y),
            accel: cycle.accel_m_s2.clone(),
            sin_grade,
            cos_grade,
            f,
            c,
            v,
            y,
            k,
            g,
            xtx,
            xty,
        }
    }

    /// Number of samples N.
    pub fn len(&self) -> usize {
        self.f.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.f.is_empty()
    }

    /// First-order variance Ω_i of the equation error u_i = ỹ_i − x̃_iᵀθ at each sample:
    /// `θ₂²k²(4V²σ_v² + 2σ_v⁴) + θ₁²σ_F² + g²(cos θ − θ₃ sin θ)²σ_θ² + σ_y²`.
    ///
    /// Speed: Ṽ² − V² = 2Ve + e² has variance 4V²σ² + 2σ⁴ and enters through −kθ₂.
    /// Force: (F̃ − F)θ₁. Grade: d/dθ [g sin θ + θ₃ g cos θ] = g (cos θ − θ₃ sin θ).
    pub fn equation_error_variance(&self, theta: &[f64; 3], noise: &NoiseLevels) -> Vec<f64> {
        let (sv2, sv4) = (noise.velocity_sd.powi(2), noise.velocity_sd.powi(4));
        let speed = (theta[1] * self.k).powi(2);
        let force = (theta[0] * noise.force_sd).powi(2);
        let grade = (self.g * noise.grade_sd).powi(2);
        let output = noise.output_sd.powi(2);
        (0..self.len())
            .map(|i| {
                let v2 = self.v[i] * self.v[i];
                let slope = self.cos_grade[i] - theta[2] * self.sin_grade[i];
                speed * (4.0 * v2 * sv2 + 2.0 * sv4) + force + grade * slope * slope + output
            })
            .collect()
    }

    /// Σ wᵢ xᵢ xᵢᵀ over the noise-free rows, with exactly rounded entries.
    fn weighted_gram(&self, weight: &[f64]) -> Matrix3<f64> {
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
        let omega = self.equation_error_variance(theta, noise);
        let bread = inverse_spd(&self.xtx)?;
        let meat = self.weighted_gram(&omega);
        let cov = bread * meat * bread;
        Ok([0, 1, 2].map(|i| cov[(i, i)].sqrt()))
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

/// The sums of one realisation from which every estimator's normal equations are built.
///
/// With x̃₁ = F̃, w = Ṽ², x̃₃ = −g cos θ̃ and ỹ the noisy output (column 2 is −k w).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Moments {
    /// Σ x̃₁².
    pub s_11: f64,
    /// Σ x̃₁ x̃₃.
    pub s_13: f64,
    /// Σ x̃₃².
    pub s_33: f64,
    /// Σ x̃₁ ỹ.
    pub s_1y: f64,
    /// Σ x̃₃ ỹ.
    pub s_3y: f64,
    /// Σ x̃₁ w.
    pub s_1w: f64,
    /// Σ x̃₃ w.
    pub s_3w: f64,
    /// Σ w².
    pub s_ww: f64,
    /// Σ w ỹ.
    pub s_wy: f64,
    /// Σ w.
    pub s_w: f64,
    /// Σ x̃₁.
    pub s_1: f64,
    /// Σ x̃₃.
    pub s_3: f64,
    /// Σ ỹ.
    pub s_y: f64,
    /// N.
    pub n: f64,
}

impl Moments {
    /// Add the sums of `b` (not its N), each with one addition.
    fn add(&mut self, b: &Moments) {
        self.s_11 += b.s_11;
        self.s_13 += b.s_13;
        self.s_33 += b.s_33;
        self.s_1y += b.s_1y;
        self.s_3y += b.s_3y;
        self.s_1w += b.s_1w;
        self.s_3w += b.s_3w;
        self.s_ww += b.s_ww;
        self.s_wy += b.s_wy;
        self.s_w += b.s_w;
        self.s_1 += b.s_1;
        self.s_3 += b.s_3;
        self.s_y += b.s_y;
    }

    /// OLS normal equations X̃ᵀX̃ θ = X̃ᵀỹ (thesis eq. 20).
    pub fn ols_system(&self, k: f64) -> (Matrix3<f64>, Vector3<f64>) {
        self.system(k, self.s_1w, self.s_3w, self.s_ww, self.s_wy)
    }

    /// BCLS normal equations for speed noise of known σ_v: each noisy power of speed is
    /// replaced by its unbiased estimate, `V² → Ṽ² − σ²`, `V⁴ → Ṽ⁴ − 6σ²Ṽ² + 3σ⁴`, in
    /// Σ F V², Σ c V², Σ V⁴ and Σ y V² (E[Ṽ²] = V² + σ², E[Ṽ⁴] = V⁴ + 6V²σ² + 3σ⁴).
    pub fn bcls_system(&self, k: f64, velocity_sd: f64) -> (Matrix3<f64>, Vector3<f64>) {
        let s2 = velocity_sd * velocity_sd;
        self.system(
            k,
            self.s_1w - s2 * self.s_1,
            self.s_3w - s2 * self.s_3,
            self.s_ww - 6.0 * s2 * self.s_w + 3.0 * s2 * s2 * self.n,
            self.s_wy - s2 * self.s_y,
        )
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

/// Partial sums of the fast path (speed and output noise only): everything that the noise
/// touches, accumulated per block.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct SpeedOutputSums {
    s_w: f64,
    s_wf: f64,
    s_wc: f64,
    s_ww: f64,
    s_wy: f64,
    s_eta: f64,
    s_f_eta: f64,
    s_c_eta: f64,
    s_w_eta: f64,
}

/// Standard-normal draws of one block, per channel (`None` when the channel is off).
#[derive(Debug, Clone, Copy)]
pub struct BlockNoise<'a> {
    /// Speed noise draws.
    pub velocity: Option<&'a [f64]>,
    /// Output noise draws.
    pub output: Option<&'a [f64]>,
    /// Grade noise draws.
    pub grade: Option<&'a [f64]>,
    /// Force noise draws.
    pub force: Option<&'a [f64]>,
}

/// Accumulates one realisation's [`Moments`] block by block.
#[derive(Debug, Clone)]
pub struct MomentAccumulator<'r> {
    reg: &'r Regression,
    noise: NoiseLevels,
    /// Only speed and output noise: the constant columns stay noise-free and five sums per
    /// sample suffice.
    use_fast_path: bool,
    fast: SpeedOutputSums,
    general: Moments,
}

impl<'r> MomentAccumulator<'r> {
    /// Start a realisation of `reg` with noise levels `noise`.
    pub fn new(reg: &'r Regression, noise: NoiseLevels) -> Self {
        let mut fast = SpeedOutputSums::default();
        if noise.velocity_sd == 0.0 {
            [fast.s_w, fast.s_wf, fast.s_wc, fast.s_ww, fast.s_wy] = reg.speed_sums_noise_free;
        }
        MomentAccumulator {
            reg,
            noise,
            use_fast_path: noise.grade_sd == 0.0 && noise.force_sd == 0.0,
            fast,
            general: Moments::default(),
        }
    }

    /// Like [`new`](Self::new) but always on the general path (for cross-checks).
    #[cfg(test)]
    fn new_general(reg: &'r Regression, noise: NoiseLevels) -> Self {
        MomentAccumulator {
            use_fast_path: false,
            ..Self::new(reg, noise)
        }
    }

    /// Add samples `start .. start + len` with the block's standard-normal draws. Each
    /// block is summed separately and then added, so rounding grows like the number of
    /// blocks, not of samples.
    #[inline]
    pub fn add_block(&mut self, start: usize, len: usize, draws: BlockNoise<'_>) {
        if self.use_fast_path {
            self.add_fast(start, len, draws);
        } else {
            self.add_general(start, len, draws);
        }
    }

    #[inline]
    fn add_fast(&mut self, start: usize, len: usize, draws: BlockNoise<'_>) {
        let reg = self.reg;
        let range = start..start + len;
        let cols = Columns {
            v: &reg.v[range.clone()],
            f: &reg.f[range.clone()],
            c: &reg.c[range.clone()],
            y: &reg.y[range],
        };
        let sd_v = self.noise.velocity_sd;
        let s = &mut self.fast;
        let e = draws.velocity.unwrap_or(&ZEROS[..len]);
        // Speed noise off: Ṽ = V exactly, and `new` set the speed sums already.
        if sd_v != 0.0 {
            let [s_w, s_wf, s_wc, s_ww, s_wy] = speed_sums(&cols, e, sd_v);
            s.s_w += s_w;
            s.s_wf += s_wf;
            s.s_wc += s_wc;
            s.s_ww += s_ww;
            s.s_wy += s_wy;
        }
        if let Some(eta) = draws.output {
            let [s_eta, s_f_eta, s_c_eta, s_w_eta] = output_sums(&cols, e, sd_v, eta);
            s.s_eta += s_eta;
            s.s_f_eta += s_f_eta;
            s.s_c_eta += s_c_eta;
            s.s_w_eta += s_w_eta;
        }
    }

    fn add_general(&mut self, start: usize, len: usize, draws: BlockNoise<'_>) {
        let reg = self.reg;
        let nz = self.noise;
        let mut b = Moments::default();
        // A channel that is off draws zeros.
        let zeros = &ZEROS[..len];
        let force = draws.force.unwrap_or(zeros);
        let velocity = draws.velocity.unwrap_or(zeros);
        let grade = draws.grade.unwrap_or(zeros);
        let output = draws.output.unwrap_or(zeros);
        for j in 0..len {
            let i = start + j;
            let x1 = reg.f[i] + nz.force_sd * force[j];
            let vt = reg.v[i] + nz.velocity_sd * velocity[j];
            let w = vt * vt;
            let (sin_t, cos_t) = if nz.grade_sd > 0.0 {
                // sin/cos of θ + δ from those of θ and δ (angle addition)
                let (sd, cd) = (nz.grade_sd * grade[j]).sin_cos();
                (
                    reg.sin_grade[i] * cd + reg.cos_grade[i] * sd,
                    reg.cos_grade[i] * cd - reg.sin_grade[i] * sd,
                )
            } else {
                (reg.sin_grade[i], reg.cos_grade[i])
            };
            let x3 = -reg.g * cos_t;
            let y = reg.accel[i] + reg.g * sin_t + nz.output_sd * output[j];
            b.s_11 += x1 * x1;
            b.s_13 += x1 * x3;
            b.s_33 += x3 * x3;
            b.s_1y += x1 * y;
            b.s_3y += x3 * y;
            b.s_1w += x1 * w;
            b.s_3w += x3 * w;
            b.s_ww += w * w;
            b.s_wy += w * y;
            b.s_w += w;
            b.s_1 += x1;
            b.s_3 += x3;
            b.s_y += y;
        }
        self.general.add(&b);
    }

    /// The realisation's moments.
    pub fn finish(&self) -> Moments {
        let reg = self.reg;
        let n = reg.len() as f64;
        if !self.use_fast_path {
            return Moments { n, ..self.general };
        }
        let s = &self.fast;
        let sd_y = self.noise.output_sd;
        Moments {
            s_11: reg.xtx[(0, 0)],
            s_13: reg.xtx[(0, 2)],
            s_33: reg.xtx[(2, 2)],
            s_1y: reg.xty[0] + sd_y * s.s_f_eta,
            s_3y: reg.xty[2] + sd_y * s.s_c_eta,
            s_1w: s.s_wf,
            s_3w: s.s_wc,
            s_ww: s.s_ww,
            s_wy: s.s_wy + sd_y * s.s_w_eta,
            s_w: s.s_w,
            s_1: reg.sum_f,
            s_3: reg.sum_c,
            s_y: reg.sum_y + sd_y * s.s_eta,
            n,
        }
    }
}

/// Zero draws for a channel that is off.
const ZEROS: [f64; BLOCK] = [0.0; BLOCK];

/// Independent partial sums per accumulator: four lanes break the add-latency chain and let
/// the compiler use vector registers; lanes are combined as (l0 + l1) + (l2 + l3).
const LANES: usize = 4;

/// The noise-free columns of one block of samples.
struct Columns<'a> {
    v: &'a [f64],
    f: &'a [f64],
    c: &'a [f64],
    y: &'a [f64],
}

#[inline(always)]
fn reduce(lanes: [f64; LANES]) -> f64 {
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
}

/// Σw, ΣwF, Σwc, Σw², Σwy over a block, w = (V + σ_v e)². On x86-64 with AVX2 the four
/// lanes are one 256-bit register each; the results are bit-identical to the portable code
/// (the same operations per lane in the same order: no FMA, no reassociation).
fn speed_sums(cols: &Columns<'_>, e: &[f64], sd_v: f64) -> [f64; 5] {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { simd::speed_sums(cols, e, sd_v) };
        }
    }
    speed_sums_body(cols, e, sd_v)
}

#[cfg(target_arch = "x86_64")]
mod simd {
    //! AVX2 versions of the per-block sums, lane for lane the portable code.

    use std::arch::x86_64::*;

    use super::{Columns, LANES, output_sums_tail, reduce, speed_sums_tail};

    #[inline]
    #[target_feature(enable = "avx2")]
    fn lanes(v: __m256d) -> [f64; LANES] {
        let mut out = [0.0; LANES];
        // SAFETY: writes four f64 into an array of four.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v) };
        out
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(x: &[f64], i: usize) -> __m256d {
        assert!(i + LANES <= x.len());
        // SAFETY: bounds checked just above.
        unsafe { _mm256_loadu_pd(x.as_ptr().add(i)) }
    }

    #[target_feature(enable = "avx2")]
    pub(super) fn speed_sums(cols: &Columns<'_>, e: &[f64], sd_v: f64) -> [f64; 5] {
        let n = cols.v.len();
        assert!(cols.f.len() == n && cols.c.len() == n && cols.y.len() == n && e.len() >= n);
        let whole = n - n % LANES;
        let sd = _mm256_set1_pd(sd_v);
        let mut acc = [_mm256_setzero_pd(); 5];
        let mut i = 0;
        while i < whole {
            let vt = _mm256_add_pd(load(cols.v, i), _mm256_mul_pd(sd, load(e, i)));
            let w = _mm256_mul_pd(vt, vt);
            acc[0] = _mm256_add_pd(acc[0], w);
            acc[1] = _mm256_add_pd(acc[1], _mm256_mul_pd(w, load(cols.f, i)));
            acc[2] = _mm256_add_pd(acc[2], _mm256_mul_pd(w, load(cols.c, i)));
            acc[3] = _mm256_add_pd(acc[3], _mm256_mul_pd(w, w));
            acc[4] = _mm256_add_pd(acc[4], _mm256_mul_pd(w, load(cols.y, i)));
            i += LANES;
        }
        let mut acc = acc.map(|a| lanes(a));
        speed_sums_tail(cols, e, sd_v, whole, &mut acc);
        acc.map(reduce)
    }

    #[target_feature(enable = "avx2")]
    pub(super) fn output_sums(cols: &Columns<'_>, e: &[f64], sd_v: f64, eta: &[f64]) -> [f64; 4] {
        let n = cols.v.len();
        assert!(cols.f.len() == n && cols.c.len() == n && e.len() >= n && eta.len() >= n);
        let whole = n - n % LANES;
        let sd = _mm256_set1_pd(sd_v);
        let mut acc = [_mm256_setzero_pd(); 4];
        let mut i = 0;
        while i < whole {
            let vt = _mm256_add_pd(load(cols.v, i), _mm256_mul_pd(sd, load(e, i)));
            let eta_i = load(eta, i);
            acc[0] = _mm256_add_pd(acc[0], eta_i);
            acc[1] = _mm256_add_pd(acc[1], _mm256_mul_pd(load(cols.f, i), eta_i));
            acc[2] = _mm256_add_pd(acc[2], _mm256_mul_pd(load(cols.c, i), eta_i));
            acc[3] = _mm256_add_pd(acc[3], _mm256_mul_pd(_mm256_mul_pd(vt, vt), eta_i));
            i += LANES;
        }
        let mut acc = acc.map(|a| lanes(a));
        output_sums_tail(cols, e, sd_v, eta, whole, &mut acc);
        acc.map(reduce)
    }
}

#[inline(always)]
fn speed_sums_body(cols: &Columns<'_>, e: &[f64], sd_v: f64) -> [f64; 5] {
    let mut acc = [[0.0; LANES]; 5];
    let n = cols.v.len();
    let whole = n - n % LANES;
    let lanes = cols.v[..whole]
        .chunks_exact(LANES)
        .zip(cols.f[..whole].chunks_exact(LANES))
        .zip(cols.c[..whole].chunks_exact(LANES))
        .zip(cols.y[..whole].chunks_exact(LANES))
        .zip(e[..whole].chunks_exact(LANES));
    for ((((v, f), c), y), e) in lanes {
        for l in 0..LANES {
            let vt = v[l] + sd_v * e[l];
            let w = vt * vt;
            acc[0][l] += w;
            acc[1][l] += w * f[l];
            acc[2][l] += w * c[l];
            acc[3][l] += w * w;
            acc[4][l] += w * y[l];
        }
    }
    speed_sums_tail(cols, e, sd_v, whole, &mut acc);
    acc.map(reduce)
}

/// The samples after the last whole group of lanes, all into lane 0 (shared by every path
/// so that they agree bit for bit).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // five parallel slices indexed together
fn speed_sums_tail(
    cols: &Columns<'_>,
    e: &[f64],
    sd_v: f64,
    whole: usize,
    acc: &mut [[f64; LANES]; 5],
) {
    for i in whole..cols.v.len() {
        let vt = cols.v[i] + sd_v * e[i];
        let w = vt * vt;
        acc[0][0] += w;
        acc[1][0] += w * cols.f[i];
        acc[2][0] += w * cols.c[i];
        acc[3][0] += w * w;
        acc[4][0] += w * cols.y[i];
    }
}

/// Ση, ΣFη, Σcη, Σwη over a block, w = (V + σ_v e)²; sample i goes to lane i mod 4. Like
/// [`speed_sums`], the AVX2 path is bit-identical to the portable code.
fn output_sums(cols: &Columns<'_>, e: &[f64], sd_v: f64, eta: &[f64]) -> [f64; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { simd::output_sums(cols, e, sd_v, eta) };
        }
    }
    output_sums_body(cols, e, sd_v, eta)
}

#[inline(always)]
fn output_sums_body(cols: &Columns<'_>, e: &[f64], sd_v: f64, eta: &[f64]) -> [f64; 4] {
    let mut acc = [[0.0; LANES]; 4];
    let n = cols.v.len();
    let whole = n - n % LANES;
    let lanes = cols.v[..whole]
        .chunks_exact(LANES)
        .zip(cols.f[..whole].chunks_exact(LANES))
        .zip(cols.c[..whole].chunks_exact(LANES))
        .zip(e[..whole].chunks_exact(LANES))
        .zip(eta[..whole].chunks_exact(LANES));
    for ((((v, f), c), e), eta) in lanes {
        for l in 0..LANES {
            let vt = v[l] + sd_v * e[l];
            acc[0][l] += eta[l];
            acc[1][l] += f[l] * eta[l];
            acc[2][l] += c[l] * eta[l];
            acc[3][l] += vt * vt * eta[l];
        }
    }
    output_sums_tail(cols, e, sd_v, eta, whole, &mut acc);
    acc.map(reduce)
}

/// The samples after the last whole group of lanes, each into lane i mod 4.
#[inline(always)]
fn output_sums_tail(
    cols: &Columns<'_>,
    e: &[f64],
    sd_v: f64,
    eta: &[f64],
    whole: usize,
    acc: &mut [[f64; LANES]; 4],
) {
    for i in whole..cols.v.len() {
        let l = i % LANES;
        let vt = cols.v[i] + sd_v * e[i];
        acc[0][l] += eta[i];
        acc[1][l] += cols.f[i] * eta[i];
        acc[2][l] += cols.c[i] * eta[i];
        acc[3][l] += vt * vt * eta[i];
    }
}

/// Solve a normal-equation system (OLS or BCLS).
pub fn solve(system: &(Matrix3<f64>, Vector3<f64>)) -> Result<Vector3<f64>, SolveError> {
    solve_spd(&system.0, &system.1)
}

/// sqrt(diag(σ² A⁻¹)) for a normal matrix `a`: the standard errors of a covariance σ² A⁻¹.
pub fn scaled_inverse_sd(a: &Matrix3<f64>, sd: f64) -> Result<[f64; 3], SolveError> {
    let inv = inverse_spd(a)?;
    Ok([0, 1, 2].map(|i| sd * inv[(i, i)].sqrt()))
}

/// M̂ = 1/θ̂₁ [kg] and Ĉd = M̂ θ̂₂ [-] (thesis eqs. 38–39).
pub fn mass_and_drag(theta: &Vector3<f64>) -> (f64, f64) {
    let m = 1.0 / theta[0];
    (m, m * theta[1])
}

/// The thesis's error conversions of the 1/M and Cd/M bounds σ₁, σ₂ into errors of M [kg]
/// and Cd [-] (thesis eqs. 41–42):
///
/// ```text
/// σ_M  = 1 / (θ̂₁ − σ₁) − M̂                      (41)
/// σ_Cd = (θ̂₂ + σ₂) (θ̂₁ + σ₁)⁻¹ − Ĉd             (42)
/// ```
///
/// How the garbled equations were read: the extracted eq. 41 is a fraction `1 / (θ̂(1) −
/// σ_{1/M})` followed by `− M̂`, unambiguous. Eq. 42 prints as `(θ̂(2) + σ_{Cd/M})
/// (θ̂(1) + σ_{1/M}) − Ĉd` with the subscripts `M` of σ_{Cd/M} and σ_{1/M} on the line
/// below. Taken literally it multiplies two quantities in 1/kg and subtracts a
/// dimensionless Ĉd, so the exponent −1 on the second factor was lost in extraction:
/// Ĉd = θ̂₂/θ̂₁ (eq. 39), and the perturbed value (θ̂₂ + σ₂)/(θ̂₁ + σ₁) is dimensionless. The
/// signs are kept as printed (+σ₁ in eq. 42, −σ₁ in eq. 41), although they make the two
/// conversions lean in different directions. These are the thesis's heuristics, reported
/// for fidelity, not propagated standard errors (the delta method would give
/// σ_M ≈ σ₁/θ̂₁²).
pub fn thesis_error_conversions(theta: &Vector3<f64>, bound: &[f64; 3]) -> (f64, f64) {
    let (m, cd) = mass_and_drag(theta);
    let sigma_m = 1.0 / (theta[0] - bound[0]) - m;
    let sigma_cd = (theta[1] + bound[1]) / (theta[0] + bound[0]) - cd;
    (sigma_m, sigma_cd)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::{Channel, NormalStream};
    use crate::terrain::GradeTable;
    use crate::vehicle::{DriveParams, simulate};

    fn regression() -> Regression {
        let vehicle = VehicleParams::thesis();
        let drive = DriveParams {
            duration_s: 60.0,
            time_step_s: 0.01,
            steps: 6000,
            initial_speed_m_s: 0.0,
            torque_mean_n_m: 225.0,
            torque_amplitude: 0.1,
            torque_frequency_rad_s: 0.1,
        };
        let grades = (0..3000).map(|i| 0.08 * (i as f64 / 150.0).sin()).collect();
        let cycle = simulate(&vehicle, &drive, &GradeTable::from_grades(grades)).unwrap();
        Regression::new(&cycle, &vehicle)
    }

    fn moments(reg: &Regression, noise: NoiseLevels, general: bool) -> Moments {
        let mut acc = if general {
            MomentAccumulator::new_general(reg, noise)
        } else {
            MomentAccumulator::new(reg, noise)
        };
        let mut speed = NormalStream::for_realisation(1, 0, Channel::Velocity, 0);
        let mut output = NormalStream::for_realisation(1, 0, Channel::Output, 0);
        let (mut e, mut eta) = ([0.0; BLOCK], [0.0; BLOCK]);
        for start in (0..reg.len()).step_by(BLOCK) {
            let len = BLOCK.min(reg.len() - start);
            speed.fill_block(&mut e[..len]);
            output.fill_block(&mut eta[..len]);
            acc.add_block(
                start,
                len,
                BlockNoise {
                    velocity: Some(&e[..len]),
                    output: Some(&eta[..len]),
                    grade: None,
                    force: None,
                },
            );
        }
        acc.finish()
    }

    #[test]
    fn fast_and_general_paths_build_the_same_moments() {
        let reg = regression();
        let noise = NoiseLevels {
            velocity_sd: 0.7,
            output_sd: 0.3,
            ..NoiseLevels::default()
        };
        let a = moments(&reg, noise, false);
        let b = moments(&reg, noise, true);
        // Same products summed in a different grouping: agreement to rounding (1e-12
        // relative is ~10^4 ulps of headroom for 6001 terms).
        let pairs = [
            (a.s_11, b.s_11),
            (a.s_13, b.s_13),
            (a.s_33, b.s_33),
            (a.s_1y, b.s_1y),
            (a.s_3y, b.s_3y),
            (a.s_1w, b.s_1w),
            (a.s_3w, b.s_3w),
            (a.s_ww, b.s_ww),
            (a.s_wy, b.s_wy),
            (a.s_w, b.s_w),
            (a.s_1, b.s_1),
            (a.s_3, b.s_3),
            (a.s_y, b.s_y),
        ];
        for (i, (x, y)) in pairs.iter().enumerate() {
            assert!(
                (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
                "moment {i}: {x} vs {y}"
            );
        }
        assert_eq!(a.n, b.n);
    }

    #[test]
    fn vector_block_sums_equal_the_portable_ones_bit_for_bit() {
        let reg = regression();
        let mut e = [0.0; BLOCK];
        NormalStream::for_realisation(5, 0, Channel::Velocity, 1).fill(&mut e);
        let mut eta = [0.0; BLOCK];
        NormalStream::for_realisation(5, 0, Channel::Output, 1).fill(&mut eta);
        for (start, len) in [(0, BLOCK), (1000, 253), (3, 7)] {
            let cols = Columns {
                v: &reg.v[start..start + len],
                f: &reg.f[start..start + len],
                c: &reg.c[start..start + len],
                y: &reg.y[start..start + len],
            };
            let portable = speed_sums_body(&cols, &e[..len], 0.8);
            let dispatched = speed_sums(&cols, &e[..len], 0.8);
            assert_eq!(portable.map(f64::to_bits), dispatched.map(f64::to_bits));
            let portable = output_sums_body(&cols, &e[..len], 0.8, &eta[..len]);
            let dispatched = output_sums(&cols, &e[..len], 0.8, &eta[..len]);
            assert_eq!(portable.map(f64::to_bits), dispatched.map(f64::to_bits));
        }
    }

    #[test]
    fn without_noise_the_moments_are_the_noise_free_normal_equations() {
        let reg = regression();
        let m = MomentAccumulator::new(&reg, NoiseLevels::default());
        let mut acc = m;
        for start in (0..reg.len()).step_by(BLOCK) {
            let len = BLOCK.min(reg.len() - start);
            let none = BlockNoise {
                velocity: None,
                output: None,
                grade: None,
                force: None,
            };
            acc.add_block(start, len, none);
        }
        let (a, b) = acc.finish().ols_system(reg.k);
        for i in 0..3 {
            assert!((b[i] - reg.xty[i]).abs() <= 1e-12 * reg.xty[i].abs());
            for j in 0..3 {
                assert!((a[(i, j)] - reg.xtx[(i, j)]).abs() <= 1e-12 * reg.xtx[(i, j)].abs());
            }
        }
        // BCLS with σ_v = 0 is OLS.
        assert_eq!(acc.finish().bcls_system(reg.k, 0.0), (a, b));
    }
}
