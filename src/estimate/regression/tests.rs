use super::*;

/// Two runs of five samples on one clock (t = 0, 1, …, 9 s), run 1 slower.
fn two_runs() -> DriveCycle {
    let v = vec![30.0, 29.0, 28.2, 27.5, 27.0, 20.0, 19.6, 19.1, 18.8, 18.6];
    DriveCycle {
        t_s: (0..10).map(f64::from).collect(),
        x_m: (0..10).map(|i| 30.0 * f64::from(i)).collect(),
        v_m_s: v,
        grade_rad: vec![0.0; 10],
        f_prop_n: vec![0.0; 10],
        accel_m_s2: vec![-0.5; 10],
        run: vec![0, 0, 0, 0, 0, 1, 1, 1, 1, 1],
        run_heading: vec![1.0, -1.0],
    }
}

#[test]
fn ar1_noise_restarts_at_each_run_s_first_sample() {
    // φ = 0 and a unit innovation where a run begins: its first sample's noise is a
    // fresh draw, independent of every earlier run's.
    let t = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5];
    let ar1 = ar1_coefficients(&t, &[0, 0, 0, 1, 1, 2], 2.0);
    for i in [0, 3, 5] {
        assert_eq!(ar1[i], [0.0, 1.0], "{i}");
    }
    for i in [1, 2, 4] {
        let phi = (-(t[i] - t[i - 1]) / 2.0f64).exp();
        assert_eq!(ar1[i], [phi, (1.0 - phi * phi).sqrt()], "{i}");
    }
    // The regression's rows carry their runs: the same at the first row of run 1.
    let reg = Regression::new(&two_runs(), &VehicleParams::thesis());
    let ar1 = reg.ar1_coefficients(2.0);
    assert_eq!(ar1[5], [0.0, 1.0]);
    assert!(ar1[4][0] > 0.0 && ar1[6][0] > 0.0);
    assert_eq!(reg.prefix(7).row_ar1_coefficients(2.0), ar1[..7]);
}

#[test]
fn a_differentiated_acceleration_differences_within_each_run() {
    let cycle = two_runs();
    // Every sample but each run's first and last.
    let used: Vec<bool> = (0..cycle.len()).map(|i| !cycle.at_run_edge(i)).collect();
    assert_eq!(used.iter().filter(|u| **u).count(), 6);
    let reg = Regression::differentiated(&cycle, &used, 0.0, &VehicleParams::thesis());
    let rows = [1, 2, 3, 6, 7, 8];
    for (r, &i) in rows.iter().enumerate() {
        assert_eq!(cycle.run[i - 1], cycle.run[i + 1]);
        let central = (cycle.v_m_s[i + 1] - cycle.v_m_s[i - 1]) / 2.0;
        assert_eq!(reg.accel[r], central, "row {r}");
    }
    // The span runs from sample 0 to 9; its noise restarts at run 1's first sample.
    let d = reg.differentiation.as_ref().unwrap();
    assert_eq!(&*d.span_run, &cycle.run[..]);
    assert_eq!(reg.ar1_coefficients(2.0)[5], [0.0, 1.0]);
}

#[test]
#[should_panic(expected = "a sample of its run on each side")]
fn a_differentiated_row_at_a_run_edge_is_refused() {
    // Sample 4 is run 0's last: its central difference would reach into run 1.
    let cycle = two_runs();
    let mut used = vec![false; cycle.len()];
    used[3] = true;
    used[4] = true;
    Regression::differentiated(&cycle, &used, 0.0, &VehicleParams::thesis());
}

/// Whether two regressions hold the same bits in every column and constant sum.
fn assert_same_bits(a: &Regression, b: &Regression) {
    let columns = |r: &Regression| {
        [
            &r.t,
            &r.f,
            &r.c,
            &r.v,
            &r.y,
            &r.accel,
            &r.g_sin,
            &r.sin_grade,
            &r.cos_grade,
        ]
        .map(|c| c.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
    };
    assert_eq!(columns(a), columns(b));
    let sums = |r: &Regression| {
        let g = r.grade_sums_noise_free;
        let mut all: Vec<f64> = r.xtx.iter().chain(r.xty.iter()).copied().collect();
        all.extend([r.sum_f, r.sum_c, r.sum_y, g.s_s, g.s_1s, g.s_3s, g.s_ws]);
        all.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    };
    assert_eq!(sums(a), sums(b));
}

#[test]
fn a_recalibrated_or_regraded_regression_is_the_one_built_whole_bit_for_bit() {
    let vehicle = VehicleParams::thesis();
    let cycle = test_cycle();
    let base = Regression::new(&cycle, &vehicle);
    // A calibration drawn per realisation: only the force column and its sums change.
    let logged = |f: f64| f * 1.0137 + 3.0;
    let mut recalibrated = cycle.clone();
    recalibrated
        .f_prop_n
        .iter_mut()
        .for_each(|f| *f = logged(*f));
    assert_same_bits(
        &base.with_force(|f| f.iter_mut().for_each(|f| *f = logged(*f))),
        &Regression::new(&recalibrated, &vehicle),
    );
    // Another grade, given by its sine and cosine (an elevation map's error).
    let grade = |g: &f64| g + 0.01 * (g * 50.0).sin();
    let sin = || Column::collected(cycle.grade_rad.iter().map(|g| grade(g).sin()));
    let cos = || Column::collected(cycle.grade_rad.iter().map(|g| grade(g).cos()));
    let regraded = base.with_grade(sin(), cos());
    assert_same_bits(
        &regraded,
        &Regression::with_sin_cos(&cycle, sin(), cos(), &vehicle),
    );
    // Storage given back by a dropped regression and filled again holds the new values.
    drop(regraded);
    let again = base.with_grade(sin(), cos());
    let mut whole = cycle.clone();
    whole.grade_rad.iter_mut().for_each(|g| *g = grade(g));
    assert_same_bits(&again, &Regression::new(&whole, &vehicle));
}
