//! The steady model errors: the same in every realisation, set per condition
//! (docs/model.md#model-errors, one paragraph each).

use std::sync::Arc;

use super::{ModelError, ModelErrorEntry, TruthSample};
use crate::dynamics::VehicleParams;

/// Steady wind along the route, `w` \[m/s\], positive a headwind when the vehicle drives the
/// route forwards (a tailwind backwards: the wind along the direction of travel is
/// heading·w): the truth's aerodynamic force is k·Cd·(V + w)·|V + w|, so
/// D₀ = k·Cd·[(V + w)|V + w| − V²] (made by [`Truth`](super::Truth) from every entry's wind
/// together).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wind {
    /// w \[m/s\].
    pub speed_m_s: f64,
}

impl ModelError for Wind {
    fn wind_m_s(&self, s: &TruthSample) -> f64 {
        s.heading * self.speed_m_s
    }
}

/// The inertia of rotating parts, δ: the inertial term is M(1 + δ)·dV/dt, so m_D = δ·M.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RotatingMass {
    /// δ \[-\].
    pub factor: f64,
}

impl ModelError for RotatingMass {
    fn added_inertia_kg(&self, vehicle: &VehicleParams, _s: &TruthSample) -> f64 {
        self.factor * vehicle.mass_kg
    }
}

/// A fixed calibration error of the force signal, s: the log records (1 + s)·F. The truth's
/// motion is unchanged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceScale {
    /// s \[-\].
    pub scale: f64,
}

impl ModelError for ForceScale {
    fn logged_force(&self, force_n: f64) -> f64 {
        (1.0 + self.scale) * force_n
    }
}

/// Rolling resistance growing with speed, c_v \[s/m\]: Cr·(1 + c_v·V), so
/// D₀ = Cr·c_v·V·M·g·cos θ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollingSpeed {
    /// c_v \[s/m\].
    pub coefficient_s_m: f64,
}

impl ModelError for RollingSpeed {
    fn omitted_force(&self, vehicle: &VehicleParams, s: &TruthSample) -> f64 {
        vehicle.rolling_resistance
            * self.coefficient_s_m
            * s.speed_m_s
            * vehicle.mass_kg
            * vehicle.gravity_m_s2
            * s.grade_rad.cos()
    }
}

/// The true air density over `vehicle.air_density`, r: the truth's aerodynamic force is
/// r·k·Cd·V², so D₀ = (r − 1)·k·Cd·V² (the regression keeps the assumed density in k).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AirDensity {
    /// r \[-\].
    pub ratio: f64,
}

impl ModelError for AirDensity {
    fn air_density_factor(&self) -> f64 {
        self.ratio
    }
}

/// A mass changing linearly in time, ṁ \[kg/s\] (fuel burn: negative): M(t) = M + ṁ·t in the
/// inertia, the rolling resistance and the climbing force, θ's truth the mass at t = 0. So
/// m_D = ṁ·t and D₀ = ṁ·t·g·(Cr cos θ + sin θ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassRate {
    /// ṁ \[kg/s\].
    pub rate_kg_s: f64,
}

impl ModelError for MassRate {
    fn added_inertia_kg(&self, _vehicle: &VehicleParams, s: &TruthSample) -> f64 {
        self.rate_kg_s * s.time_s
    }

    fn omitted_force(&self, vehicle: &VehicleParams, s: &TruthSample) -> f64 {
        let dm = self.rate_kg_s * s.time_s;
        dm * vehicle.gravity_m_s2
            * (vehicle.rolling_resistance * s.grade_rad.cos() + s.grade_rad.sin())
    }
}

/// `Some(reason)` unless `v` is a finite number in `[low, high]`.
pub(super) fn within(v: f64, low: f64, high: f64, reason: &'static str) -> Option<&'static str> {
    (!(v.is_finite() && (low..=high).contains(&v))).then_some(reason)
}

/// The strongest steady wind a study may name \[m/s\]: a violent storm (Beaufort 11 ends at
/// 32.6 m/s); beyond it no road test runs, and the truth's motion is meaningless.
pub(super) const WIND_LIMIT_M_S: f64 = 50.0;

/// `truth.wind_speed`.
pub(super) const WIND: ModelErrorEntry = ModelErrorEntry {
    name: "steady wind",
    key: "wind_speed",
    unit: "m/s",
    axis: true,
    drawn: false,
    neutral: 0.0,
    check: |w| {
        within(
            w,
            -WIND_LIMIT_M_S,
            WIND_LIMIT_M_S,
            "must be a finite number within ±50 m/s (a violent storm)",
        )
    },
    build: |w, _| Some(Arc::new(Wind { speed_m_s: w })),
};

/// `truth.rotating_mass_factor`.
pub(super) const ROTATING_MASS: ModelErrorEntry = ModelErrorEntry {
    name: "rotating mass",
    key: "rotating_mass_factor",
    unit: "",
    axis: true,
    drawn: false,
    neutral: 0.0,
    // Rotating parts add 3–15 % to a car's inertia, up to about 50 % in a truck's lowest
    // gear: a factor outside [−0.5, 1] is not a vehicle.
    check: |d| within(d, -0.5, 1.0, "must be a finite number in [-0.5, 1]"),
    build: |d, _| Some(Arc::new(RotatingMass { factor: d })),
};

/// `truth.force_scale`.
pub(super) const FORCE_SCALE: ModelErrorEntry = ModelErrorEntry {
    name: "force calibration",
    key: "force_scale",
    unit: "",
    axis: true,
    drawn: false,
    neutral: 0.0,
    // A logged force half or one and a half times the truth's is no calibration error but
    // another signal.
    check: |s| within(s, -0.5, 0.5, "must be a finite number in [-0.5, 0.5]"),
    build: |s, _| Some(Arc::new(ForceScale { scale: s })),
};

/// `truth.rolling_speed_coefficient`.
pub(super) const ROLLING_SPEED: ModelErrorEntry = ModelErrorEntry {
    name: "speed-dependent rolling resistance",
    key: "rolling_speed_coefficient",
    unit: "s/m",
    axis: true,
    drawn: false,
    neutral: 0.0,
    // Tyres give 0.005–0.02 s/m; at 0.1 s/m the rolling resistance quadruples by 30 m/s.
    check: |c| within(c, 0.0, 0.1, "must be a finite number in [0, 0.1] s/m"),
    build: |c, _| Some(Arc::new(RollingSpeed { coefficient_s_m: c })),
};

/// `truth.air_density_ratio`.
pub(super) const AIR_DENSITY: ModelErrorEntry = ModelErrorEntry {
    name: "air density",
    key: "air_density_ratio",
    unit: "",
    axis: true,
    drawn: false,
    neutral: 1.0,
    // Air on a road: about 0.7 kg/m³ (a high pass in summer) to 1.5 kg/m³ (a cold sea
    // level), around the 1.2 kg/m³ a study assumes.
    check: |r| within(r, 0.5, 2.0, "must be a finite number in [0.5, 2]"),
    build: |r, _| Some(Arc::new(AirDensity { ratio: r })),
};

/// `truth.mass_rate`.
pub(super) const MASS_RATE: ModelErrorEntry = ModelErrorEntry {
    name: "mass drift",
    key: "mass_rate",
    unit: "kg/s",
    axis: false,
    drawn: false,
    neutral: 0.0,
    // A truck burns about 0.01 kg/s of fuel; 10 kg/s empties a tanker in minutes.
    check: |m| within(m, -10.0, 10.0, "must be a finite number within ±10 kg/s"),
    build: |m, _| Some(Arc::new(MassRate { rate_kg_s: m })),
};
