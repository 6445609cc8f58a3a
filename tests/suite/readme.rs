//! The README's lists that name the code's entries (the condition axes, the drive modes) name
//! exactly those entries, in the code's order: adding an entry without its README line fails
//! here.

use chassis_mc::dynamics::DRIVE_MODES;
use chassis_mc::model::vehicle::axes;

use super::common::*;

fn readme() -> String {
    std::fs::read_to_string(root().join("README.md")).unwrap()
}

/// The README's "Conditions are the product …" names the vehicle model's condition axes,
/// outermost first, by their study keys.
///
/// Regression: the product left out `estimation.acceleration`.
#[test]
fn the_readme_condition_product_is_the_vehicle_axes_in_nesting_order() {
    let text = readme().split_whitespace().collect::<Vec<_>>().join(" ");
    let product = text
        .split("Conditions are the product `")
        .nth(1)
        .and_then(|rest| rest.split('`').next())
        .expect("the README states the condition product");
    // A key's last segment is its axis column, a list's name in the singular.
    let factors: Vec<&str> = product
        .split(" × ")
        .map(|key| match key.rsplit('.').next().unwrap() {
            "scales" => "scale",
            "durations" => "duration",
            column => column,
        })
        .collect();
    let columns: Vec<String> = axes().map(|a| a.column().name.to_string()).collect();
    assert_eq!(factors, columns);
}

/// The README's `drive.mode` row names every drive mode a study can name, in order.
///
/// Regression: the row named `torque` and `speed_trace`, not `replay`.
#[test]
fn the_readme_drive_mode_row_names_every_drive_mode() {
    let text = readme();
    let row = text
        .lines()
        .find(|l| l.starts_with("| `drive.mode`"))
        .expect("the README has a drive.mode row");
    // The code spans of the row that are quoted values.
    let named: Vec<&str> = row
        .split('`')
        .skip(1)
        .step_by(2)
        .filter_map(|span| span.strip_prefix('"')?.strip_suffix('"'))
        .collect();
    let modes: Vec<&str> = DRIVE_MODES.iter().map(|m| m.name).collect();
    assert_eq!(named, modes);
}
