//! The posterior Cramér–Rao bound of the filters' model (Tichavský, Muravchik & Nehorai
//! 1998), with the inverse mass a static parameter, in the augmented-information form
//! (docs/model.md#pcrlb).
//!
//! The state splits into its dynamic part d = \[V, φ\] and the static p = θ₁. With A = ∂f/∂d
//! and B = ∂f/∂p of the speed equation and the grade walk (2 × 2 and 2 × 1), W = Q⁻¹ =
//! diag(1/q_v, 1/(q|V|Δt)) and the expectations E over the truths at step k, the joint
//! information of (d_k, d_{k+1}, p) given the information J_k of (d_k, p) is
//!
//! ```text
//! M11 = J_dd + E[AᵀWA]   M12 = −E[AᵀW]             M13 = J_dp + E[AᵀWB]
//!                        M22 = E[W] + HᵀH/σ_v²     M23 = −E[WB]
//!                                                   M33 = J_pp + E[BᵀWB]
//! ```
//!
//! (H = \[1, 0\]) and J_{k+1} is its Schur complement on d_k:
//! \[\[M22, M23\], \[M32, M33\]\] − \[M12 M13\]ᵀ M11⁻¹ \[M12 M13\]. J₀ = P₀⁻¹, the filter's start
//! (the first speed measured once). The bound on the variance of φ_k and of θ₁ is the
//! corresponding diagonal element of J_k⁻¹. Along one path the expectations are its own
//! values and the recursion is the information form of the Kalman filter linearised about
//! that path (`path_bound`); over several, each E is their mean (`pcrlb`). W is taken at
//! each truth's speed as known: the information a speed-dependent walk variance adds about
//! V is left out.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};

use super::ekf::Prior;
use super::{CHECKPOINTS_S, FilterModel, TruePath, checkpoint_indices};
use crate::numeric::linalg::{SolveError, inverse_spd};

/// The bound on the variances of θ₁ \[1/kg²\] and φ \[rad²\] at one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundAt {
    /// Var θ₁ \[1/kg²\].
    pub inv_mass_var: f64,
    /// Var φ \[rad²\].
    pub grade_var: f64,
}

/// The bound at the last sample and at each of [`CHECKPOINTS_S`] the samples reach.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundTrack {
    /// At the last sample.
    pub end: BoundAt,
    /// At the checkpoints.
    pub checkpoints: [Option<BoundAt>; CHECKPOINTS_S.len()],
}

/// The expectations of one step over the truths.
#[derive(Debug, Clone, Copy, Default)]
struct StepTerms {
    awa: Matrix2<f64>,
    aw: Matrix2<f64>,
    awb: Vector2<f64>,
    w: Vector2<f64>,
    wb: Vector2<f64>,
    bwb: f64,
}

impl StepTerms {
    /// The terms of the step from sample `k` of `path`.
    fn of(model: &FilterModel, path: &TruePath<'_>, k: usize) -> StepTerms {
        let dt = path.t[k + 1] - path.t[k];
        let jac = model.jacobian(&path.state(k), path.force[k], dt);
        let a = Matrix2::new(jac[(0, 0)], jac[(0, 2)], 0.0, 1.0);
        let b = Vector2::new(jac[(0, 1)], 0.0);
        let w = Vector2::new(
            1.0 / model.speed_process_var,
            1.0 / model.grade_step_var(path.v[k], dt),
        );
        let wm = Matrix2::from_diagonal(&w);
        let aw = a.transpose() * wm;
        StepTerms {
            awa: aw * a,
            aw,
            awb: aw * b,
            w,
            wb: wm * b,
            bwb: (b.transpose() * wm * b)[0],
        }
    }

    fn add(&mut self, o: &StepTerms) {
        self.awa += o.awa;
        self.aw += o.aw;
        self.awb += o.awb;
        self.w += o.w;
        self.wb += o.wb;
        self.bwb += o.bwb;
    }

    fn scale(&mut self, s: f64) {
        self.awa *= s;
        self.aw *= s;
        self.awb *= s;
        self.w *= s;
        self.wb *= s;
        self.bwb *= s;
    }
}

/// The bound of the model `model` started from `prior`, its expectations the means over
/// `paths` (one path: that path's `path_bound`). The paths share their sample times (the
/// first's are read).
pub fn bound(
    model: &FilterModel,
    prior: &Prior,
    paths: &[TruePath<'_>],
) -> Result<BoundTrack, SolveError> {
    let first = paths.first().expect("a bound along at least one path");
    let n = first.len();
    assert!(
        paths.iter().all(|p| p.len() == n),
        "the paths share their samples"
    );
    let at = checkpoint_indices(first.t);
    let mut checkpoints = [None; CHECKPOINTS_S.len()];
    // Information of (V, φ, θ₁), in that order.
    let mut j = Matrix3::from_diagonal(&Vector3::new(
        1.0 / model.speed_noise_var,
        1.0 / (prior.grade_sd_rad * prior.grade_sd_rad),
        1.0 / prior.inv_mass_var(),
    ));
    let read = |j: &Matrix3<f64>| -> Result<BoundAt, SolveError> {
        let cov = inverse_spd(j)?;
        Ok(BoundAt {
            inv_mass_var: cov[(2, 2)],
            grade_var: cov[(1, 1)],
        })
    };
    let take = |k: usize, j: &Matrix3<f64>, checkpoints: &mut [Option<BoundAt>; 3]| {
        for (c, &i) in checkpoints.iter_mut().zip(&at) {
            if i == Some(k) {
                *c = Some(read(j)?);
            }
        }
        Ok::<(), SolveError>(())
    };
    take(0, &j, &mut checkpoints)?;
    let weight = 1.0 / paths.len() as f64;
    let measurement = 1.0 / model.speed_noise_var;
    for k in 0..n - 1 {
        let mut e = StepTerms::default();
        for path in paths {
            e.add(&StepTerms::of(model, path, k));
        }
        if paths.len() > 1 {
            e.scale(weight);
        }
        let j_dd = j.fixed_view::<2, 2>(0, 0).into_owned();
        let j_dp = j.fixed_view::<2, 1>(0, 2).into_owned();
        let m11 = j_dd + e.awa;
        // [M12 M13], 2 × 3.
        let mut c = Matrix2x3::zeros();
        c.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-e.aw));
        c.fixed_view_mut::<2, 1>(0, 2).copy_from(&(j_dp + e.awb));
        let mut lower = Matrix3::zeros();
        lower[(0, 0)] = e.w[0] + measurement;
        lower[(1, 1)] = e.w[1];
        lower[(0, 2)] = -e.wb[0];
        lower[(1, 2)] = -e.wb[1];
        lower[(2, 0)] = -e.wb[0];
        lower[(2, 1)] = -e.wb[1];
        lower[(2, 2)] = j[(2, 2)] + e.bwb;
        let m11_inv = inverse_spd(&m11)?;
        j = lower - c.transpose() * m11_inv * c;
        j = (j + j.transpose()) * 0.5;
        take(k + 1, &j, &mut checkpoints)?;
    }
    Ok(BoundTrack {
        end: read(&j)?,
        checkpoints,
    })
}
