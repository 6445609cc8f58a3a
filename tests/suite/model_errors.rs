//! Model errors (`[truth]`, docs/model.md#model-errors): the steady entries change the
//! truth's signals exactly as their equations say, and `bias_model` is what the regression's
//! normal equations make of them.

use chassis_mc::model::Model;
use chassis_mc::model::vehicle::VehicleModel;
use chassis_mc::study::Study;
use nalgebra::{Matrix3, Vector3};

use super::common::{f64_col, read_table, run, set_key, str_col, study_path, study_text};

// The route_trace.toml vehicle (a passenger car), written out.
const M: f64 = 1800.0;
const CD: f64 = 0.35;
const CR: f64 = 0.0125;
const G: f64 = 9.81;
const K_ROUTE: f64 = 0.5 * 1.2 * 2.2;
const THETA: [f64; 3] = [1.0 / M, CD / M, CR];

/// `text` with `truth` appended as its `[truth]` table (none when empty), loaded at R = 2
/// relative to the shipped studies.
fn load(text: &str, truth: &str) -> Study {
    let text = match truth {
        "" => text.to_string(),
        t => format!("{text}\n[truth]\n{t}\n"),
    };
    Study::from_toml(&text, study_path("x.toml").to_str().unwrap())
        .unwrap()
        .with_overrides(Some(2), None)
        .unwrap()
}

/// The shipped speed trace with stops, braking and grade, noise-free, OLS, the whole log.
fn route_noise_free() -> String {
    let text = study_text("route_trace.toml")
        .lines()
        .filter(|l| !l.starts_with("durations"))
        .collect::<Vec<_>>()
        .join("\n");
    let text = set_key(&text, "velocity_sd", "[0.0]");
    set_key(&text, "estimators", "[\"ols\"]")
}

/// θ̂ of OLS in realisation 0 of condition 0.
fn estimate(model: &VehicleModel) -> [f64; 3] {
    let layout = model.layout();
    let mut slots = vec![0.0; layout.realisation_stride()];
    model.realise(1, 0, 0, &mut slots);
    [0, 1, 2].map(|p| slots[layout.theta_at(0, p)])
}

/// The OLS solution of rows x = [F, −kV², −g cos θ], y = a + g sin θ over `used`, and
/// (XᵀX)⁻¹ Xᵀ d for each `extra` output d.
fn normal_equations(
    x: &[[f64; 3]],
    y: &[f64],
    extra: &[f64],
    used: &[bool],
) -> (Vector3<f64>, Vector3<f64>) {
    let mut xtx = Matrix3::zeros();
    let (mut xty, mut xtd) = (Vector3::zeros(), Vector3::zeros());
    for i in (0..y.len()).filter(|&i| used[i]) {
        let row = Vector3::from(x[i]);
        xtx += row * row.transpose();
        xty += row * y[i];
        xtd += row * extra[i];
    }
    let lu = xtx.lu();
    (lu.solve(&xty).unwrap(), lu.solve(&xtd).unwrap())
}

