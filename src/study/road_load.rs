//! `[vehicle]` given by its road-load coefficients (docs/model.md#road-load-vehicle): the
//! coast-down's A + B·V + C·V² and a test mass, in SI units (`road_load_a` [N],
//! `road_load_b` [N/(m/s)], `road_load_c` [N/(m/s)²], `test_mass` [kg]) or the EPA test car
//! list's (`road_load_a_lbf`, `road_load_b_lbf_per_mph`, `road_load_c_lbf_per_mph2`,
//! `test_weight_lb`). M = the test mass, Cr = A/(M g), Cd = 2C/(ρ A_f), and B the truth's
//! speed-dependent rolling resistance, `rolling_speed_coefficient` = B/A: the exact inverse
//! of the `road_load` estimator on a flat coast-down.

use super::StudyError;
use super::checker::Checker;
use super::raw::RawVehicle;
use super::truth::TruthAxes;
use crate::dynamics::truth::MODEL_ERRORS;

/// One pound-force \[N\].
pub const LBF_N: f64 = 4.4482216152605;
/// One mile per hour \[m/s\].
pub const MPH_M_S: f64 = 0.44704;
/// One pound \[kg\].
pub const LB_KG: f64 = 0.45359237;

/// The vehicle's M, Cd and Cr, and the truth's rolling-resistance speed coefficient (0 when
/// the vehicle is given by Cd and Cr).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct VehicleBy {
    pub mass_kg: f64,
    pub drag_coefficient: f64,
    pub rolling_resistance: f64,
    pub rolling_speed_coefficient: f64,
}

/// Read `[vehicle]`'s mass and resistances: by Cd and Cr, or by road load (SI or the EPA
/// list's units), never both; each set complete.
pub(super) fn vehicle_by(
    v: &RawVehicle,
    frontal_area_m2: f64,
    air_density_kg_m3: f64,
    gravity_m_s2: f64,
    c: &Checker<'_>,
) -> Result<VehicleBy, StudyError> {
    let si = [
        ("road_load_a", v.road_load_a, 1.0),
        ("road_load_b", v.road_load_b, 1.0),
        ("road_load_c", v.road_load_c, 1.0),
        ("test_mass", v.test_mass, 1.0),
    ];
    let epa = [
        ("road_load_a_lbf", v.road_load_a_lbf, LBF_N),
        (
            "road_load_b_lbf_per_mph",
            v.road_load_b_lbf_per_mph,
            LBF_N / MPH_M_S,
        ),
        (
            "road_load_c_lbf_per_mph2",
            v.road_load_c_lbf_per_mph2,
            LBF_N / (MPH_M_S * MPH_M_S),
        ),
        ("test_weight_lb", v.test_weight_lb, LB_KG),
    ];
    let classic = [
        ("mass", v.mass),
        ("drag_coefficient", v.drag_coefficient),
        ("rolling_resistance", v.rolling_resistance),
    ];
    let given = |set: &[(&'static str, Option<f64>, f64)]| {
        set.iter().find(|(_, x, _)| x.is_some()).map(|(k, _, _)| *k)
    };
    let (si_key, epa_key) = (given(&si), given(&epa));
    let classic_key = classic.iter().find(|(_, x)| x.is_some()).map(|(k, _)| *k);
    let set = match (si_key, epa_key, classic_key) {
        (None, None, _) => {
            let [m, cd, cr] = classic.map(|(k, x)| {
                x.ok_or_else(|| c.fail(&format!("vehicle.{k}"), "required key is missing (or give the vehicle by road load: road_load_a, road_load_b, road_load_c, test_mass)"))
            });
            return Ok(VehicleBy {
                mass_kg: c.positive("vehicle.mass", m?)?,
                drag_coefficient: c.non_negative("vehicle.drag_coefficient", cd?)?,
                rolling_resistance: c.non_negative("vehicle.rolling_resistance", cr?)?,
                rolling_speed_coefficient: 0.0,
            });
        }
        (Some(a), _, Some(b)) | (None, Some(a), Some(b)) => {
            return Err(c.fail(
                &format!("vehicle.{a}"),
                format!(
                    "and vehicle.{b} are both given: give the vehicle by mass, drag_coefficient \
                     and rolling_resistance, or by its road load, not both"
                ),
            ));
        }
        (Some(a), Some(b), None) => {
            return Err(c.fail(
                &format!("vehicle.{b}"),
                format!(
                    "and vehicle.{a} are both given: give the road load in SI units or in the \
                     EPA list's (lbf, mph, lb), not both"
                ),
            ));
        }
        (Some(_), None, None) => si,
        (None, Some(_), None) => epa,
    };
    let [a, b, cc, m] = set.map(|(k, x, factor)| {
        x.map(|x| (k, x * factor)).ok_or_else(|| {
            c.fail(
                &format!("vehicle.{k}"),
                "required key is missing: the road load needs A, B, C and the test mass",
            )
        })
    });
    let ((a_key, a), (b_key, b), (c_key, cc), (m_key, m)) = (a?, b?, cc?, m?);
    let a = c.positive(&format!("vehicle.{a_key}"), a)?;
    let cc = c.positive(&format!("vehicle.{c_key}"), cc)?;
    let m = c.positive(&format!("vehicle.{m_key}"), m)?;
    if !b.is_finite() {
        return Err(c.fail(&format!("vehicle.{b_key}"), "must be a finite number"));
    }
    Ok(VehicleBy {
        mass_kg: m,
        drag_coefficient: 2.0 * cc / (air_density_kg_m3 * frontal_area_m2),
        rolling_resistance: a / (m * gravity_m_s2),
        rolling_speed_coefficient: b / a,
    })
}

/// Set the truth's `rolling_speed_coefficient` to B/A of a vehicle given by road load; an
/// error when `[truth]` sets it too.
pub(super) fn set_rolling_speed(
    truth: &mut TruthAxes,
    coefficient: f64,
    table: Option<&toml::Table>,
    c: &Checker<'_>,
) -> Result<(), StudyError> {
    let key = "rolling_speed_coefficient";
    if table.is_some_and(|t| t.contains_key(key)) {
        return Err(c.fail(
            &format!("truth.{key}"),
            "and vehicle.road_load_b are both given: the road load's B sets the truth's \
             rolling_speed_coefficient (B/A)",
        ));
    }
    let i = MODEL_ERRORS
        .iter()
        .position(|e| e.key == key)
        .expect("an entry");
    truth.set(i, vec![coefficient]);
    Ok(())
}
