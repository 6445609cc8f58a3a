//! The drive mode `replay`: a cycle given sample by sample — time, speed, propulsion force,
//! grade and acceleration, all in SI units — taken as the truth without simulating or
//! differentiating anything (docs/model.md#replay). `fit`'s bootstrap replays the fitted
//! vehicle on a measured log with it; any recorded cycle whose signals are consistent can
//! be replayed.

use std::path::PathBuf;
use std::sync::Arc;

use super::{
    CycleSource, DriveCycle, MAX_SAMPLES, Road, SimulationError, VehicleParams, positions,
};
use crate::settings::{KeyError, Params};
use crate::tabular::read_columns;

/// A cycle read from a file: `t` \[s\], `v` \[m/s\], `f_prop` \[N\], `grade` \[rad\], `accel`
/// \[m/s²\].
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    /// The file.
    pub file: PathBuf,
    /// The cycle (its position integrated from the speed by the trapezoid rule).
    pub cycle: DriveCycle,
}

impl Replay {
    /// The mode's keys of `[drive]`.
    pub const KEYS: &'static [&'static str] = &["file"];

    /// Read `[drive]` of mode `replay`: `file`, whose columns are `t`, `v`, `f_prop`,
    /// `grade` and `accel` (SI units).
    pub fn parse(p: &Params<'_>) -> Result<Arc<dyn CycleSource>, KeyError> {
        p.only(Self::KEYS)?;
        let file = p.file("file")?;
        let names = ["t", "v", "f_prop", "grade", "accel"];
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
        };
        Ok(Arc::new(Replay { file, cycle }))
    }
}

impl CycleSource for Replay {
    fn cycle(
        &self,
        _vehicle: &VehicleParams,
        _road: Road<'_>,
    ) -> Result<DriveCycle, SimulationError> {
        Ok(self.cycle.clone())
    }

    fn describe(&self) -> String {
        format!("replay of {}", self.file.display())
    }

    fn needs_terrain(&self) -> bool {
        false
    }
}