/// One steady entry on a noise-free speed trace: the logged force is the equation's plus
/// the entry's force (or the calibrated force), written out here from the README's
/// equations; the estimate is what the normal equations of those exact signals give, and
/// `bias_model` is the documented first-order prediction −θ₁ (XᵀX)⁻¹ Xᵀ D.
fn check_speed_trace_entry(truth: &str, omitted: impl Fn(f64, f64, f64, f64) -> f64, scale: f64) {
    let plain = VehicleModel::new(&load(&route_noise_free(), "")).unwrap();
    let model = VehicleModel::new(&load(&route_noise_free(), truth)).unwrap();
    let (c0, c) = (&plain.cycles()[0], &model.cycles()[0]);
    // The motion is prescribed: the same in both.
    assert_eq!(c0.v_m_s, c.v_m_s);
    assert_eq!(c0.accel_m_s2, c.accel_m_s2);
    let n = c.len();
    let (t, v, a, th) = (&c.t_s, &c.v_m_s, &c.accel_m_s2, &c.grade_rad);
    let equation: Vec<f64> = (0..n)
        .map(|i| {
            M * a[i] + CD * K_ROUTE * v[i] * v[i] + CR * M * G * th[i].cos() + M * G * th[i].sin()
        })
        .collect();
    let d: Vec<f64> = (0..n).map(|i| omitted(t[i], v[i], a[i], th[i])).collect();
    let logged: Vec<f64> = (0..n)
        .map(|i| (1.0 + scale) * (equation[i] + d[i]))
        .collect();
    // What the log records: forces of ~1e3 N, computed in another order (rounding ~1e-12).
    let f_max = logged.iter().fold(0.0_f64, |m, f| m.max(f.abs()));
    for (i, (f, expected)) in c.f_prop_n.iter().zip(&logged).enumerate() {
        assert!((f - expected).abs() <= 1e-9 * f_max, "{truth}: sample {i}");
    }
    // The rows of route_trace.toml: V ≥ 0.5 m/s and a logged force ≥ 0.
    let used: Vec<bool> = (0..n).map(|i| v[i] >= 0.5 && logged[i] >= 0.0).collect();
    let y: Vec<f64> = (0..n).map(|i| a[i] + G * th[i].sin()).collect();
    let rows = |f: &[f64]| -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| [f[i], -K_ROUTE * v[i] * v[i], -G * th[i].cos()])
            .collect()
    };
    let (expected, _) = normal_equations(&rows(&logged), &y, &d, &used);
    let found = estimate(&model);
    let bias_model = &model.condition_info(0).bias_model[0];
    // The truth's force D (calibration: s·F) on the equation's rows.
    let d_first: Vec<f64> = (0..n)
        .map(|i| scale * equation[i] + (1.0 + scale) * d[i])
        .collect();
    let (_, projection) = normal_equations(&rows(&equation), &y, &d_first, &used);
    for p in 0..3 {
        // Exactly the normal equations of the logged signals: the engine's exactly rounded
        // sums and this test's plain ones differ by rounding, amplified by cond(XᵀX) (the
        // noise-free recovery on this trace holds to ≤ 1e-9, docs/model.md#speed-trace).
        let rel = (found[p] - expected[p]).abs() / expected[p].abs();
        assert!(
            rel <= 1e-9,
            "{truth}: θ{p} {} vs {} ({rel:e})",
            found[p],
            expected[p]
        );
        // bias_model is that estimate minus the truth (same rows, same rounding bound).
        let b = expected[p] - THETA[p];
        assert!(
            (bias_model[p] - b).abs() <= 1e-9 * THETA[p],
            "{truth}: bias_model θ{p}"
        );
        // The first-order prediction, on the rows without the entry: for D = Xβ + r its
        // error is β₁/(1 + β₁) of it (Sherman–Morrison, docs/model.md#model-errors) plus
        // terms of the order |Δθ|², so within 2 % while |Δθ₁/θ₁| ≤ 1 % at these sizes.
        let predicted = -THETA[0] * projection[p];
        println!(
            "{truth}: θ{p} rel. to the normal equations {rel:.1e}, bias_model {:.4e}, first order {predicted:.4e}",
            bias_model[p]
        );
        assert!(
            (bias_model[p] - predicted).abs() <= 0.02 * predicted.abs() + 1e-9 * THETA[p],
            "{truth}: θ{p} bias_model {} vs first order {predicted}",
            bias_model[p]
        );
    }
}

#[test]
fn each_steady_entry_on_a_speed_trace_gives_the_normal_equations_of_its_logged_force() {
    let w = 0.5;
    check_speed_trace_entry(
        &format!("wind_speed = [{w}]"),
        |_, v, _, _| CD * K_ROUTE * ((v + w) * (v + w).abs() - v * v),
        0.0,
    );
    check_speed_trace_entry(
        "rotating_mass_factor = [0.005]",
        |_, _, a, _| 0.005 * M * a,
        0.0,
    );
    check_speed_trace_entry("force_scale = [0.005]", |_, _, _, _| 0.0, 0.005);
    check_speed_trace_entry(
        "rolling_speed_coefficient = [0.001]",
        |_, v, _, th| CR * 0.001 * v * M * G * th.cos(),
        0.0,
    );
    check_speed_trace_entry(
        "air_density_ratio = [1.005]",
        |_, v, _, _| 0.005 * CD * K_ROUTE * v * v,
        0.0,
    );
    check_speed_trace_entry(
        "mass_rate = -0.01",
        |t, _, a, th| -0.01 * t * (a + G * (CR * th.cos() + th.sin())),
        0.0,
    );
}

