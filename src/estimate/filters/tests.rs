use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::ekf::{self, Prior};
use super::rls_mf::{self, RlsMfSettings};
use super::*;

/// The thesis vehicle's model: c = ½·1.2·2.2·0.3 kg/m, Cr = 0.01, σ_v = 0.1 m/s,
/// q_v = (1e-3 m/s)², q = 1e-7 rad²/m.
fn thesis_model() -> FilterModel {
    FilterModel {
        drag: 0.5 * 1.2 * 2.2 * 0.3,
        rolling: 0.01,
        g: 9.81,
        speed_process_var: 1e-6,
        grade_walk: 1e-7,
        speed_noise_var: 0.01,
    }
}

fn prior() -> Prior {
    Prior {
        mass_kg: 1500.0,
        mass_sd_kg: 250.0,
        grade_sd_rad: 0.01,
    }
}

/// A force that excites: 1500 N ± 20 % at 0.2 rad/s.
fn force(t: f64) -> f64 {
    1500.0 * (1.0 + 0.2 * (0.2 * t).sin())
}

/// A truth that follows the filters' model exactly: 1/M from the prior (delta method), φ₀
/// from N(0, σ_φ0²), each step the model's with its process noise, speeds measured with
/// σ_v. Returns (t, V, φ, F, z, θ₁).
#[allow(clippy::type_complexity)]
fn simulate(
    model: &FilterModel,
    steps: usize,
    dt: f64,
    rng: &mut ChaCha8Rng,
) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, f64) {
    let p = prior();
    let mut normal = || -> f64 { StandardNormal.sample(rng) };
    let inv_mass = p.inv_mass() + p.inv_mass_var().sqrt() * normal();
    let mut x: State = [10.0, inv_mass, p.grade_sd_rad * normal()];
    let (mut t, mut v, mut grade, mut f, mut z) = (vec![], vec![], vec![], vec![], vec![]);
    for k in 0..=steps {
        let tk = k as f64 * dt;
        t.push(tk);
        v.push(x[SPEED]);
        grade.push(x[GRADE]);
        f.push(force(tk));
        z.push(x[SPEED] + model.speed_noise_var.sqrt() * normal());
        let walk = model.grade_step_var(x[SPEED], dt).sqrt() * normal();
        x = model.step(&x, force(tk), dt);
        x[SPEED] += model.speed_process_var.sqrt() * normal();
        x[GRADE] += walk;
    }
    (t, v, grade, f, z, inv_mass)
}

/// The covariance-form Riccati recursion of the Kalman filter linearised about `path`
/// (Jacobians and Q at the true states): an independent form of what the
/// augmented-information recursion computes along one path.
fn linearised_riccati(model: &FilterModel, prior: &Prior, path: &TruePath<'_>) -> Matrix3<f64> {
    let mut p = Matrix3::from_diagonal(&Vector3::new(
        model.speed_noise_var,
        prior.inv_mass_var(),
        prior.grade_sd_rad.powi(2),
    ));
    for k in 0..path.len() - 1 {
        let dt = path.t[k + 1] - path.t[k];
        let f = model.jacobian(&path.state(k), path.force[k], dt);
        let mut pm = f * p * f.transpose();
        pm[(0, 0)] += model.speed_process_var;
        pm[(2, 2)] += model.grade_step_var(path.v[k], dt);
        let s = pm[(0, 0)] + model.speed_noise_var;
        let h = pm.column(0).into_owned();
        p = pm - h * h.transpose() / s;
    }
    p
}

#[test]
fn the_bound_along_one_path_is_the_kalman_filter_linearised_about_it() {
    let model = thesis_model();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let (t, v, grade, f, _, inv_mass) = simulate(&model, 20_000, 0.01, &mut rng);
    let path = TruePath {
        t: &t,
        v: &v,
        grade: &grade,
        force: &f,
        inv_mass,
    };
    let bound = pcrlb::bound(&model, &prior(), &[path]).unwrap();
    let p = linearised_riccati(&model, &prior(), &path);
    // Two algebraically equal recursions in f64 over 2e4 steps: each step's rounding is
    // relative 1e-16 on terms whose cancellation (the walk's 1e10 information against the
    // grade's) costs about four digits; 1e-7 leaves a wide margin for the accumulation.
    let rel = |a: f64, b: f64| (a / b - 1.0).abs();
    assert!(
        rel(bound.end.inv_mass_var, p[(1, 1)]) < 1e-7,
        "{bound:?} {p}"
    );
    assert!(rel(bound.end.grade_var, p[(2, 2)]) < 1e-7, "{bound:?} {p}");
    // The checkpoints are read where the run reaches them: 60 and 120 s, not 300 s.
    assert!(bound.checkpoints[0].is_some() && bound.checkpoints[1].is_some());
    assert!(bound.checkpoints[2].is_none());
    // The information grows: the bound at 120 s is below that at 60 s.
    let [a, b, _] = bound.checkpoints;
    assert!(b.unwrap().inv_mass_var < a.unwrap().inv_mass_var);
}

