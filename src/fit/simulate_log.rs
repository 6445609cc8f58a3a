//! `simulate-log`: a synthetic log of a one-condition study, drawn as a run draws it
//! (docs/model.md#fit).

use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, RecordBatch};
use arrow::datatypes::{DataType, Field, Schema};
use arrow::error::ArrowError;

use crate::estimate::channels::{Channel, Signal};
use crate::model::Model;
use crate::model::vehicle::VehicleModel;
use crate::output::OutputError;
use crate::study::Study;

use super::FitError;

/// The header row of every log `simulate-log` writes: a file that starts with it is the
/// engine's own earlier output, which a new log may replace.
pub const LOG_HEADER: &str = "time_s,speed_m_s,force_n,grade_rad,accel_m_s2";

/// Write a synthetic log of `study` (one condition) to `path`: the noise-free cycle (or
/// realisation `r`'s own path, where its truth follows the filters' model) with
/// realisation `r`'s noise of every channel that is on (drawn as a run draws it),
/// columns `time_s`, `speed_m_s`, `force_n`, `grade_rad` and `accel_m_s2` (the model
/// acceleration plus the output noise: an accelerometer).
///
/// A file already at `path` is replaced only when it is an earlier log of the engine's (it
/// starts with [`LOG_HEADER`]) or with `force`: a measured log is never overwritten by
/// mistake. The log is written under a temporary name and renamed into place when complete.
pub fn simulate_log(study: &Study, r: u64, path: &Path, force: bool) -> Result<usize, FitError> {
    if !force {
        ensure_replaceable(path)?;
    }
    write_log(&simulated_log(study, r)?, path, true)
}

/// Write `log` (the columns of [`simulated_log`]) as [`simulate_log`] does to `path`; a
/// file there is replaced only when it is a log the engine wrote, or with `force`. Returns
/// its number of samples.
pub fn write_log(log: &[Vec<f64>; 5], path: &Path, force: bool) -> Result<usize, FitError> {
    if !force {
        ensure_replaceable(path)?;
    }
    let n = log[0].len();
    let mut csv = format!("{LOG_HEADER}\n");
    let [t, v, f, g, a] = log;
    for ((((t, v), f), g), a) in t.iter().zip(v).zip(f).zip(g).zip(a) {
        let _ = writeln!(csv, "{t},{v},{f},{g},{a}");
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(crate::output::temporary_name(&name));
    let pending = crate::output::PendingFile::new(tmp.clone(), path.to_path_buf());
    std::fs::write(&tmp, csv).map_err(|e| OutputError::io(&tmp, e))?;
    pending.commit()?;
    Ok(n)
}

/// The columns of [`simulate_log`]'s log of realisation `r` of `study`, in the order of
/// [`LOG_HEADER`], held in memory (the CSV holds each value's shortest decimal that reads
/// back as the same number, so the file and these columns agree bit for bit).
pub fn simulated_log(study: &Study, r: u64) -> Result<[Vec<f64>; 5], FitError> {
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
    // The log is the condition's noise-free cycle plus each channel's draws, or the
    // realisation's own path where its truth follows the filters' model at the vehicle's
    // mass (docs/model.md#filter-truth): a realisation with its own model errors, map or
    // mass, or an air-speed sensor, has signals this log has no place for.
    // A measured air speed has no column here, whatever the truth.
    if model.study().air_speed == crate::study::AirSpeed::Measured {
        return Err(study
            .error_at(
                "estimation.air_speed",
                "simulate-log writes the vehicle's speed; a measured air speed has no column in \
                 its log",
            )
            .into());
    }
    let cycle = match model.filter_cycle(0, study.seed(), r) {
        Some(drawn) => std::sync::Arc::new(drawn.map_err(|reason| {
            study.error_at("truth", format!("realisation {r}'s path: {reason}"))
        })?),
        None => {
            if let Some(key) = model.draws_a_world(0) {
                return Err(study
                    .error_at(
                        key,
                        "simulate-log writes the condition's cycle with its sensor noise (or a \
                         realisation's own path where it follows the filters' model at the \
                         vehicle's mass); it does not write a realisation's own gusts, \
                         calibration, map or mass, nor a measured air speed",
                    )
                    .into());
            }
            model.cycles().remove(0)
        }
    };
    let noise_levels = model.noise_levels(0);
    let n = cycle.t_s.len();
    // Each channel that is on adds its draws times its SD to the signal it moves
    // (`Channel::signal`); a signal no channel moves is logged as the truth plus zero.
    let mut noise: [Option<Vec<f64>>; Signal::LOGGED.len()] = Default::default();
    for c in Channel::ALL.into_iter().filter(|&c| noise_levels.is_on(c)) {
        let mut z = vec![0.0; n];
        model.standard_draws(study.seed(), 0, c, r, &mut z);
        let sd = noise_levels[c];
        let column = &mut noise[signal_index(c.signal())];
        match column {
            Some(sum) => sum.iter_mut().zip(&z).for_each(|(s, z)| *s += z * sd),
            None => *column = Some(z.iter().map(|z| z * sd).collect()),
        }
    }
    let truth = [
        &cycle.v_m_s,
        &cycle.f_prop_n,
        &cycle.grade_rad,
        &cycle.accel_m_s2,
    ];
    let logged = |k: usize| -> Vec<f64> {
        (0..n)
            .map(|i| truth[k][i] + noise[k].as_ref().map_or(0.0, |e| e[i]))
            .collect()
    };
    Ok([
        cycle.t_s.clone(),
        logged(0),
        logged(1),
        logged(2),
        logged(3),
    ])
}

/// The log of [`simulated_log`] as a table: the columns of [`LOG_HEADER`], float64.
pub fn log_batch(log: [Vec<f64>; 5]) -> Result<RecordBatch, ArrowError> {
    let fields: Vec<Field> = LOG_HEADER
        .split(',')
        .map(|name| Field::new(name, DataType::Float64, false))
        .collect();
    let columns: Vec<ArrayRef> = log
        .into_iter()
        .map(|c| Arc::new(Float64Array::from(c)) as ArrayRef)
        .collect();
    RecordBatch::try_new(Arc::new(Schema::new(fields)), columns)
}

/// The column of `signal` in the log after the time (the order of [`LOG_HEADER`]).
fn signal_index(signal: Signal) -> usize {
    Signal::LOGGED
        .iter()
        .position(|&s| s == signal)
        .expect("a logged signal (a measured air speed is refused above)")
}

/// Fail unless the file at `path` (if any) is a log the engine wrote: a user's file there
/// (a real measured log) is never replaced without `force`.
pub fn ensure_replaceable(path: &Path) -> Result<(), FitError> {
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return Ok(());
    };
    let ours = meta.is_file() && {
        use std::io::Read;
        let mut head = vec![0; LOG_HEADER.len() + 1];
        std::fs::File::open(path)
            .and_then(|mut f| f.read_exact(&mut head))
            .is_ok_and(|()| {
                head.strip_suffix(b"\n")
                    .or_else(|| head.strip_suffix(b"\r"))
                    .is_some_and(|h| h == LOG_HEADER.as_bytes())
            })
    };
    match ours {
        true => Ok(()),
        false => Err(OutputError::NotEngines {
            path: path.to_path_buf(),
            reason: format!(
                "is not a log simulate-log wrote (its first line is not `{LOG_HEADER}`), so it \
                 may be a measured log; choose another --out, or give --force to replace it"
            ),
        }
        .into()),
    }
}