#[test]
fn a_steady_headwind_in_torque_mode_is_the_rk4_integration_of_the_truth() {
    // The thesis drive at scale 1, noise-free, in a 3 m/s headwind.
    let text = set_key(&study_text("thesis.toml"), "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", "[0.0]");
    let study = load(&text, "wind_speed = [3.0]");
    let model = VehicleModel::new(&study).unwrap();
    let cycle = &model.cycles()[0];
    let table = study
        .vehicle()
        .unwrap()
        .terrain
        .as_ref()
        .unwrap()
        .grade_table(1.0);
    // Independent RK4 of M dV/dt = F − k Cd (V + w)|V + w| − Cr M g cos θ − M g sin θ.
    let (k, w, h) = (0.5 * 1.2 * 5.5, 3.0, 0.01);
    let force = |t: f64| 225.0 * (1.0 + 0.1 * (0.1 * t).sin()) * 2.7 / 0.3;
    let accel = |t: f64, x: f64, v: f64| {
        let th = table.grade_at(x).unwrap();
        let air = v + w;
        (force(t) - k * CD * air * air.abs() - CR * M * G * th.cos() - M * G * th.sin()) / M
    };
    let n = 60_001;
    let (mut xs, mut vs, mut acc) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut x, mut v) = (0.0, 0.0);
    for i in 0..n {
        let t = i as f64 * h;
        (xs[i], vs[i], acc[i]) = (x, v, accel(t, x, v));
        let k1 = (v, acc[i]);
        let k2 = (
            v + 0.5 * h * k1.1,
            accel(t + 0.5 * h, x + 0.5 * h * k1.0, v + 0.5 * h * k1.1),
        );
        let k3 = (
            v + 0.5 * h * k2.1,
            accel(t + 0.5 * h, x + 0.5 * h * k2.0, v + 0.5 * h * k2.1),
        );
        let k4 = (
            v + h * k3.1,
            accel((i + 1) as f64 * h, x + h * k3.0, v + h * k3.1),
        );
        x += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        v += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
    }
    // The same scheme in another order of operations: rounding differences (~1e-16
    // relative per step) grow at most linearly over 6e4 steps on this stable drive.
    let v_max = vs.iter().fold(0.0_f64, |m, v| m.max(*v));
    for i in (0..n).step_by(97) {
        assert!((cycle.v_m_s[i] - vs[i]).abs() <= 1e-9 * v_max, "v at {i}");
        assert!((cycle.x_m[i] - xs[i]).abs() <= 1e-9 * xs[n - 1], "x at {i}");
        assert!((cycle.accel_m_s2[i] - acc[i]).abs() <= 1e-9, "a at {i}");
        assert_eq!(cycle.f_prop_n[i], force(i as f64 * h), "F at {i}");
    }
    let th: Vec<f64> = xs.iter().map(|&x| table.grade_at(x).unwrap()).collect();
    let rows: Vec<[f64; 3]> = (0..n)
        .map(|i| [force(i as f64 * h), -k * vs[i] * vs[i], -G * th[i].cos()])
        .collect();
    let y: Vec<f64> = (0..n).map(|i| acc[i] + G * th[i].sin()).collect();
    let (expected, _) = normal_equations(&rows, &y, &y, &vec![true; n]);
    let found = estimate(&model);
    for p in 0..3 {
        // The signals agree to ≤ 1e-9 relative (above); the normal equations' solution
        // amplifies that by their conditioning, 1e-7 leaves it a factor 100 (measured:
        // ≤ 3e-12, printed with --nocapture).
        let rel = (found[p] - expected[p]).abs() / expected[p].abs();
        println!("headwind: θ{p} rel. to the RK4 estimate {rel:.1e}");
        assert!(
            rel <= 1e-7,
            "θ{p}: {} vs {} ({rel:e})",
            found[p],
            expected[p]
        );
        assert!(
            (model.condition_info(0).bias_model[0][p] - (found[p] - THETA[p])).abs()
                <= 1e-9 * THETA[p]
        );
    }
    // The headwind biases the drag estimate up (more drag than k Cd V²).
    assert!(found[1] > THETA[1] * 1.05, "{found:?}");
}

