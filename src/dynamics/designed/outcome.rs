//! A drive once designed: its torque at every sample and what the search found.

use std::sync::Arc;

use super::super::{CycleSource, DriveCycle, Road, SimulationError, Truth, VehicleParams};
use super::DriveDesign;
use super::integrate;
use crate::terrain::GradeTable;

/// What the search found, for the report and the trace's footer.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignSummary {
    /// The criterion's name (`d`, `a` or a parameter).
    pub criterion: String,
    /// The estimator whose bound it is, and the bound.
    pub estimator: String,
    /// The bound the criterion is of (`eiv_sandwich`, …).
    pub bound: &'static str,
    /// Each candidate reported: its name (`designed`, `best square wave (… s)`, `study's
    /// own drive`), its criterion, its bound's relative SEs per parameter, and the fraction
    /// of its steps the governor set.
    pub candidates: Vec<Candidate>,
    /// Number of criterion evaluations of the search.
    pub evaluations: u64,
}

/// One drive of a [`DesignSummary`].
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// What it is.
    pub name: String,
    /// Its criterion (lower is better).
    pub criterion: f64,
    /// Its bound's SE over |θ| per parameter (NaN for a known one).
    pub relative_se: [f64; 3],
    /// The fraction of its steps at which the governor set the torque.
    pub governed_fraction: f64,
}

/// A drive designed by `numeric::profile_search`: the torque it applies at every sample, driven under
/// each truth without the governor (the nominal truth's drive stays within the limits by
/// construction).
#[derive(Debug, Clone)]
pub struct DesignedDrive {
    /// Its keys.
    pub design: DriveDesign,
    /// The torque applied from each sample to the next \[N·m\].
    pub torque_n_m: Arc<Vec<f64>>,
    /// The segment levels the search chose \[N·m\].
    pub levels: Vec<f64>,
    /// What the search found.
    pub summary: DesignSummary,
}

impl DesignedDrive {
    /// The drive of the applied torque under `truth`.
    pub fn drive(
        &self,
        vehicle: &VehicleParams,
        table: &GradeTable,
        truth: &Truth,
    ) -> Result<DriveCycle, SimulationError> {
        let torque = &self.torque_n_m;
        integrate(vehicle, table, truth, &self.design, |i, _, _, step| {
            Ok((torque[i], step.map(|s| s(torque[i])).transpose()?))
        })
        .map(|d| d.cycle)
    }
}

impl CycleSource for DesignedDrive {
    /// The cycle is integrated into a spare ([`DriveCycle::one_run`]).
    fn reuses_spares(&self) -> bool {
        true
    }

    fn cycle(
        &self,
        vehicle: &VehicleParams,
        road: Road<'_>,
        truth: &Truth,
    ) -> Result<DriveCycle, SimulationError> {
        let table = road
            .table
            .expect("the designed mode is validated to have a terrain profile");
        self.drive(vehicle, table, truth)
    }

    fn describe(&self) -> String {
        format!(
            "designed torque {}–{} N·m, speed {}–{} m/s, {} s (criterion {})",
            self.design.torque_min_n_m,
            self.design.torque_max_n_m,
            self.design.speed_min_m_s,
            self.design.speed_max_m_s,
            self.design.duration_s,
            self.design.criterion
        )
    }

    fn duration_step(&self) -> Option<f64> {
        Some(self.design.time_step_s)
    }

    fn needs_drivetrain(&self) -> bool {
        true
    }

    fn designed(&self) -> Option<&DesignedDrive> {
        Some(self)
    }
}
