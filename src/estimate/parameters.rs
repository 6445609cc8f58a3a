//! Which components of θ = \[1/M, Cd/M, Cr\] the estimators fit (docs/model.md#known-mass).
//!
//! By default all three. With `estimation.known_mass` the mass is weighed: 1/M is known and
//! the regression is y − F/M = x₂θ₂ + x₃θ₃. Its normal equations are those of the
//! three-parameter system with θ₁ fixed: rows and columns 2–3 of XᵀX, and Xᵀy minus θ₁ times
//! XᵀX's first column (the sums of x_j (y − θ₁F)). Every covariance of the two-parameter
//! estimate is the three-parameter formula with (XᵀX)⁻¹ replaced by the inverse of the free
//! block, zero in the known row and column: `eiv_sandwich`'s bread, the Fisher information's
//! inverse, σ² A⁻¹. So every estimator, bound and prediction keeps its 3-vectors and 3×3
//! matrices, and reads which parameters are free from here.

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

use crate::numeric::linalg::{SolveError, condition_number, inverse_spd, solve_spd};

/// The parameters the estimators fit.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Parameters {
    /// θ = \[1/M, Cd/M, Cr\], all three (the thesis).
    #[default]
    All,
    /// \[Cd/M, Cr\], the mass weighed: 1/M is known.
    KnownMass {
        /// The known 1/M \[1/kg\].
        inv_mass: f64,
    },
}

/// The indices of θ fitted with every parameter free.
const ALL: [usize; 3] = [0, 1, 2];

impl Parameters {
    /// The indices into θ of the fitted parameters, in order (their rows in every table).
    pub fn free(self) -> &'static [usize] {
        match self {
            Parameters::All => &ALL,
            Parameters::KnownMass { .. } => &ALL[1..],
        }
    }

    /// Whether θ component `i` is fitted.
    pub fn is_free(self, i: usize) -> bool {
        self.free().contains(&i)
    }

    /// The solution θ of the normal equations `system` = (A, b) over the free parameters,
    /// the known 1/M in place of θ₁ (by equilibrated Cholesky; a singular free block is an
    /// error naming the θ column).
    pub fn solve(self, system: &(Matrix3<f64>, Vector3<f64>)) -> Result<Vector3<f64>, SolveError> {
        let (a, b) = system;
        match self {
            Parameters::All => solve_spd(a, b),
            Parameters::KnownMass { inv_mass } => {
                let a2 = free_block(a);
                let b2 = Vector2::new(b[1] - a[(1, 0)] * inv_mass, b[2] - a[(2, 0)] * inv_mass);
                let x = solve_spd(&a2, &b2).map_err(shift_column)?;
                Ok(Vector3::new(inv_mass, x[0], x[1]))
            }
        }
    }

    /// The inverse of `a` over the free parameters: A⁻¹, or with the mass known the inverse
    /// of A's free block with zeros in the known row and column.
    pub fn inverse(self, a: &Matrix3<f64>) -> Result<Matrix3<f64>, SolveError> {
        match self {
            Parameters::All => inverse_spd(a),
            Parameters::KnownMass { .. } => {
                let inv = inverse_spd(&free_block(a)).map_err(shift_column)?;
                let mut full = Matrix3::zeros();
                for i in 0..2 {
                    for j in 0..2 {
                        full[(i + 1, j + 1)] = inv[(i, j)];
                    }
                }
                Ok(full)
            }
        }
    }

    /// θ from the values of the fitted parameters, `fitted(p)` the p-th of [`free`](Self::free)
    /// (a table's row order), the known 1/M in its place.
    pub fn theta(self, fitted: impl Fn(usize) -> f64) -> Vector3<f64> {
        let mut theta = Vector3::zeros();
        if let Parameters::KnownMass { inv_mass } = self {
            theta[0] = inv_mass;
        }
        for (p, &i) in self.free().iter().enumerate() {
            theta[i] = fitted(p);
        }
        theta
    }

    /// The 2-norm condition number of `a` over the free parameters (of its free block).
    pub fn condition_number(self, a: &Matrix3<f64>) -> f64 {
        match self {
            Parameters::All => condition_number(a),
            Parameters::KnownMass { .. } => condition_number(&free_block(a)),
        }
    }
}

/// Rows and columns 2–3 of `a`.
fn free_block(a: &Matrix3<f64>) -> Matrix2<f64> {
    Matrix2::new(a[(1, 1)], a[(1, 2)], a[(2, 1)], a[(2, 2)])
}

/// An error of the free block, its column numbered as in θ.
fn shift_column(e: SolveError) -> SolveError {
    match e {
        SolveError::DegenerateColumn(i) => SolveError::DegenerateColumn(i + 1),
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With 1/M fixed, the solution is that of the reduced regression y − θ₁F on x₂, x₃,
    /// solved directly, to rounding (a 2×2 system of O(1) condition here).
    #[test]
    fn known_mass_solves_the_reduced_regression() {
        let x: Vec<[f64; 3]> = (0..50)
            .map(|i| {
                let t = i as f64 * 0.1;
                [
                    2000.0 + 300.0 * t.sin(),
                    -(10.0 + t).powi(2),
                    -9.8 * (0.1 * t).cos(),
                ]
            })
            .collect();
        let theta = [1.0 / 1500.0, 3e-4, 0.011];
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, r)| {
                r[0] * theta[0] + r[1] * theta[1] + r[2] * theta[2] + 0.01 * (i as f64).cos()
            })
            .collect();
        let mut a = Matrix3::zeros();
        let mut b = Vector3::zeros();
        let (mut a2, mut b2) = (Matrix2::zeros(), Vector2::zeros());
        for (r, &y) in x.iter().zip(&y) {
            for i in 0..3 {
                for j in 0..3 {
                    a[(i, j)] += r[i] * r[j];
                }
                b[i] += r[i] * y;
            }
            let y2 = y - theta[0] * r[0];
            for i in 0..2 {
                for j in 0..2 {
                    a2[(i, j)] += r[i + 1] * r[j + 1];
                }
                b2[i] += r[i + 1] * y2;
            }
        }
        let known = Parameters::KnownMass { inv_mass: theta[0] };
        let got = known.solve(&(a, b)).unwrap();
        let want = solve_spd(&a2, &b2).unwrap();
        assert_eq!(got[0], theta[0]);
        for i in 0..2 {
            assert!(
                (got[i + 1] - want[i]).abs() <= 1e-10 * want[i].abs(),
                "{got} vs {want}"
            );
        }
        let inv = known.inverse(&a).unwrap();
        let want = inverse_spd(&a2).unwrap();
        assert_eq!(
            inv.row(0)
                .iter()
                .chain(inv.column(0).iter())
                .filter(|v| **v != 0.0)
                .count(),
            0
        );
        for i in 0..2 {
            for j in 0..2 {
                assert_eq!(inv[(i + 1, j + 1)], want[(i, j)]);
            }
        }
        // A zero force column (a coast-down) does not make the two-parameter system singular.
        let mut coast = a;
        for i in 0..3 {
            coast[(0, i)] = 0.0;
            coast[(i, 0)] = 0.0;
        }
        assert!(known.solve(&(coast, b)).is_ok());
        assert_eq!(
            Parameters::All.solve(&(coast, b)),
            Err(SolveError::DegenerateColumn(0))
        );
    }
}
