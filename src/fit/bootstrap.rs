//! The parametric bootstrap of one estimator's fit: its world (the fitted vehicle replayed
//! on the log's rows, built in memory) and the estimates re-drawn in it
//! (docs/model.md#fit).

use std::convert::Infallible;

use nalgebra::Vector3;

use crate::numeric::ode::{Stage, rk4_step};

use crate::dynamics::{DriveCycle, Replay};
use crate::dynamics::{central_differences, positions};
use crate::estimate::channels::Acceleration;
use crate::estimate::estimators::EstimatorRef;
use crate::model::Model;
use crate::model::vehicle::{ReplayTruth, VehicleModel};
use crate::montecarlo::{self, Silent};
use crate::study::TruthAxes;

use super::{FitError, FitSpec, SMOOTHING_S};
use crate::dynamics::filter_truth::{FilterTruth, GradeWalk};

/// The measured speed smoothed by a centred moving average over ±[`SMOOTHING_S`], not
/// below 0.
fn smoothed_speed(c: &DriveCycle) -> Vec<f64> {
    let n = c.t_s.len();
    let (mut lo, mut hi) = (0, 0);
    let mut sum = 0.0;
    let mut smooth = Vec::with_capacity(n);
    for i in 0..n {
        while hi < n && c.t_s[hi] <= c.t_s[i] + SMOOTHING_S {
            sum += c.v_m_s[hi];
            hi += 1;
        }
        while c.t_s[lo] < c.t_s[i] - SMOOTHING_S {
            sum -= c.v_m_s[lo];
            lo += 1;
        }
        smooth.push((sum / (hi - lo) as f64).max(0.0));
    }
    smooth
}

/// The speed of the vehicle with θ = `theta` driven by the log's force on the log's grade:
/// over each stretch of samples that a used row reads (the rows and their neighbours), from
/// the smoothed speed `smooth` at the stretch's first sample, by RK4 with the force and
/// grade linear between samples; `smooth` elsewhere. The speed is as smooth as the force,
/// so its central differences carry no measurement noise (docs/model.md#fit).
fn simulated_speed(spec: &FitSpec, theta: &Vector3<f64>, smooth: &[f64]) -> Vec<f64> {
    let c = &spec.cycle;
    let (g, k) = (spec.vehicle.gravity_m_s2, spec.vehicle.drag_factor_kg_m());
    let n = c.t_s.len();
    let used = &spec.used;
    let read = |i: usize| used[i] || (i > 0 && used[i - 1]) || (i + 1 < n && used[i + 1]);
    // The fitted vehicle's acceleration at speed v under force f on grade gr; drag opposes
    // the motion (v|v|), so a stretch cannot run away below standstill.
    let accel = |v: f64, f: f64, gr: f64| {
        theta[0] * f - theta[1] * k * v * v.abs() - theta[2] * g * gr.cos() - g * gr.sin()
    };
    let mut v = smooth.to_vec();
    for i in 0..n - 1 {
        if !(read(i) && read(i + 1)) {
            continue;
        }
        // The stretch starts at i when i − 1 is not read; v[i] is then smooth[i].
        let h = c.t_s[i + 1] - c.t_s[i];
        let (f0, f1) = (c.f_prop_n[i], c.f_prop_n[i + 1]);
        let (g0, g1) = (c.grade_rad[i], c.grade_rad[i + 1]);
        let (fm, gm) = (0.5 * (f0 + f1), 0.5 * (g0 + g1));
        let step = rk4_step::<1, Infallible>([v[i]], h, [accel(v[i], f0, g0)], |stage, [vs]| {
            Ok([match stage {
                Stage::Half => accel(vs, fm, gm),
                Stage::Full => accel(vs, f1, g1),
            }])
        });
        let Ok([next]) = step;
        v[i + 1] = next;
    }
    v
}

/// The cycle of the world of one estimator's fit: the vehicle with θ = `theta` replayed on
/// the log's rows (docs/model.md#fit), fitting θ exactly on every row; for a filter
/// ([`filter_replay`]) following the filters' model exactly.
pub(super) fn replay(spec: &FitSpec, estimator: EstimatorRef, theta: &Vector3<f64>) -> Replay {
    let c = &spec.cycle;
    let n = c.t_s.len();
    let smooth = smoothed_speed(c);
    if estimator.estimates_grade() {
        return filter_replay(spec, estimator, smooth);
    }
    // The bootstrap world's truth, on the log's own rows, fitting θ exactly. With an
    // accelerometer: the smoothed speed, the logged force and grade, and the acceleration
    // that makes every row fit θ (so the excitation is the log's own). With a
    // differentiated acceleration the output is the speed's central difference, and the
    // regression's noise comes from the rows at each end of a used stretch (the interior
    // telescopes) unless the force is rough: the speed is the fitted vehicle's, simulated
    // under the logged force, and the force the one that makes its differences fit θ.
    let speed = match spec.acceleration {
        Acceleration::Model => smooth,
        Acceleration::Differentiated => simulated_speed(spec, theta, &smooth),
    };
    let (g, k) = (spec.vehicle.gravity_m_s2, spec.vehicle.drag_factor_kg_m());
    let central = central_differences(&c.t_s, &speed);
    let (mut f_prop_n, mut accel_m_s2) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let (v, gr) = (speed[i], c.grade_rad[i]);
        let resistance = theta[1] * k * v * v + theta[2] * g * gr.cos() + g * gr.sin();
        let (f, a) = match spec.acceleration {
            Acceleration::Model => {
                let f = c.f_prop_n[i];
                (f, theta[0] * f - resistance)
            }
            Acceleration::Differentiated => ((central[i] + resistance) / theta[0], central[i]),
        };
        f_prop_n.push(f);
        accel_m_s2.push(a);
    }
    let grade = c.grade_rad.clone();
    log_replay(spec, estimator, [speed, grade, f_prop_n, accel_m_s2])
}

