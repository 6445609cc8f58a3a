//! Small symmetric positive-definite systems: the normal equations of every estimator.
//!
//! The regressor columns of the vehicle model differ in scale by three orders of magnitude
//! (F ≈ 2000 N, ½ρAV² ≈ 5000, g cos θ ≈ 9.8), so the normal matrix is equilibrated
//! (D A D with D = diag(A)^-½) before its Cholesky factorisation; a pivot that is not clearly
//! positive marks the system singular instead of returning garbage.

use nalgebra::{SMatrix, SVector};
use thiserror::Error;

/// Reciprocal condition (of the equilibrated matrix) below which a system is called singular.
pub const SINGULAR_RCOND: f64 = 1e-15;

/// A normal-equation system that cannot be solved reliably.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[non_exhaustive]
pub enum SolveError {
    /// A diagonal entry is not positive and finite: a regressor column is zero or non-finite.
    #[error("regressor column {0} is zero or not finite")]
    DegenerateColumn(usize),
    /// The equilibrated matrix is numerically singular (collinear regressors).
    #[error("normal matrix is numerically singular")]
    Singular,
}

/// Solve `A θ = b` for symmetric positive-definite `A` by equilibrated Cholesky.
pub fn solve_spd<const P: usize>(
    a: &SMatrix<f64, P, P>,
    b: &SVector<f64, P>,
) -> Result<SVector<f64, P>, SolveError> {
    let (scaled, d) = equilibrate(a)?;
    let chol = scaled.cholesky().ok_or(SolveError::Singular)?;
    check_pivots(chol.l_dirty())?;
    let z = chol.solve(&b.component_mul(&d));
    Ok(z.component_mul(&d))
}

/// The inverse of symmetric positive-definite `A` (by equilibrated Cholesky).
pub fn inverse_spd<const P: usize>(
    a: &SMatrix<f64, P, P>,
) -> Result<SMatrix<f64, P, P>, SolveError> {
    let (scaled, d) = equilibrate(a)?;
    let chol = scaled.cholesky().ok_or(SolveError::Singular)?;
    check_pivots(chol.l_dirty())?;
    let inv = chol.inverse();
    let dm = SMatrix::<f64, P, P>::from_diagonal(&d);
    Ok(dm * inv * dm)
}

/// The 2-norm condition number λ_max / λ_min of symmetric `A` (what MATLAB's `cond` gives
/// for the thesis's Fisher matrix); ∞ when A is not positive definite.
pub fn condition_number<const P: usize>(a: &SMatrix<f64, P, P>) -> f64
where
    nalgebra::Const<P>: nalgebra::DimSub<nalgebra::U1>,
    nalgebra::DefaultAllocator:
        nalgebra::allocator::Allocator<nalgebra::DimDiff<nalgebra::Const<P>, nalgebra::U1>>,
{
    let eig = a.symmetric_eigenvalues();
    let max = eig.max();
    let min = eig.min();
    if min > 0.0 { max / min } else { f64::INFINITY }
}

fn equilibrate<const P: usize>(
    a: &SMatrix<f64, P, P>,
) -> Result<(SMatrix<f64, P, P>, SVector<f64, P>), SolveError> {
    let mut d = SVector::<f64, P>::zeros();
    for i in 0..P {
        let aii = a[(i, i)];
        if !(aii > 0.0 && aii.is_finite()) {
            return Err(SolveError::DegenerateColumn(i));
        }
        d[i] = 1.0 / aii.sqrt();
    }
    let mut scaled = *a;
    for i in 0..P {
        for j in 0..P {
            scaled[(i, j)] *= d[i] * d[j];
        }
    }
    Ok((scaled, d))
}

/// Reject factorisations whose smallest pivot² is below [`SINGULAR_RCOND`] (the diagonal
/// of the equilibrated matrix is 1, so pivot² ≈ the smallest eigenvalue scale).
fn check_pivots<const P: usize>(l: &SMatrix<f64, P, P>) -> Result<(), SolveError> {
    for i in 0..P {
        let p = l[(i, i)];
        if !(p.is_finite() && p * p > SINGULAR_RCOND) {
            return Err(SolveError::Singular);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

    #[test]
    fn solves_badly_scaled_systems_to_full_precision() {
        // A = X^T X for columns of very different scale; θ chosen, b = A θ.
        let x = [
            [2000.0, -5000.0, -9.8],
            [2100.0, -4000.0, -9.7],
            [1900.0, -100.0, -9.81],
            [2050.0, -2500.0, -9.75],
        ];
        let mut a = Matrix3::zeros();
        for r in &x {
            let v = Vector3::new(r[0], r[1], r[2]);
            a += v * v.transpose();
        }
        let theta = Vector3::new(1.0 / 1800.0, 0.35 / 1800.0, 0.0125);
        let b = a * theta;
        let got = solve_spd(&a, &b).unwrap();
        for i in 0..3 {
            assert!(
                ((got[i] - theta[i]) / theta[i]).abs() < 1e-9,
                "{got} vs {theta}"
            );
        }
        let inv = inverse_spd(&a).unwrap();
        let eye = a * inv;
        for i in 0..3 {
            for j in 0..3 {
                let target = if i == j { 1.0 } else { 0.0 };
                assert!((eye[(i, j)] - target).abs() < 1e-6, "{eye}");
            }
        }
    }

    #[test]
    fn singular_and_degenerate_systems_are_reported() {
        let a = Matrix2::new(1.0, 1.0, 1.0, 1.0);
        assert_eq!(
            solve_spd(&a, &Vector2::new(1.0, 1.0)),
            Err(SolveError::Singular)
        );
        let z = Matrix2::new(0.0, 0.0, 0.0, 1.0);
        assert_eq!(inverse_spd(&z), Err(SolveError::DegenerateColumn(0)));
        assert_eq!(condition_number(&Matrix2::new(4.0, 0.0, 0.0, 1.0)), 4.0);
    }
}
