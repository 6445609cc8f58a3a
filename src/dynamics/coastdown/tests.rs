use super::*;
use crate::dynamics::Road;

/// The passenger car of `studies/coastdown.toml`.
fn car() -> VehicleParams {
    VehicleParams {
        mass_kg: 1500.0,
        drag_coefficient: 0.30,
        rolling_resistance: 0.010,
        frontal_area_m2: 2.2,
        air_density_kg_m3: 1.2,
        gravity_m_s2: 9.81,
        drivetrain: None,
    }
}

fn drive(time_step_s: f64, runs: usize, directions: Directions) -> CoastDown {
    CoastDown {
        speed_high_m_s: 33.3,
        speed_low_m_s: 8.3,
        runs: vec![runs],
        time_step_s,
        start_distance_m: 0.0,
        run_spacing_m: None,
        directions,
    }
}

fn flat(drive: &CoastDown) -> DriveCycle {
    let road = Road {
        table: None,
        scale: 1.0,
    };
    drive.cycle(&car(), road, &Truth::default()).unwrap()
}

/// The largest |V − V_exact| over run 0 of the flat, calm coast-down at step `h`, and
/// the run's samples' count. On a flat road in calm air M dV/dt = −kCd V² − Cr M g, so
/// with a = Cr g, b = kCd/M: V(t) = √(a/b)·tan(atan(V₀√(b/a)) − √(ab)·t).
fn closed_form_error(h: f64) -> (f64, usize) {
    let veh = car();
    let cycle = flat(&drive(h, 2, Directions::Alternate));
    let a = veh.rolling_resistance * veh.gravity_m_s2;
    let b = veh.drag_factor_kg_m() * veh.drag_coefficient / veh.mass_kg;
    let v0 = 33.3;
    let exact = |t: f64| (a / b).sqrt() * ((v0 * (b / a).sqrt()).atan() - (a * b).sqrt() * t).tan();
    let run0: Vec<usize> = (0..cycle.len()).filter(|&i| cycle.run[i] == 0).collect();
    let error = run0
        .iter()
        .map(|&i| (cycle.v_m_s[i] - exact(cycle.t_s[i])).abs())
        .fold(0.0, f64::max);
    (error, run0.len())
}

#[test]
fn a_flat_calm_coast_down_is_the_closed_form_to_rk4_s_h4_error() {
    // RK4's global error is C·h⁴: halving the step from 2 s to 1 s divides it by 16
    // (measured 14.5; the next order, h⁵, makes it differ from 16 by a few per cent of
    // itself per halving, so [12, 20] holds it and rules out order 3 (8) or 5 (32)).
    let (e2, _) = closed_form_error(2.0);
    let (e1, _) = closed_form_error(1.0);
    let ratio = e2 / e1;
    assert!(
        (12.0..20.0).contains(&ratio),
        "error ratio {ratio} ({e2} / {e1})"
    );
    // At the example's h = 0.1 s the truncation error is (0.1/1)⁴ = 1e-4 of h = 1 s's
    // (twice that allowed for the next order), plus rounding: ~1256 steps of a speed
    // of ~30 m/s, each ~1e-15 m/s, so 1e-12 m/s.
    let (e01, samples) = closed_form_error(0.1);
    let tolerance = 2.0 * 1e-4 * e1 + 1e-12;
    println!("RK4 against the closed form: {e2:e} m/s at 2 s, {e1:e} at 1 s, {e01:e} at 0.1 s");
    assert!(e01 <= tolerance, "{e01} m/s vs {tolerance} m/s");
    // The run lasts until the last sample with V ≥ 8.3 m/s: t = 125.6 s at h = 0.1 s,
    // sample 1256 (the closed form reaches 8.3 m/s at t = 125.656 s).
    assert_eq!(samples, 1257);
}

#[test]
fn each_run_ends_at_its_last_sample_at_or_above_speed_low() {
    let d = drive(0.1, 4, Directions::Alternate);
    let cycle = flat(&d);
    assert_eq!(cycle.runs(), 4);
    for k in 0..4u32 {
        let rows: Vec<usize> = (0..cycle.len()).filter(|&i| cycle.run[i] == k).collect();
        let (first, last) = (rows[0], rows[rows.len() - 1]);
        assert_eq!(cycle.v_m_s[first], 33.3);
        assert!(cycle.v_m_s[last] >= 8.3);
        // One more step would fall below speed_low: the speed falls by less than
        // 0.2 m/s per 0.1 s step at the end (a + bV² ≈ 0.12 m/s² at 8.3 m/s).
        assert!(cycle.v_m_s[last] < 8.3 + 0.02, "{}", cycle.v_m_s[last]);
    }
    // One clock: t_i = i·Δt over the whole cycle, runs end to end.
    for (i, t) in cycle.t_s.iter().enumerate() {
        assert_eq!(*t, i as f64 * 0.1);
    }
}

