//! Where the keys of a fit file belong: the keys of its fixed tables, and the table a key
//! written in the wrong one belongs in instead.

use crate::estimate::channels::Channel;
use crate::study::axes::VELOCITY_CORRELATION;
use crate::study::truth::truth_keys;

/// The keys of the fit file's fixed tables (`""`: the top level), as the serde structs
/// read them (a unit test checks the two agree); `[noise]` has the channels' keys and
/// `velocity_correlation_time`.
pub(in crate::study) const FIT_KEYS: [(&str, &[&str]); 5] = [
    ("", &["name", "seed", "realisations"]),
    (
        "log",
        &[
            "file",
            "time_column",
            "speed_column",
            "speed_unit",
            "force_column",
            "torque_column",
            "grade_column",
            "grade_unit",
            "acceleration_column",
            "min_speed",
        ],
    ),
    (
        "vehicle",
        &[
            "mass",
            "drag_coefficient",
            "rolling_resistance",
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
    (
        "reference",
        &["mass", "drag_coefficient", "rolling_resistance"],
    ),
];

/// Where a key unknown in `[table]` of a fit file belongs instead (the fit file's
/// [`Placement`](crate::study::checker::Placement)).
pub(super) fn elsewhere(table: &str, key: &str, _variant: Option<(&str, &str)>) -> Option<String> {
    let noise =
        Channel::ALL.iter().any(|c| c.own_axis() && c.key() == key) || key == VELOCITY_CORRELATION;
    let systematic = truth_keys().contains(&key);
    FIT_KEYS
        .iter()
        .filter(|(_, keys)| keys.contains(&key))
        .map(|(t, _)| *t)
        .chain(noise.then_some("noise"))
        .chain(systematic.then_some("systematic"))
        .find(|t| *t != table)
        .map(|t| match t {
            "" => "it belongs at the top of the file, before any [table]".to_string(),
            t => format!("it belongs in [{t}]"),
        })
}
