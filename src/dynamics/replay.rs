//! The drive mode `replay`: a cycle given sample by sample — time, speed, propulsion force,
//! grade and acceleration, all in SI units — taken as the truth without simulating or
//! differentiating anything (docs/model.md#replay), optionally with the samples the
//! regression may use. `fit`'s bootstrap replays the fitted vehicle on a measured log with
//! it (a cycle built in memory); any recorded cycle whose signals are consistent can be
//! replayed.

use std::sync::Arc;

use super::{
    CycleSource, DriveCycle, MAX_SAMPLES, Road, SimulationError, Truth, VehicleParams, positions,
};
use crate::settings::{KeyError, Params};
use crate::tabular::read_columns;

/// A cycle read from a file: `t` \[s\], `v` \[m/s\], `f_prop` \[N\], `grade` \[rad\], `accel`
/// \[m/s²\].
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    /// What the cycle is, for tables and figures: the file it was read from, or what made
    /// it.
    pub source: String,
    /// The cycle (its position integrated from the speed by the trapezoid rule).
    pub cycle: DriveCycle,
    /// The samples the regression may use (`used_column`; `None`: all of them).
    pub used: Option<Vec<bool>>,
}

impl Replay {
    /// The mode's keys of `[drive]`.
    pub const KEYS: &'static [&'static str] = &["file", "used_column"];

    /// Read `[drive]` of mode `replay`: `file`, whose columns are `t`, `v`, `f_prop`,
    /// `grade` and `accel` (SI units), and optionally `used_column`, the name of a column
    /// of 1 (the regression may use the sample) and 0 (it may not).
    pub fn parse(p: &Params<'_>) -> Result<Arc<dyn CycleSource>, KeyError> {
        p.only(Self::KEYS)?;
        let file = p.file("file")?;
        let used_column = p.optional("used_column", |p, k| p.string(k))?;
        let mut names = vec!["t", "v", "f_prop", "grade", "accel"];
        names.extend(used_column);
        let cols = read_columns(&file, &names, 3).map_err(|e| p.error("file", e.to_string()))?;
        cols.strictly_increasing("t")
            .map_err(|e| p.error("file", e.to_string()))?;
        if cols.len() > MAX_SAMPLES {
            return Err(p.error(
                "file",
                format!(
                    "{}: at most {MAX_SAMPLES} rows are supported",
                    file.display()
                ),
            ));
        }
        let (t, v) = (cols.get("t").to_vec(), cols.get("v").to_vec());
        let cycle = DriveCycle {
            x_m: positions(&t, &v),
            t_s: t,
            v_m_s: v,
            grade_rad: cols.get("grade").to_vec(),
            f_prop_n: cols.get("f_prop").to_vec(),
            accel_m_s2: cols.get("accel").to_vec(),
            run: vec![0; cols.len()],
            run_heading: vec![1.0],
        };
        let used = match used_column {
            Some(name) => {
                let values = cols.get(name);
                if let Some(i) = values.iter().position(|&u| u != 0.0 && u != 1.0) {
                    return Err(p.error(
                        "used_column",
                        format!(
                            "{}: column \"{name}\", {}: must be 0 or 1, got {}",
                            file.display(),
                            cols.place(i),
                            values[i]
                        ),
                    ));
                }
                Some(values.iter().map(|&u| u == 1.0).collect())
            }
            None => None,
        };
        Ok(Arc::new(Replay {
            source: file.display().to_string(),
            cycle,
            used,
        }))
    }
}

impl CycleSource for Replay {
    fn cycle(
        &self,
        vehicle: &VehicleParams,
        _road: Road<'_>,
        truth: &Truth,
    ) -> Result<DriveCycle, SimulationError> {
        // The replayed cycle obeys the equation; the truth needed its force plus D, and the
        // log records that (docs/model.md#model-errors).
        let mut cycle = self.cycle.clone();
        cycle.f_prop_n = truth.logged_forces(vehicle, &self.cycle);
        Ok(cycle)
    }

    fn describe(&self) -> String {
        format!("replay of {}", self.source)
    }

    fn needs_terrain(&self) -> bool {
        false
    }

    fn used(&self) -> Option<&[bool]> {
        self.used.as_deref()
    }
}
