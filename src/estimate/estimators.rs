//! The estimators of the vehicle regression: each builds its normal equations from a
//! realisation's [`Moments`] (see docs/model.md#estimators).

use nalgebra::{Matrix3, Vector3};

use super::moments::Moments;
use crate::numeric::linalg::{SolveError, solve_spd};

impl Moments {
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

/// Solve a normal-equation system (OLS or BCLS).
pub fn solve(system: &(Matrix3<f64>, Vector3<f64>)) -> Result<Vector3<f64>, SolveError> {
    solve_spd(&system.0, &system.1)
}
