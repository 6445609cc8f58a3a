//! Why a drive cycle could not be simulated.

use thiserror::Error;

/// Why a drive cycle could not be simulated.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SimulationError {
    /// The speed fell to zero or below after the start: the grade is too steep for the force.
    #[error(
        "the vehicle stalls: its speed falls to {speed_m_s:.3} m/s at t = {time_s:.2} s, x = {position_m:.1} m (the grade is too steep for the propulsion force)"
    )]
    Stalled {
        /// Time of the first sample with V ≤ 0 \[s\].
        time_s: f64,
        /// Position there \[m\].
        position_m: f64,
        /// The speed there \[m/s\].
        speed_m_s: f64,
    },
    /// The vehicle passed the last point of the grade table.
    #[error(
        "the vehicle runs off the end of the terrain (x > {end_m} m) at t = {time_s:.2} s; make terrain.length longer or drive.duration shorter"
    )]
    RanOffTerrain {
        /// Time of the step that left the table \[s\].
        time_s: f64,
        /// Last grid point of the table \[m\].
        end_m: f64,
    },
    /// A grade the cycle brings itself reaches the limit after scaling.
    #[error(
        "the grade of the trace reaches {grade_rad:.3} rad at t = {time_s:.2} s after scaling; grades must stay below {limit} rad in magnitude"
    )]
    TooSteep {
        /// The grade \[rad\].
        grade_rad: f64,
        /// Where \[s\].
        time_s: f64,
        /// The limit \[rad\].
        limit: f64,
    },
    /// A coast-down run cannot be made as asked (docs/model.md#coastdown).
    #[error("coast-down run {run} (t = {time_s:.2} s): {reason}")]
    CoastRun {
        /// The run, 0-based.
        run: usize,
        /// The study key to change (e.g. `drive.time_step`).
        key: &'static str,
        /// Where \[s\].
        time_s: f64,
        /// What went wrong, and which key to change.
        reason: String,
    },
    /// A designed drive cannot hold its speed limits (docs/model.md#designed-drive).
    #[error("the designed drive cannot hold drive.{key} at t = {time_s:.2} s: {reason}")]
    SpeedLimit {
        /// Where \[s\].
        time_s: f64,
        /// The limit's key.
        key: &'static str,
        /// What happened.
        reason: String,
    },
    /// A designed drive was driven before the study's preparation designed it.
    #[error(
        "the drive mode `designed` is designed when its study is prepared; it has no cycle before"
    )]
    Undesigned,
    /// The state became NaN or infinite.
    #[error("the simulation diverged (non-finite state) at t = {time_s:.2} s")]
    NonFinite {
        /// Time at which it happened \[s\].
        time_s: f64,
    },
}

impl SimulationError {
    /// The error of an integrated drive's state at sample `i` (time `t` \[s\], position `x`
    /// \[m\], speed `v` \[m/s\]), if any: non-finite, or stalled after the start.
    pub fn check_state(i: usize, t: f64, x: f64, v: f64) -> Result<(), SimulationError> {
        if !(x.is_finite() && v.is_finite()) {
            return Err(SimulationError::NonFinite { time_s: t });
        }
        if i > 0 && v <= 0.0 {
            return Err(SimulationError::Stalled {
                time_s: t,
                position_m: x,
                speed_m_s: v,
            });
        }
        Ok(())
    }

    /// The time \[s\] at which the simulation failed.
    pub fn time_s(&self) -> f64 {
        match self {
            SimulationError::Stalled { time_s, .. }
            | SimulationError::RanOffTerrain { time_s, .. }
            | SimulationError::TooSteep { time_s, .. }
            | SimulationError::CoastRun { time_s, .. }
            | SimulationError::SpeedLimit { time_s, .. }
            | SimulationError::NonFinite { time_s } => *time_s,
            SimulationError::Undesigned => 0.0,
        }
    }
}
