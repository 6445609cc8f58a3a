use super::*;
use crate::dynamics::VehicleParams;

/// `[drive]` of a designed drive with `extra` keys replacing the defaults.
fn parse(extra: &str) -> Result<DriveDesign, KeyError> {
    let mut table: toml::Table = toml::from_str(
        "duration = 60.0\ntime_step = 0.01\ninitial_speed = 10.0\ntorque_min = 0.0\n\
         torque_max = 450.0\nspeed_min = 10.0\nspeed_max = 35.0\nsegments = 12\n\
         shape = \"constant\"\ncriterion = \"d\"\n",
    )
    .unwrap();
    let extra: toml::Table = toml::from_str(extra).unwrap();
    table.extend(extra);
    let source = DriveDesign::parse(&Params::new(&table, "drive"))?;
    Ok(source.design().unwrap().clone())
}

#[test]
fn bad_keys_are_named() {
    for (extra, key) in [
        ("initial_speed = 5.0", "drive.initial_speed"),
        ("segments = 7", "drive.segments"),
        ("torque_max = -1.0", "drive.torque_max"),
        ("speed_max = 9.0", "drive.speed_max"),
        ("speed_band = 20.0", "drive.speed_band"),
        ("torque_mean = 225.0", "drive.torque_amplitude"),
        ("shape = \"wavy\"", "drive.shape"),
    ] {
        let err = parse(extra).unwrap_err();
        assert_eq!(err.key, key, "{extra}: {}", err.reason);
    }
}

#[test]
fn the_profiles_are_constant_or_linear_between_midpoints() {
    let d = parse("segments = 3\nduration = 0.06\n").unwrap(); // 6 steps, 2 per segment
    assert_eq!(
        d.planned(&[0.0, 10.0, 40.0]),
        vec![0.0, 0.0, 10.0, 10.0, 40.0, 40.0, 40.0]
    );
    let s = parse("segments = 3\nduration = 0.06\nshape = \"smooth\"\n").unwrap();
    // Midpoints at samples 0.5, 2.5, 4.5 (in step units): linear between, flat outside.
    let planned = s.planned(&[0.0, 10.0, 40.0]);
    let expected = [0.0, 2.5, 7.5, 17.5, 32.5, 40.0, 40.0];
    for (p, e) in planned.iter().zip(expected) {
        assert!((p - e).abs() < 1e-12, "{planned:?}");
    }
}

#[test]
fn the_governor_holds_the_limits_and_the_designed_drive_repeats_it() {
    // Full torque for a minute on a flat road would pass 35 m/s; the governor caps it, and
    // the drive of the torque it applied is the governed drive to the bit.
    let vehicle = VehicleParams::thesis();
    let d = parse("").unwrap();
    let flat = GradeTable::from_grades(vec![0.0; 3000]);
    let planned = vec![450.0; d.samples()];
    let driven = d.governed(&vehicle, &flat, &planned).unwrap();
    let v = &driven.cycle.v_m_s;
    assert!(v.iter().all(|v| (10.0..=35.0).contains(v)));
    assert!(v.iter().any(|&v| v > 34.0), "the limit is reached");
    assert!(driven.governed_fraction > 0.0);
    let designed = DesignedDrive {
        design: d.clone(),
        torque_n_m: Arc::new(driven.torque_n_m.clone()),
        levels: vec![450.0; 12],
        summary: DesignSummary {
            criterion: "d".into(),
            estimator: "ols".into(),
            bound: "crlb_output",
            candidates: Vec::new(),
            evaluations: 0,
        },
    };
    let again = designed.drive(&vehicle, &flat, &Truth::default()).unwrap();
    assert_eq!(again, driven.cycle);
}

#[test]
fn a_grade_too_steep_for_the_torque_limits_is_named() {
    // Downhill at 0.3 rad: even zero torque accelerates the vehicle past speed_max.
    let vehicle = VehicleParams::thesis();
    let d = parse("").unwrap();
    let steep = GradeTable::from_grades(vec![-0.3; 5000]);
    let err = d
        .governed(&vehicle, &steep, &vec![0.0; d.samples()])
        .unwrap_err();
    assert!(
        matches!(
            err,
            SimulationError::SpeedLimit {
                key: "speed_max",
                ..
            }
        ),
        "{err}"
    );
}
