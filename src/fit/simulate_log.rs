//! `simulate-log`: a synthetic log of a one-condition study, drawn as a run draws it
//! (docs/model.md#fit).

use std::fmt::Write as _;
use std::path::Path;

use crate::estimate::channels::Channel;
use crate::model::Model;
use crate::model::vehicle::VehicleModel;
use crate::output::OutputError;
use crate::study::Study;

use super::FitError;

/// Write a synthetic log of `study` (one condition) to `path`: the noise-free cycle with
/// realisation `r`'s noise of every channel that is on (drawn as a run draws it),
/// columns `time_s`, `speed_m_s`, `force_n`, `grade_rad` and `accel_m_s2` (the model
/// acceleration plus the output noise: an accelerometer).
pub fn simulate_log(study: &Study, r: u64, path: &Path) -> Result<usize, FitError> {
    let model = VehicleModel::new(study)?;
    if model.condition_count() != 1 {
        return Err(study
            .error_at(
                "terrain.scales",
                format!(
                    "simulate-log needs a study with one condition; this one has {}",
                    model.condition_count()
                ),
            )
            .into());
    }
    // The log is the condition's noise-free cycle plus each channel's draws: a realisation
    // with its own truth or map, or an air-speed sensor, has signals this log has no place
    // for.
    if let Some(key) = model.draws_a_world(0) {
        return Err(study
            .error_at(
                key,
                "simulate-log writes the condition's cycle with its sensor noise; it does not \
                 write a realisation's own gusts, calibration or map, nor a measured air speed",
            )
            .into());
    }
    let cycle = model.cycles().remove(0);
    let noise = model.noise_levels(0);
    let n = cycle.t_s.len();
    let draws = |c: Channel| -> Vec<f64> {
        let mut out = vec![0.0; n];
        if noise.is_on(c) {
            model.standard_draws(study.seed(), 0, c, r, &mut out);
            out.iter_mut().for_each(|z| *z *= noise[c]);
        }
        out
    };
    let (ev, ey, eg, ef) = (
        draws(Channel::Velocity),
        draws(Channel::Output),
        draws(Channel::Grade),
        draws(Channel::Force),
    );
    let mut csv = String::from("time_s,speed_m_s,force_n,grade_rad,accel_m_s2\n");
    for i in 0..n {
        let _ = writeln!(
            csv,
            "{},{},{},{},{}",
            cycle.t_s[i],
            cycle.v_m_s[i] + ev[i],
            cycle.f_prop_n[i] + ef[i],
            cycle.grade_rad[i] + eg[i],
            cycle.accel_m_s2[i] + ey[i]
        );
    }
    std::fs::write(path, csv).map_err(|e| OutputError::io(path, e))?;
    Ok(n)
}