#[test]
fn the_truth_axes_and_bias_model_are_columns_of_every_table() {
    // Two headwinds on the route: two conditions, two cycles, keyed by `wind_speed`.
    let text = set_key(&route_noise_free(), "velocity_sd", "[0.1]");
    let study = load(&text, "wind_speed = [0.0, 2.0]");
    let (dir, _) = run(&study, Some(1));
    let table = |name: &str| read_table(&dir.path().join(format!("{name}.parquet")));
    let (cycles, summary) = (table("cycles"), table("summary"));
    let winds = f64_col(&cycles, "wind_speed");
    assert!(winds.contains(&0.0) && winds.contains(&2.0));
    assert_eq!(f64_col(&table("realisations"), "wind_speed").len(), 2 * 2);
    let model = VehicleModel::new(&study).unwrap();
    let (wind, bias_model) = (
        f64_col(&summary, "wind_speed"),
        f64_col(&summary, "bias_model"),
    );
    let condition = |w: f64| wind.iter().position(|&x| x == w).unwrap();
    for (c, w) in [(0, 0.0), (1, 2.0)] {
        let i = condition(w);
        assert_eq!(str_col(&summary, "parameter")[i], "inv_mass");
        assert_eq!(bias_model[i], model.condition_info(c).bias_model[0][0]);
    }
    // Without wind the noise-free estimate is the truth (to ≤ 1e-9, as above); a 2 m/s
    // headwind moves Cd/M by percents.
    assert!(bias_model[condition(0.0)].abs() <= 1e-9 * THETA[0]);
    let drag = bias_model[condition(2.0) + 1];
    assert!(drag > 0.01 * THETA[1], "{drag}");
}

#[test]
fn a_bad_truth_key_or_value_names_the_key_and_its_line() {
    let text = route_noise_free();
    let lines = text.lines().count();
    let origin = study_path("bad.toml");
    let origin = origin.to_str().unwrap();
    let error =
        |truth: &str| Study::from_toml(&format!("{text}\n[truth]\n{truth}\n"), origin).unwrap_err();
    let e = error("wind_sped = [1.0]");
    assert_eq!(e.key.as_deref(), Some("truth.wind_sped"));
    assert_eq!(e.line, Some(lines + 3));
    assert!(
        e.reason.contains("wind_speed") && e.reason.contains("mass_rate"),
        "{e}"
    );
    let e = error("air_density_ratio = [1.0, -0.5]");
    assert_eq!(e.key.as_deref(), Some("truth.air_density_ratio[1]"));
    assert_eq!(e.line, Some(lines + 3));
    assert!(e.reason.contains("[0.5, 2]"), "{e}");
    let e = error("mass_rate = [-0.01, 0.0]");
    assert_eq!(e.key.as_deref(), Some("truth.mass_rate"));
    let e = error("force_scale = \"big\"");
    assert_eq!(e.key.as_deref(), Some("truth.force_scale"));
    // A truth key in another table is placed.
    let e = Study::from_toml(
        &set_key(&text, "output_sd", "[0.0]\nwind_speed = [1.0]"),
        origin,
    )
    .unwrap_err();
    assert!(e.reason.contains("[truth]"), "{e}");
    // A drifting mass that would reach zero within the log (1800 kg at −2 kg/s, 1551 s)
    // is an error naming the key when the model is prepared.
    let study = Study::from_toml(&format!("{text}\n[truth]\nmass_rate = -2.0\n"), origin).unwrap();
    let e = VehicleModel::new(&study).unwrap_err();
    assert_eq!(e.key.as_deref(), Some("truth.mass_rate"), "{e}");
    assert!(e.reason.contains("must stay positive"), "{e}");
}

#[test]
fn mass_drift_counts_time_from_the_start_of_a_trace_whatever_its_clock() {
    // A trace's time column may be a clock (a log stamped from t = 3600 s); the mass drift
    // is ṁ·(t − t₀). The same trace shifted by 3600 s must give the same estimate: only the
    // rounding of the shifted times' differences differs (~1e-16 · 3600 s / 0.1 s steps,
    // below 1e-11 relative on θ̂), where counting from the clock's zero would add
    // 36 kg (2 % of M) at the first sample.
    let dir = tempfile::tempdir().unwrap();
    let csv = std::fs::read_to_string(study_path("data/route_trace.csv")).unwrap();
    let mut shifted = String::new();
    for line in csv.lines() {
        match line.split_once(',') {
            Some((t, rest)) if t.parse::<f64>().is_ok() => {
                let t: f64 = t.parse().unwrap();
                shifted.push_str(&format!("{},{rest}\n", t + 3600.0));
            }
            _ => shifted.push_str(&format!("{line}\n")),
        }
    }
    let path = dir.path().join("clock.csv");
    std::fs::write(&path, shifted).unwrap();
    let text = route_noise_free();
    let clock = text.replace(
        "trace = \"data/route_trace.csv\"",
        &format!("trace = {:?}", path.to_str().unwrap()),
    );
    assert_ne!(clock, text, "the study names its trace");
    let truth = "mass_rate = -0.01";
    let a = estimate(&VehicleModel::new(&load(&text, truth)).unwrap());
    let b = estimate(&VehicleModel::new(&load(&clock, truth)).unwrap());
    for p in 0..3 {
        assert!(
            (a[p] - b[p]).abs() <= 1e-9 * a[p].abs(),
            "parameter {p}: {} from t = 0, {} from t = 3600 s",
            a[p],
            b[p]
        );
    }
}

