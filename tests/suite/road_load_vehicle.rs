//! `[vehicle]` by road load (docs/model.md#road-load-vehicle): A, B, C and a test mass (SI or
//! the EPA list's units) are the vehicle the road_load analysis of a coast-down recovers.

use chassis_mc::study::Study;

use super::common::*;

/// A passenger car's road load: A [N], B [N/(m/s)] (≠ 0: the speed-dependent rolling
/// resistance), C [N/(m/s)²], test mass [kg].
const ROAD_LOAD: [f64; 4] = [150.0, 2.5, 0.42, 1500.0];

/// `studies/coastdown.toml` without noise, road_load only, its vehicle given by `vehicle`
/// (the `[vehicle]` lines after `frontal_area`, `air_density` and `gravity`).
fn coastdown(vehicle: &str) -> Result<Study, chassis_mc::study::StudyError> {
    let text = study_text("coastdown.toml");
    let start = text.find("[vehicle]").unwrap();
    let end = text.find("[drive]").unwrap();
    let text = format!(
        "{}[vehicle]\nfrontal_area = 2.2\nair_density = 1.2\ngravity = 9.81\n{vehicle}\n\n{}",
        &text[..start],
        &text[end..]
    );
    let text = set_key(&text, "velocity_sd", "[0.0]");
    let text = set_key(&text, "estimators", "[\"road_load\"]");
    Study::from_toml(&text, "road_load_vehicle.toml")?.with_overrides(Some(2), None)
}

#[test]
fn road_load_in_is_road_load_out_on_a_noise_free_flat_coast_down() {
    // SI keys, and the same vehicle in the EPA list's units (lbf, lbf/mph, lbf/mph², lb).
    let [a, b, c, m] = ROAD_LOAD;
    let (lbf, mph, lb) = (4.4482216152605, 0.44704, 0.45359237);
    let si = format!("road_load_a = {a}\nroad_load_b = {b}\nroad_load_c = {c}\ntest_mass = {m}");
    let epa = format!(
        "road_load_a_lbf = {:?}\nroad_load_b_lbf_per_mph = {:?}\nroad_load_c_lbf_per_mph2 = {:?}\ntest_weight_lb = {:?}",
        a / lbf,
        b * mph / lbf,
        c * mph * mph / lbf,
        m / lb
    );
    for vehicle in [si, epa] {
        let study = coastdown(&vehicle).unwrap();
        let vs = study.vehicle().unwrap();
        // The conversion: M = test mass, Cr = A/(M g), Cd = 2C/(ρ A_f).
        let rel = |x: f64, t: f64| ((x - t) / t).abs();
        assert!(rel(vs.vehicle.mass_kg, m) <= 1e-12);
        assert!(rel(vs.vehicle.rolling_resistance, a / (m * 9.81)) <= 1e-12);
        assert!(rel(vs.vehicle.drag_coefficient, 2.0 * c / (1.2 * 2.2)) <= 1e-12);
        // The coast-down's road_load analysis returns A, B, C: noise-free on a flat road the
        // truth's force is A + B·V + C·V² exactly, and the fit's rounding over 8 runs of
        // [1, V, V²] (equilibrated condition ≈ 1e5) stays below 1e-9 relative.
        let (dir, _) = run(&study, None);
        let table = read_table(&dir.path().join("realisations.parquet"));
        for (column, truth) in [("road_load_a", a), ("road_load_b", b), ("road_load_c", c)] {
            for x in f64_col(&table, column) {
                assert!(
                    rel(x, truth) <= 1e-9,
                    "{vehicle}: {column} {x} against {truth}"
                );
            }
        }
    }
}

#[test]
fn a_vehicle_given_twice_or_by_half_a_road_load_is_named() {
    for (vehicle, key, reason) in [
        (
            "mass = 1500.0\ndrag_coefficient = 0.3\nrolling_resistance = 0.01\nroad_load_c = 0.4",
            "vehicle.road_load_c",
            "vehicle.mass are both given",
        ),
        (
            "road_load_a = 150.0\nroad_load_b = 2.5\ntest_mass = 1500.0",
            "vehicle.road_load_c",
            "required key is missing",
        ),
        (
            "road_load_a = 150.0\nroad_load_b = 2.5\nroad_load_c = 0.4\ntest_mass = 1500.0\ntest_weight_lb = 3300.0",
            "vehicle.test_weight_lb",
            "not both",
        ),
    ] {
        let err = coastdown(vehicle).unwrap_err();
        assert_eq!(err.key.as_deref(), Some(key), "{vehicle}: {err}");
        assert!(err.to_string().contains(reason), "{vehicle}: {err}");
    }
}
