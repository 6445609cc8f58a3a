//! The vehicle regression (thesis eqs. 32–37), its per-realisation sufficient statistics,
//! and its estimators and bounds (SPEC §3–§4).
//!
//! One row per sample i:
//!
//! ```text
//! y_i = dV/dt_i + g sin θ_i
//! x_i = [ F_prop,i , −k V_i² , −g cos θ_i ],   k = ½ ρ A
//! θ   = [ 1/M , Cd/M , Cr ]                     y = X θ
//! ```
//!
//! Under speed-measurement noise only the middle column changes (`V → Ṽ = V + e`), so a
//! realisation is summarised by five sums of w = Ṽ² against the fixed columns
//! (Σw, ΣwF, Σwc, Σw², Σwy) plus, under output noise, four sums against η. The kernel never
//! forms the N×3 matrix: XᵀX and Xᵀy are assembled from these sums and the per-condition
//! constants.

use nalgebra::{Matrix3, Vector3};

use super::linalg::{SolveError, inverse_spd, solve_spd};
use crate::stats::sum::ExactSum;
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
    /// k = ½ ρ A [kg/m].
    pub k: f64,
    /// Noise-free XᵀX.
    pub xtx: Matrix3<f64>,
    /// Noise-free Xᵀy.
    pub xty: Vector3<f64>,
    /// Σ F, Σ c, Σ y: the sums the compensations and output noise need.
    pub sum_f: f64,
    /// Σ c.
    pub sum_c: f64,
    /// Σ y.
    pub sum_y: f64,
}

impl Regression {
    /// The regression of `cycle` for `vehicle`; constant sums are exactly rounded.
    pub fn new(cycle: &DriveCycle, vehicle: &VehicleParams) -> Self {
        let g = vehicle.gravity_m_s2;
        let k = vehicle.drag_factor_kg_m();
        let f = cycle.f_prop_n.clone();
        let c: Vec<f64> = cycle.grade_rad.iter().map(|t| -g * t.cos()).collect();
        let v = cycle.v_m_s.clone();
        let y: Vec<f64> = cycle
            .accel_m_s2
            .iter()
            .zip(&cycle.grade_rad)
            .map(|(a, t)| a + g * t.sin())
            .collect();
        let dot = |a: &[f64], b: &[f64]| {
            let mut s = ExactSum::new();
            s.add_all(a.iter().zip(b).map(|(p, q)| p * q));
            s.value()
        };
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
        let sum = |a: &[f64]| crate::stats::sum::exact_sum(a.iter().copied());
        Regression {
            sum_f: sum(&f),
            sum_c: sum(&c),
            sum_y: sum(&y),
            f,
            c,
            v,
            y,
            k,
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

    /// Σ F², Σ F c, Σ c², Σ F y, Σ c y: the entries that no speed noise touches.
    fn fixed(&self) -> [f64; 5] {
        [
            self.xtx[(0, 0)],
            self.xtx[(0, 2)],
            self.xtx[(2, 2)],
            self.xty[0],
            self.xty[2],
        ]
    }
}

/// Sufficient statistics of one realisation under speed and output noise.
///
/// With w_i = Ṽ_i² and η_i the output-noise draw (σ_y η_i is added to y_i):
/// `s_w = Σw, s_wf = ΣwF, s_wc = Σwc, s_ww = Σw², s_wy = Σwy`,
/// `s_eta = Ση, s_f_eta = ΣFη, s_c_eta = Σcη, s_w_eta = Σwη`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NoisySums {
    /// Σ Ṽ².
    pub s_w: f64,
    /// Σ F Ṽ².
    pub s_wf: f64,
    /// Σ c Ṽ².
    pub s_wc: f64,
    /// Σ Ṽ⁴.
    pub s_ww: f64,
    /// Σ y Ṽ².
    pub s_wy: f64,
    /// Σ η.
    pub s_eta: f64,
    /// Σ F η.
    pub s_f_eta: f64,
    /// Σ c η.
    pub s_c_eta: f64,
    /// Σ Ṽ² η.
    pub s_w_eta: f64,
}

impl NoisySums {
    /// Add another block's partial sums (blocked summation keeps rounding error ~ log N).
    #[inline]
    pub fn add(&mut self, o: &NoisySums) {
        self.s_w += o.s_w;
        self.s_wf += o.s_wf;
        self.s_wc += o.s_wc;
        self.s_ww += o.s_ww;
        self.s_wy += o.s_wy;
        self.s_eta += o.s_eta;
        self.s_f_eta += o.s_f_eta;
        self.s_c_eta += o.s_c_eta;
        self.s_w_eta += o.s_w_eta;
    }

    /// Accumulate samples `start..start + e.len()` with standard-normal draws `e` (speed,
    /// scaled by `sd_v`) and `eta` (output, scaled by `sd_y`; empty when off).
    #[inline]
    pub fn accumulate_block(
        &mut self,
        reg: &Regression,
        start: usize,
        sd_v: f64,
        e: &[f64],
        eta: Option<&[f64]>,
    ) {
        let n = e.len();
        let v = &reg.v[start..start + n];
        let f = &reg.f[start..start + n];
        let c = &reg.c[start..start + n];
        let y = &reg.y[start..start + n];
        let mut b = NoisySums::default();
        for i in 0..n {
            let vt = v[i] + sd_v * e[i];
            let w = vt * vt;
            b.s_w += w;
            b.s_wf += w * f[i];
            b.s_wc += w * c[i];
            b.s_ww += w * w;
            b.s_wy += w * y[i];
        }
        if let Some(eta) = eta {
            let eta = &eta[..n];
            for i in 0..n {
                let vt = v[i] + sd_v * e[i];
                let w = vt * vt;
                b.s_eta += eta[i];
                b.s_f_eta += f[i] * eta[i];
                b.s_c_eta += c[i] * eta[i];
                b.s_w_eta += w * eta[i];
            }
        }
        self.add(&b);
    }

    /// Normal equations XᵀX θ = Xᵀy of OLS on the noisy data (thesis eq. 20).
    pub fn ols_system(&self, reg: &Regression, sd_y: f64) -> (Matrix3<f64>, Vector3<f64>) {
        let [ff, fc, cc, fy, cy] = reg.fixed();
        let k = reg.k;
        let a = Matrix3::new(
            ff,
            -k * self.s_wf,
            fc,
            -k * self.s_wf,
            k * k * self.s_ww,
            -k * self.s_wc,
            fc,
            -k * self.s_wc,
            cc,
        );
        let b = Vector3::new(
            fy + sd_y * self.s_f_eta,
            -k * (self.s_wy + sd_y * self.s_w_eta),
            cy + sd_y * self.s_c_eta,
        );
        (a, b)
    }
}

/// An estimate with its status.
pub type Estimate = Result<Vector3<f64>, SolveError>;

/// OLS: θ̂ = (X̃ᵀX̃)⁻¹ X̃ᵀỹ.
pub fn ols(system: &(Matrix3<f64>, Vector3<f64>)) -> Estimate {
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