/// The replay of `estimator`'s world on the log's times and runs, its speed, grade, force
/// and acceleration `signals`, the regression's rows the log's.
fn log_replay(spec: &FitSpec, estimator: EstimatorRef, signals: [Vec<f64>; 4]) -> Replay {
    let c = &spec.cycle;
    let [v_m_s, grade_rad, f_prop_n, accel_m_s2] = signals;
    let cycle = DriveCycle {
        x_m: positions(&c.t_s, &v_m_s),
        t_s: c.t_s.clone(),
        v_m_s,
        grade_rad,
        f_prop_n,
        accel_m_s2,
        run: c.run.clone(),
        run_heading: c.run_heading.clone(),
    };
    Replay {
        source: format!("the fit of {} to {}", estimator.name(), spec.log.display()),
        cycle,
        used: Some(spec.used.clone()),
    }
}

/// The cycle behind a filter's bootstrap world, which has no grade to replay: the log's
/// times and force, from the smoothed speed at the first sample; the world draws the rest
/// as the filters' model has it ([`filter_truth`]).
fn filter_replay(spec: &FitSpec, estimator: EstimatorRef, smooth: Vec<f64>) -> Replay {
    let n = spec.cycle.t_s.len();
    let force = spec.cycle.f_prop_n.clone();
    log_replay(spec, estimator, [smooth, vec![0.0; n], force, vec![0.0; n]])
}

/// The truth of a filter's bootstrap world: the filters' own model with the fit's 1/M
/// (docs/model.md#fit): each realisation steps the speed from the log's first (smoothed)
/// sample under the logged force with the filters' process noise, on a grade drawn from
/// their random walk; nothing is drawn for another estimator.
fn filter_truth(spec: &FitSpec, estimator: EstimatorRef) -> FilterTruth {
    if !estimator.estimates_grade() {
        return FilterTruth::default();
    }
    let f = &spec.settings.filter;
    FilterTruth {
        speed_process_sd: f.speed_process_sd,
        mass_prior: None,
        grade_walk: Some(GradeWalk {
            intensity: f.grade_walk,
            sd0_rad: f.prior.grade_sd_rad,
        }),
    }
}

/// The world of one estimator's fit, the vehicle with θ = `theta` replayed on `replay`
/// ([`replay`]) with the model errors of `truth`, measured with the assumed noise, as a
/// one-condition model of `estimator`: without model errors the parametric bootstrap's
/// world; with one, the world of its systematic shift (docs/model.md#fit).
pub(super) fn world(
    spec: &FitSpec,
    estimator: EstimatorRef,
    theta: &Vector3<f64>,
    replay: Replay,
    truth: TruthAxes,
) -> Result<VehicleModel, FitError> {
    let vehicle = spec.vehicle.with_theta([theta[0], theta[1], theta[2]]);
    let world = match truth == TruthAxes::default() {
        true => "bootstrap",
        false => "systematic shift",
    };
    let origin = format!("{} ({world} of {})", spec.origin, estimator.name());
    Ok(VehicleModel::for_cycle(
        replay,
        vehicle,
        spec.noise,
        vec![estimator],
        spec.settings,
        ReplayTruth {
            model_errors: truth,
            filter: filter_truth(spec, estimator),
        },
        &origin,
    )?)
}

/// The bootstrap in `model` (from [`world`]): the assumed noise re-drawn and the estimator
/// re-run `spec.realisations` times. Returns each realisation's θ̂ (failed ones left out).
pub(super) fn resample(spec: &FitSpec, model: &VehicleModel) -> Vec<Vector3<f64>> {
    let layout = model.layout();
    let slots = montecarlo::in_memory(model, spec.seed, &[0], 0..spec.realisations, &Silent);
    slots
        .chunks_exact(layout.realisation_stride())
        .map(|s| spec.settings.parameters.theta(|p| s[layout.theta_at(0, p)]))
        .filter(|t| t.iter().all(|v| v.is_finite()))
        .collect()
}