#[test]
fn run_k_starts_at_start_plus_k_spacings_and_odd_runs_drive_backwards() {
    let mut d = drive(0.1, 4, Directions::Alternate);
    d.start_distance_m = 5000.0;
    d.run_spacing_m = Some(2500.0);
    let cycle = flat(&d);
    for k in 0..4u32 {
        let rows: Vec<usize> = (0..cycle.len()).filter(|&i| cycle.run[i] == k).collect();
        let (first, last) = (rows[0], rows[rows.len() - 1]);
        assert_eq!(cycle.x_m[first], 5000.0 + 2500.0 * k as f64);
        let heading = if k % 2 == 1 { -1.0 } else { 1.0 };
        assert_eq!(cycle.run_heading[k as usize], heading);
        // The distance covered is the same each way on a flat calm road, exactly (the
        // same RK4 steps with the sign of dX/dt flipped).
        let covered = cycle.x_m[last] - cycle.x_m[first];
        assert!(heading * covered > 1000.0, "run {k} covers {covered} m");
    }
    // The default spacing is the distance run 0 covers: run 1 drives it back to the
    // start, ending where run 0 began (the same steps negated: to rounding).
    let d = drive(0.1, 2, Directions::Alternate);
    let cycle = flat(&d);
    let last0 = cycle.run.iter().rposition(|&r| r == 0).unwrap();
    assert_eq!(cycle.x_m[last0 + 1], cycle.x_m[last0]);
    let end = *cycle.x_m.last().unwrap();
    assert!(end.abs() < 1e-9, "{end}");
    // One way: every run forwards from its start, run 1 from where run 0 ended to twice
    // as far (the same steps from another start: to rounding).
    let one_way = flat(&drive(0.1, 2, Directions::OneWay));
    assert_eq!(one_way.run_heading, [1.0, 1.0]);
    let end = *one_way.x_m.last().unwrap();
    assert!((end - 2.0 * cycle.x_m[last0]).abs() < 1e-9 * end, "{end}");
}

#[test]
fn a_reverse_run_sees_the_grade_negated() {
    // A 0.5 % climb with a 0.3 % ripple of period 628 m: run 0 climbs it, run 1
    // (backwards) descends it, seeing −θ(x) at every sample.
    let grades = (0..20_000)
        .map(|i| 0.005 + 0.003 * (i as f64 / 100.0).sin())
        .collect();
    let table = GradeTable::from_grades(grades);
    let d = CoastDown {
        start_distance_m: 5000.0,
        ..drive(0.1, 2, Directions::Alternate)
    };
    let road = Road {
        table: Some(&table),
        scale: 1.0,
    };
    let cycle = d.cycle(&car(), road, &Truth::default()).unwrap();
    for i in 0..cycle.len() {
        let theta = table.grade_at(cycle.x_m[i]).unwrap();
        let heading = if cycle.run[i] == 0 { 1.0 } else { -1.0 };
        assert_eq!(cycle.grade_rad[i], heading * theta);
        assert_eq!(cycle.f_prop_n[i], 0.0);
    }
    // Downhill the run lasts longer.
    let n0 = cycle.run.iter().filter(|&&r| r == 0).count();
    assert!(cycle.len() - n0 > n0);
}

#[test]
fn backwards_off_the_start_of_the_terrain_is_an_error_naming_the_run() {
    // Run 1 goes back from the end of run 0 downhill, further than run 0 climbed: it
    // passes x = 0.
    let table = GradeTable::from_grades(vec![0.01; 20_000]);
    let road = Road {
        table: Some(&table),
        scale: 1.0,
    };
    let err = drive(0.1, 2, Directions::Alternate)
        .cycle(&car(), road, &Truth::default())
        .unwrap_err();
    assert!(
        matches!(err, SimulationError::CoastRun { run: 1, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("drive.start_distance"), "{err}");
}

#[test]
fn a_run_that_does_not_slow_down_is_an_error() {
    // A 5 % descent: g sin θ ≈ 0.49 m/s² beats rolling and drag at every speed below
    // ~40 m/s, so the vehicle never slows to 8.3 m/s.
    let table = GradeTable::from_grades(vec![-0.05; 1_000_000]);
    let road = Road {
        table: Some(&table),
        scale: 1.0,
    };
    let err = drive(0.1, 2, Directions::OneWay)
        .cycle(&car(), road, &Truth::default())
        .unwrap_err();
    assert!(
        matches!(err, SimulationError::CoastRun { run: 0, .. }),
        "{err}"
    );
}

fn parse(text: &str) -> Result<Arc<dyn CycleSource>, KeyError> {
    let table: toml::Table = toml::from_str(text).unwrap();
    CoastDown::parse(&Params::new(&table, "drive"))
}

#[test]
fn the_keys_are_checked_and_named() {
    let base = "speed_high = 33.3\nspeed_low = 8.3\ntime_step = 0.1\n";
    let ok = parse(&format!("{base}runs = [4, 8]")).unwrap();
    assert_eq!(ok.runs(), Some(&[4, 8][..]));
    assert_eq!(
        parse(&format!("{base}runs = 6")).unwrap().runs(),
        Some(&[6][..])
    );
    let err = |text: &str| parse(&format!("{base}{text}")).unwrap_err();
    assert_eq!(err("runs = [4, 3]").key, "drive.runs[1]");
    assert_eq!(err("runs = 5").key, "drive.runs");
    assert_eq!(err("runs = [0]").key, "drive.runs[0]");
    assert_eq!(err("runs = [4, 4]").key, "drive.runs[1]");
    assert_eq!(err("runs = [4.0]").key, "drive.runs[0]");
    assert_eq!(
        err("runs = [4]\ndirections = \"both\"").key,
        "drive.directions"
    );
    let e = parse("speed_high = 8.3\nspeed_low = 8.3\ntime_step = 0.1\nruns = 2").unwrap_err();
    assert_eq!(e.key, "drive.speed_low");
    assert!(e.reason.contains("below drive.speed_high"), "{}", e.reason);
    assert_eq!(parse(base).unwrap_err().key, "drive.runs");
}
