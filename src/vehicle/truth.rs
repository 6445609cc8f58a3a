//! Model errors: how the simulated vehicle may differ from the regression's equation
//! (docs/model.md#model-errors).
//!
//! The estimators always fit the thesis's equation, `M dV/dt = F − ½ρ Cd A V² − Cr M g cos θ
//! − M g sin θ`. A model error is a force the truth has and the equation leaves out: wind,
//! the inertia of rotating parts, a miscalibrated force signal, rolling resistance that grows
//! with speed, another air density, a mass that drifts. Each is one [`ModelError`] (what it
//! adds to the truth's dynamics, whether it is drawn per realisation) and one entry of
//! [`MODEL_ERRORS`] (its keys of `[truth]` and how it reads them). The kind is prepared,
//! not yet wired: the registry is empty, a study has no `[truth]` table, and the kernel and
//! the first-order bias do not read it yet; the equations below are what they will do.
//!
//! One quantity serves every use. With the omitted force D(t) of an entry, the truth is
//! `M dV/dt = F − D − (the equation's forces)`:
//! - a drive mode that integrates the motion (`torque`) integrates it under F − D;
//! - a drive mode that prescribes the motion (`speed_trace`, `replay`) logs the force the
//!   truth needed, F + D for the equation's F;
//! - to first order the estimate moves by Δθ ≈ −θ₁ (XᵀX)⁻¹ Xᵀ D (the regression's normal
//!   equations applied to the output error −θ₁ D), its `bias_model`.

use std::fmt;
use std::sync::Arc;

use super::VehicleParams;
use crate::settings::{KeyError, Params};

/// The state of the truth at one sample, as a model error sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    /// Time since the start of the cycle \[s\].
    pub time_s: f64,
    /// Distance travelled \[m\].
    pub distance_m: f64,
    /// Speed V \[m/s\].
    pub speed_m_s: f64,
    /// Acceleration dV/dt \[m/s²\].
    pub acceleration_m_s2: f64,
    /// Road grade θ \[rad\].
    pub grade_rad: f64,
    /// Propulsion force F \[N\] (the truth's, before any calibration error of the log).
    pub force_n: f64,
}

/// The random numbers a model error draws in a realisation, from its own stream (so that
/// switching it on leaves every other draw as it was).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Draws {
    /// None: the entry is the same in every realisation (set per condition).
    Steady,
    /// This many standard normal numbers once per realisation (a calibration error).
    PerRealisation(usize),
    /// One standard normal number per sample (a process in time, such as gusts).
    PerSample,
}

/// One way the truth differs from the regression's equation.
pub trait ModelError: Send + Sync + fmt::Debug {
    /// The force \[N\] the equation leaves out at `sample`, opposing the motion when
    /// positive, for the vehicle `vehicle`, with this realisation's `draws` (empty for a
    /// [`Draws::Steady`] entry; the realisation's numbers for the others, and for
    /// [`Draws::PerSample`] the sample's own number first).
    fn omitted_force(&self, vehicle: &VehicleParams, sample: &TruthSample, draws: &[f64]) -> f64;

    /// Which random numbers it draws per realisation.
    fn draws(&self) -> Draws {
        Draws::Steady
    }

    /// Whether it changes the motion of a drive mode that integrates it (`torque`) from one
    /// realisation to the next: then each realisation's motion is integrated again.
    fn moves_the_vehicle(&self) -> bool {
        !matches!(self.draws(), Draws::Steady)
    }
}

/// How an entry reads its keys of `[truth]`: `None` when they are absent (the truth is the
/// equation's).
pub type ParseModelError = fn(&Params<'_>) -> Result<Option<Arc<dyn ModelError>>, KeyError>;

/// A model error as study files name it.
#[derive(Debug, Clone, Copy)]
pub struct ModelErrorEntry {
    /// Its name in messages and docs (e.g. "steady wind").
    pub name: &'static str,
    /// Its keys of `[truth]`.
    pub keys: &'static [&'static str],
    /// Read its keys of `[truth]`.
    pub parse: ParseModelError,
}

/// Every model error a study can name. (Empty: the entries come with `[truth]`.)
pub static MODEL_ERRORS: [ModelErrorEntry; 0] = [];