#[test]
fn the_bound_over_copies_of_one_path_is_the_bound_along_it() {
    let model = thesis_model();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let (t, v, grade, f, _, inv_mass) = simulate(&model, 5_000, 0.01, &mut rng);
    let path = TruePath {
        t: &t,
        v: &v,
        grade: &grade,
        force: &f,
        inv_mass,
    };
    let one = pcrlb::bound(&model, &prior(), &[path]).unwrap();
    let three = pcrlb::bound(&model, &prior(), &[path, path, path]).unwrap();
    // The mean of three equal terms differs from the term by rounding alone.
    assert!((three.end.inv_mass_var / one.end.inv_mass_var - 1.0).abs() < 1e-9);
    assert!((three.end.grade_var / one.end.grade_var - 1.0).abs() < 1e-9);
}

/// Over truths that follow its model, the EKF is consistent: its mean NEES at the end is
/// that of a χ² with 3 degrees of freedom, and its error of 1/M is not below the PCRLB.
#[test]
fn the_ekf_is_consistent_on_truths_that_follow_its_model() {
    let model = thesis_model();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let runs = 200;
    let (mut nees, mut err2) = (0.0, 0.0);
    let mut paths = Vec::new();
    for _ in 0..runs {
        let (t, v, grade, f, z, inv_mass) = simulate(&model, 6_000, 0.01, &mut rng);
        let run = ekf::run(&model, &prior(), &t, &z, &f, |_, _| {});
        let n = t.len() - 1;
        nees += ekf::nees(&run.end, &[v[n], inv_mass, grade[n]]);
        err2 += (run.end.state[INV_MASS] - inv_mass).powi(2);
        paths.push((t, v, grade, f, inv_mass));
    }
    let nees = nees / runs as f64;
    // The mean of 200 χ²₃ has SD √(6/200) = 0.17: 4 SD is 0.69 (the filter's own
    // linearisation adds little at these noise levels).
    assert!((nees - 3.0).abs() < 0.69, "mean NEES {nees}");
    let truths: Vec<TruePath<'_>> = paths
        .iter()
        .map(|(t, v, grade, f, inv_mass)| TruePath {
            t,
            v,
            grade,
            force: f,
            inv_mass: *inv_mass,
        })
        .collect();
    let bound = pcrlb::bound(&model, &prior(), &truths).unwrap();
    let mse = err2 / runs as f64;
    // The MSE of 200 errors has a relative SE of about √(2/200) = 0.1: below the bound by
    // more than 3 SE would refute it.
    assert!(
        mse > bound.end.inv_mass_var * (1.0 - 0.3),
        "MSE {mse} against the PCRLB {}",
        bound.end.inv_mass_var
    );
}

/// A force that swings ±80 % about 1000 N every 20 s: u far from collinear with the constant
/// regressor of β.
fn strong(t: f64) -> f64 {
    1000.0 * (1.0 + 0.8 * (0.3 * t).sin())
}

#[test]
fn recursive_least_squares_with_two_forgetting_factors_finds_the_mass_on_a_flat_road() {
    // Noise-free speeds on a flat road with no process noise, a force far from constant.
    // Each parameter's scalar update sees the other's error as its own: with λ = 1 their
    // gains fall as 1/k and the pair converges only as a power of k (u is 80 % correlated
    // with the constant regressor of β); with λ₁ = λ₂ = 0.999 the gains stay about
    // (1 − λ)/E[φ²] and the error falls by e every ~4000 samples, to ~e⁻⁷ over 3e4. What
    // is left is the central difference's: y averages the 2m Euler slopes about k, off from
    // the model's at k by the change of the acceleration over ±0.1 s, ~5e-4 relative.
    let model = FilterModel {
        speed_process_var: 0.0,
        speed_noise_var: 0.0,
        ..thesis_model()
    };
    let inv_mass = 1.0 / 1400.0;
    let mut x: State = [10.0, inv_mass, 0.0];
    let (mut t, mut z, mut f) = (vec![], vec![], vec![]);
    for k in 0..=30_000 {
        let tk = k as f64 * 0.01;
        t.push(tk);
        z.push(x[SPEED]);
        f.push(strong(tk));
        x = model.step(&x, strong(tk), 0.01);
    }
    let settings = RlsMfSettings {
        forgetting_mass: 0.999,
        forgetting_grade: 0.999,
        half_window: rls_mf::half_window(0.1, 0.01),
    };
    assert_eq!(settings.half_window, 10);
    let run = rls_mf::run(&model, &prior(), &settings, &t, &z, &f, |_, _| {}).unwrap();
    assert!(
        (run.inv_mass / inv_mass - 1.0).abs() < 2e-3,
        "{} against {inv_mass}",
        run.inv_mass
    );
    // β = Cr cos 0 + sin 0 = Cr.
    assert!((run.beta - 0.01).abs() < 1e-3, "{}", run.beta);
}

#[test]
fn settling_is_the_first_sample_after_the_last_outside_the_band() {
    let mut s = Settle::new(1.0, 0.1);
    for (k, e) in [2.0, 1.05, 0.5, 1.01, 0.95, 1.0].into_iter().enumerate() {
        s.see(k, e);
    }
    assert_eq!(s.settled(6), Some(3));
    s.see(6, f64::NAN);
    assert_eq!(s.settled(7), None);
}