/// `design_thesis.toml` (the thesis drive at scale 1, OLS and BCLS) at speed noise
/// `velocity_sd` with `truth` as its `[truth]` table, `realisations` per condition.
fn design_thesis(velocity_sd: f64, truth: &str, realisations: u64) -> Study {
    let text = set_key(
        &study_text("design_thesis.toml"),
        "velocity_sd",
        &format!("[{velocity_sd}]"),
    );
    Study::from_toml(
        &format!("{text}\n[truth]\n{truth}\n"),
        study_path("x.toml").to_str().unwrap(),
    )
    .unwrap()
    .with_overrides(Some(realisations), None)
    .unwrap()
}

#[test]
fn the_first_order_bias_of_ols_is_bias_model_without_noise_under_each_entry() {
    // `design` predicts OLS's bias from the expected sums of the condition's rows, which
    // carry the truth: without noise that is the estimate on those rows, i.e. bias_model
    // (the same normal equations summed in another order: rounding, ~1e-12 relative for
    // their conditioning; asserted 1e-9 of θ).
    for truth in [
        "wind_speed = [1.0]",
        "rotating_mass_factor = [0.03]",
        "force_scale = [0.05]",
        "rolling_speed_coefficient = [0.002]",
        "air_density_ratio = [1.1]",
    ] {
        let model = VehicleModel::new(&design_thesis(0.0, truth, 2)).unwrap();
        let (bias, _) = model.first_order(0, 0);
        let bias_model = &model.condition_info(0).bias_model[0];
        for p in 0..3 {
            assert!(
                (bias[p] - bias_model[p]).abs() <= 1e-9 * THETA[p],
                "{truth}, θ{p}: predicted {} vs bias_model {}",
                bias[p],
                bias_model[p]
            );
        }
        // The entry does move the estimate (so the comparison is not 0 = 0).
        assert!(
            bias_model
                .iter()
                .zip(THETA)
                .any(|(b, t)| b.abs() > 1e-3 * t),
            "{truth}: {bias_model:?}"
        );
    }
}

#[test]
fn the_first_order_bias_of_a_compensating_estimator_includes_the_model_errors() {
    // σ_v = 0.5 m/s and a 1 m/s headwind on the thesis drive, R = 200. BCLS compensates the
    // speed noise, not the wind: its bias is the wind's (bias_model, +3.5 % of Cd/M here),
    // which first_order predicted as 0 before it knew the truth. OLS's prediction adds the
    // speed noise's bias to the truth's rows. The Monte Carlo bias (seed 2018) must agree
    // with each prediction within 3 MCSE: the prediction is the ratio of expectations, off
    // from the expectation of the ratio by O((EmpSE/θ)²) ≈ 1e-7 relative here, far below
    // the MCSE (≈ 2e-5 relative).
    let study = design_thesis(0.5, "wind_speed = [1.0]", 200);
    let model = VehicleModel::new(&study).unwrap();
    let s = super::common::run_summary(&study);
    let (est, param) = (str_col(&s, "estimator"), str_col(&s, "parameter"));
    let (bias, mcse) = (f64_col(&s, "bias"), f64_col(&s, "bias_mcse"));
    for (e, name) in [(0, "ols"), (1, "bcls")] {
        let (predicted, _) = model.first_order(0, e);
        for (p, parameter) in ["inv_mass", "drag_over_mass", "rolling_resistance"]
            .into_iter()
            .enumerate()
        {
            let i = (0..s.num_rows())
                .find(|&i| est[i] == name && param[i] == parameter)
                .unwrap();
            println!(
                "{name} {parameter}: predicted {:.4e}, Monte Carlo {:.4e} ± {:.1e}",
                predicted[p], bias[i], mcse[i]
            );
            assert!(
                (predicted[p] - bias[i]).abs() <= 3.0 * mcse[i],
                "{name} {parameter}: predicted {} vs {} ± {}",
                predicted[p],
                bias[i],
                mcse[i]
            );
        }
    }
    let (bcls, _) = model.first_order(0, 1);
    assert!(bcls[1] > 0.02 * THETA[1], "{bcls:?}");
}
