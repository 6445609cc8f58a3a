//! The drive mode `speed_trace`: the vehicle follows a recorded speed trace exactly
//! (prescribed motion), at the trace's own sample times (docs/model.md#speed-trace).
//!
//! Position by the trapezoid rule from x = 0; grade from the trace (by time, times the
//! terrain scale) or from the terrain at x(t); acceleration by central differences
//! (one-sided at the ends); the net tractive force by inverse dynamics,
//! `F_i = M a_i + Cd k V_i² + Cr M g cos θ_i + M g sin θ_i`, so that without noise the
//! regression recovers θ exactly.

use std::path::PathBuf;
use std::sync::Arc;

use super::{CycleSource, DriveCycle, MAX_SAMPLES, Road, SimulationError, Truth, VehicleParams};
use crate::settings::{KeyError, Params};
use crate::tabular::read_columns;
use crate::terrain::{GradeUnit, MAX_GRADE_RAD};

/// Unit of a trace's speed column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpeedUnit {
    /// Metres per second.
    MetresPerSecond,
    /// Kilometres per hour.
    KilometresPerHour,
    /// Miles per hour (1 mph = 0.44704 m/s exactly).
    MilesPerHour,
}

impl SpeedUnit {
    /// Every unit, as study files name them.
    pub const ALL: [(&'static str, SpeedUnit); 3] = [
        ("m/s", SpeedUnit::MetresPerSecond),
        ("km/h", SpeedUnit::KilometresPerHour),
        ("mph", SpeedUnit::MilesPerHour),
    ];

    /// A speed in this unit, in m/s.
    pub fn to_m_s(self, v: f64) -> f64 {
        match self {
            SpeedUnit::MetresPerSecond => v,
            SpeedUnit::KilometresPerHour => v / 3.6,
            SpeedUnit::MilesPerHour => v * 0.44704,
        }
    }
}

/// A recorded speed trace, read and checked when the study is loaded.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedTrace {
    /// The trace file.
    pub file: PathBuf,
    /// Sample times \[s\], strictly increasing (not necessarily evenly spaced).
    pub t_s: Vec<f64>,
    /// Speeds \[m/s\], ≥ 0.
    pub v_m_s: Vec<f64>,
    /// Grades by time \[rad\] (unscaled), when the trace has a grade column.
    pub grade_rad: Option<Vec<f64>>,
}

impl SpeedTrace {
    /// The mode's keys of `[drive]`.
    pub const KEYS: &'static [&'static str] = &[
        "trace",
        "time_column",
        "speed_column",
        "speed_unit",
        "grade_column",
        "grade_unit",
    ];

    /// Read `[drive]` of mode `speed_trace`: `trace`, `time_column`, `speed_column`,
    /// `speed_unit`, and optionally `grade_column` with `grade_unit`; then the file.
    pub fn parse(p: &Params<'_>) -> Result<Arc<dyn CycleSource>, KeyError> {
        p.only(Self::KEYS)?;
        let file = p.file("trace")?;
        let time = p.string("time_column")?;
        let speed = p.string("speed_column")?;
        let speed_unit = p.named("speed_unit", &SpeedUnit::ALL)?;
        let grade = p.optional("grade_column", |p, k| p.string(k))?;
        let grade_unit = match grade {
            Some(_) => Some(GradeUnit::parse(p, "grade_unit")?),
            None if p.has("grade_unit") => {
                return Err(p.error("grade_unit", "is given without grade_column"));
            }
            None => None,
        };
        let mut wanted = vec![time, speed];
        wanted.extend(grade);
        let cols = read_columns(&file, &wanted, 3).map_err(|e| p.error("trace", e.to_string()))?;
        cols.strictly_increasing(time)
            .map_err(|e| p.error("trace", e.to_string()))?;
        if cols.len() > MAX_SAMPLES {
            return Err(p.error(
                "trace",
                format!(
                    "{}: {} rows; at most {MAX_SAMPLES} are supported",
                    file.display(),
                    cols.len()
                ),
            ));
        }
        let v = cols.get(speed);
        if let Some(i) = v.iter().position(|&s| s < 0.0) {
            return Err(p.error(
                "trace",
                format!(
                    "{}: column \"{speed}\", {}: the speed {} is negative",
                    file.display(),
                    cols.place(i),
                    v[i]
                ),
            ));
        }
        Ok(Arc::new(SpeedTrace {
            t_s: cols.get(time).to_vec(),
            v_m_s: v.iter().map(|&s| speed_unit.to_m_s(s)).collect(),
            grade_rad: grade
                .zip(grade_unit)
                .map(|(g, unit)| cols.get(g).iter().map(|&x| unit.to_rad(x)).collect()),
            file,
        }))
    }
}

