//! Where a study-file key belongs: each table's keys, and the message for a key placed in
//! the wrong table.

use super::noise::other_noise_keys;
use crate::dynamics::DRIVE_MODES;
use crate::estimate::channels::Channel;
use crate::terrain::profiles::PROFILES;

/// Keys of `[drive]` that every drive mode has.
pub(super) const COMMON_DRIVE_KEYS: [&str; 3] = ["min_speed", "exclude_braking", "durations"];

/// Keys of `[terrain]` that every profile has.
pub(super) const COMMON_TERRAIN_KEYS: [&str; 4] =
    ["profile", "length", "scales", "scale_applies_to"];

/// The keys of the study's fixed tables (`""`: the top level); `[vehicle]` and
/// `[estimation]` as their serde structs read them (a unit test checks the two agree).
const FIXED_KEYS: [(&str, &[&str]); 3] = [
    ("", &["name", "seed", "realisations", "model"]),
    (
        "vehicle",
        &[
            "mass",
            "drag_coefficient",
            "rolling_resistance",
            "road_load_a",
            "road_load_b",
            "road_load_c",
            "test_mass",
            "road_load_a_lbf",
            "road_load_b_lbf_per_mph",
            "road_load_c_lbf_per_mph2",
            "test_weight_lb",
            "frontal_area",
            "air_density",
            "gravity",
            "final_drive_ratio",
            "wheel_radius",
        ],
    ),
    (
        "estimation",
        &[
            "estimators",
            "forgetting",
            "acceleration",
            "air_speed",
            "known_mass",
            "effective_mass_factor",
            "grade",
            "speed_process_sd",
            "grade_walk",
            "prior_mass",
            "prior_mass_sd",
            "grade_sd0",
            "forgetting_mass",
            "forgetting_grade",
            "difference_window",
        ],
    ),
];

/// Every place a study-file key can stand: its table (`""` for the top level) and, for a
/// key of one drive mode or terrain profile only, that mode's or profile's name.
pub(super) fn home_of(key: &str) -> Vec<(&'static str, Option<&'static str>)> {
    let mut homes = Vec::new();
    for (table, keys) in FIXED_KEYS {
        if keys.contains(&key) {
            homes.push((table, None));
        }
    }
    if key == "mode" || COMMON_DRIVE_KEYS.contains(&key) {
        homes.push(("drive", None));
    }
    for mode in &DRIVE_MODES {
        if mode.keys.contains(&key) {
            homes.push(("drive", Some(mode.name)));
        }
    }
    if COMMON_TERRAIN_KEYS.contains(&key) {
        homes.push(("terrain", None));
    }
    for profile in &PROFILES {
        if profile.keys.contains(&key) {
            homes.push(("terrain", Some(profile.name)));
        }
    }
    let noise = Channel::ALL.map(Channel::key);
    if noise.contains(&key) || other_noise_keys().contains(&key) {
        homes.push(("noise", None));
    }
    if super::truth::truth_keys().contains(&key) {
        homes.push(("truth", None));
    }
    if super::campaign::campaign_keys().contains(&key) {
        homes.push(("campaign", None));
    }
    homes
}

/// The keys of `[vehicle]`: those a fleet's columns may give.
pub(super) fn vehicle_keys() -> &'static [&'static str] {
    FIXED_KEYS
        .iter()
        .find(|(table, _)| *table == "vehicle")
        .map(|(_, keys)| *keys)
        .expect("[vehicle] has fixed keys")
}

/// Where a key unknown in `[table]` belongs instead, in words (`None`: nowhere).
pub(super) fn elsewhere(table: &str, key: &str, variant: Option<(&str, &str)>) -> Option<String> {
    let homes = home_of(key);
    if let Some((kind, this)) = variant
        && let Some(other) = homes
            .iter()
            .find_map(|(t, v)| (*t == table).then_some(*v).flatten())
    {
        return Some(format!(
            "it is a key of {kind} \"{other}\", and this [{table}] is {kind} \"{this}\""
        ));
    }
    homes
        .iter()
        .find(|(t, _)| *t != table)
        .map(|(t, _)| match *t {
            "" => "it belongs at the top of the file, before any [table]".to_string(),
            t => format!("it belongs in [{t}]"),
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::raw::{RawEstimation, RawVehicle};

    /// The fields serde lists for an unknown key of a fixed table.
    fn serde_fields<T: serde::de::DeserializeOwned + std::fmt::Debug>() -> Vec<String> {
        let err = toml::from_str::<T>("no_such_key = 1")
            .unwrap_err()
            .to_string();
        // Two fields are listed as "expected `a` or `b`", more as "expected one of `a`, …".
        let list = err
            .split("expected one of")
            .nth(1)
            .or_else(|| err.split("expected").nth(1))
            .expect("serde lists the fields")
            .replace(" or ", ",");
        list.split(',')
            .map(|f| {
                f.trim()
                    .trim_matches(|c: char| c == '`' || c.is_whitespace())
            })
            .map(|f| f.split('`').next().unwrap_or(f).to_string())
            .filter(|f| !f.is_empty())
            .collect()
    }

    #[test]
    fn the_fixed_tables_keys_are_the_serde_structs_fields() {
        for (table, fields) in [
            ("vehicle", serde_fields::<RawVehicle>()),
            ("estimation", serde_fields::<RawEstimation>()),
        ] {
            let keys = FIXED_KEYS.iter().find(|(t, _)| *t == table).unwrap().1;
            assert_eq!(keys, fields.as_slice(), "[{table}]");
        }
    }

    #[test]
    fn the_fit_file_s_tables_keys_are_its_serde_structs_fields() {
        use crate::study::fit::placement::FIT_KEYS;
        use crate::study::fit::{RawFitEstimation, RawFitVehicle, RawLog, RawReference};
        for (table, fields) in [
            ("log", serde_fields::<RawLog>()),
            ("vehicle", serde_fields::<RawFitVehicle>()),
            ("estimation", serde_fields::<RawFitEstimation>()),
            ("reference", serde_fields::<RawReference>()),
        ] {
            let keys = FIT_KEYS.iter().find(|(t, _)| *t == table).unwrap().1;
            assert_eq!(keys, fields.as_slice(), "[{table}]");
        }
    }

    #[test]
    fn a_key_of_another_table_is_placed() {
        assert_eq!(
            elsewhere("terrain", "min_speed", Some(("profile", "cos2"))).as_deref(),
            Some("it belongs in [drive]")
        );
        assert_eq!(elsewhere("terrain", "no_such_key", None), None);
        assert_eq!(
            elsewhere("noise", "seed", None).as_deref(),
            Some("it belongs at the top of the file, before any [table]")
        );
    }
}