/// Position \[m\] at each sample from x = 0, by the trapezoid rule on the speeds `v` at
/// times `t`.
pub fn positions(t: &[f64], v: &[f64]) -> Vec<f64> {
    let mut position = 0.0;
    (0..t.len())
        .map(|i| {
            if i > 0 {
                position += 0.5 * (t[i] - t[i - 1]) * (v[i] + v[i - 1]);
            }
            position
        })
        .collect()
}

/// dV/dt by central differences, (V_{i+1} − V_{i−1}) / (t_{i+1} − t_{i−1}), one-sided at
/// the two ends (at least two samples).
pub fn central_differences(t: &[f64], v: &[f64]) -> Vec<f64> {
    let n = t.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (v[b] - v[a]) / (t[b] - t[a])
        })
        .collect()
}

impl CycleSource for SpeedTrace {
    fn cycle(
        &self,
        vehicle: &VehicleParams,
        road: Road<'_>,
        truth: &Truth,
    ) -> Result<DriveCycle, SimulationError> {
        let (t, v) = (&self.t_s, &self.v_m_s);
        let n = t.len();
        let x = positions(t, v);
        let grade: Vec<f64> = match (&self.grade_rad, road.table) {
            (Some(g), _) => {
                let g: Vec<f64> = g.iter().map(|g| road.scale * g).collect();
                if let Some(i) = (0..n).find(|&i| g[i].is_nan() || g[i].abs() >= MAX_GRADE_RAD) {
                    return Err(SimulationError::TooSteep {
                        grade_rad: g[i],
                        time_s: t[i],
                        limit: MAX_GRADE_RAD,
                    });
                }
                g
            }
            (None, Some(table)) => (0..n)
                .map(|i| {
                    table.grade_at(x[i]).ok_or(SimulationError::RanOffTerrain {
                        time_s: t[i],
                        end_m: table.end_m(),
                    })
                })
                .collect::<Result<_, _>>()?,
            (None, None) => unreachable!("a trace without grade is validated to have a terrain"),
        };
        let accel = central_differences(t, v);
        let (m, g) = (vehicle.mass_kg, vehicle.gravity_m_s2);
        let drag = vehicle.drag_coefficient * vehicle.drag_factor_kg_m();
        let force = (0..n)
            .map(|i| {
                m * accel[i]
                    + drag * v[i] * v[i]
                    + vehicle.rolling_resistance * m * g * grade[i].cos()
                    + m * g * grade[i].sin()
            })
            .collect();
        // The force the equation needs for the trace; the truth needed more, and the log
        // records that (docs/model.md#model-errors).
        let mut cycle = DriveCycle {
            t_s: t.clone(),
            x_m: x,
            v_m_s: v.clone(),
            grade_rad: grade,
            f_prop_n: force,
            accel_m_s2: accel,
            run: vec![0; n],
            run_heading: vec![1.0],
        };
        cycle.f_prop_n = truth.logged_forces(vehicle, &cycle);
        Ok(cycle)
    }

    fn needs_terrain(&self) -> bool {
        self.grade_rad.is_none()
    }

    fn describe(&self) -> String {
        let name = self.file.file_name().unwrap_or_default().to_string_lossy();
        let span = self.t_s[self.t_s.len() - 1] - self.t_s[0];
        let grade = if self.grade_rad.is_some() {
            ", grade by time"
        } else {
            ""
        };
        format!(
            "speed trace {name} ({} samples, {span} s{grade})",
            self.t_s.len()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn central_differences_are_exact_for_a_parabola_on_uneven_steps() {
        // v = t²: the central difference on uneven steps is (t_{i+1}² − t_{i−1}²) /
        // (t_{i+1} − t_{i−1}) = t_{i+1} + t_{i−1}, exact up to rounding.
        let t = [0.0, 0.5, 1.7, 2.0, 3.1];
        let v: Vec<f64> = t.iter().map(|t| t * t).collect();
        let a = central_differences(&t, &v);
        assert_eq!(a[0], 0.5);
        for i in 1..4 {
            assert!((a[i] - (t[i + 1] + t[i - 1])).abs() < 1e-12, "{i}");
        }
        assert!((a[4] - (3.1 + 2.0)).abs() < 1e-12);
    }

    #[test]
    fn units_convert_to_si() {
        assert_eq!(SpeedUnit::KilometresPerHour.to_m_s(36.0), 10.0);
        assert_eq!(SpeedUnit::MilesPerHour.to_m_s(10.0), 4.4704);
    }
}
