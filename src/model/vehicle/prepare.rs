//! The drive cycles of a vehicle study, one per terrain scale and truth (the steady model
//! errors of `[truth]`), and the regression of each (scale, truth, prefix: a duration or a
//! number of coast-down runs): the rows a condition's realisations are drawn on.

use std::sync::Arc;

use rayon::prelude::*;

use super::ErrorAt;
use crate::dynamics::truth::sample_of;
use crate::dynamics::{DriveCycle, Prefix, Road, SimulationError, Truth};
use crate::estimate::channels::Acceleration;
use crate::estimate::filters::GradeSource;
use crate::estimate::regression::Regression;
use crate::study::{AirSpeed, LevelAxis, StudyError, VehicleStudy};
use crate::terrain::{GradeTable, MAX_GRADE_RAD, mean_square};

/// The drive cycle of one terrain scale and truth.
#[derive(Debug)]
pub(super) struct ScaleCycle {
    /// Index into `terrain.scales`.
    pub scale_index: usize,
    /// Index of the truth ([`TruthAxes::index`](crate::study::TruthAxes::index)).
    pub truth_index: usize,
    /// The noise-free cycle (every sample, used or not), with the truth's steady entries.
    pub cycle: Arc<DriveCycle>,
    /// The grade table of its scale (`None` without a terrain profile).
    pub table: Option<Arc<GradeTable>>,
    /// ς over the terrain table \[rad²\] (NaN without a terrain profile).
    pub terrain_ms_grid: f64,
}

/// The regression rows of one (scale, truth, prefix).
#[derive(Debug)]
pub(super) struct Segment {
    /// The regression of those samples per acceleration source, and within it one per
    /// grade bias (the measured grade θ + b).
    pub regressions: Vec<Vec<Arc<Regression>>>,
    /// The condition metrics: ς over the table and over the used samples.
    pub metrics: Vec<f64>,
    /// The duration \[s\]: the axis value, or the length of the prefix's samples
    /// ([`Prefix::length_s`]).
    pub duration_s: f64,
}

/// One cycle per (scale, truth), scale-major (index `s · truths + t`), simulated in
/// parallel (each is independent). A scale at which the grade is too steep, the vehicle
/// stalls or runs off the terrain is an error naming it.
pub(super) fn scale_cycles(
    vs: &VehicleStudy,
    error_at: &ErrorAt<'_>,
) -> Result<Vec<ScaleCycle>, StudyError> {
    let truths = vs.truth.combinations();
    // The grade table of each scale, built once for all its truths.
    let tables: Vec<Option<Arc<GradeTable>>> = vs
        .scales
        .par_iter()
        .map(|&scale| vs.terrain.as_ref().map(|t| Arc::new(t.grade_table(scale))))
        .collect();
    (0..vs.scales.len() * truths)
        .into_par_iter()
        .map(|k| {
            let (i, truth_index) = (k / truths, k % truths);
            debug_assert_eq!(k, cycle_index(vs, i, truth_index));
            let scale = vs.scales[i];
            let truth = vs.truth.truth(truth_index).steady();
            let key = format!("terrain.scales[{i}]");
            let table = tables[i].as_deref();
            if let (Some(t), Some(table)) = (&vs.terrain, table)
                && let Some((grade, x)) = table.steepest_beyond_limit()
            {
                return Err(error_at(
                    &key,
                    format!(
                        "at scale {scale} the steepest grade of the terrain is {grade:.3} rad at x = {x} m; \
                         grades must stay below {MAX_GRADE_RAD} rad in magnitude (scaling applies \
                         to the {})",
                        t.scale_applies_to.name()
                    ),
                ));
            }
            let road = Road { table, scale };
            let with_truth = match truth.is_empty() {
                true => String::new(),
                false => format!(" with the truth's values {:?}", vs.truth.values(truth_index)),
            };
            let cycle = vs
                .drive
                .cycle(&vs.vehicle, road, &truth)
                .map_err(|e| {
                    // A mass drift that has taken away most of the mass by then is the
                    // cause, whatever the integration met; a coast-down run names the key to
                    // change; the rest blame the scale.
                    if let Some(reason) = drifted_away(&truth, &vs.vehicle, e.time_s()) {
                        return error_at(
                            "truth.mass_rate",
                            format!("at scale {scale}{with_truth}: {reason} ({e})"),
                        );
                    }
                    let key = match &e {
                        SimulationError::CoastRun { key, .. } => key.to_string(),
                        _ => key.clone(),
                    };
                    error_at(&key, format!("at scale {scale}{with_truth}: {e}"))
                })?;
            // A drifting mass must stay positive over the cycle (it is linear in time, so
            // its ends tell).
            if let Some(last) = cycle.t_s.len().checked_sub(1) {
                for j in [0, last] {
                    let inertia = truth.inertia_kg(&vs.vehicle, &sample_of(&cycle, j));
                    if inertia.is_nan() || inertia <= 0.0 {
                        return Err(error_at(
                            "truth.mass_rate",
                            format!(
                                "at scale {scale}{with_truth} the truth's mass would be {inertia} kg \
                                 at t = {} s of the cycle; it must stay positive",
                                cycle.t_s[j] - cycle.t_s[0]
                            ),
                        ));
                    }
                }
            }
            Ok(ScaleCycle {
                scale_index: i,
                truth_index,
                cycle: Arc::new(cycle),
                table: tables[i].clone(),
                terrain_ms_grid: table.map_or(f64::NAN, |t| t.mean_square()),
            })
        })
        .collect::<Vec<_>>()
        // The first error in study order, whatever the thread count.
        .into_iter()
        .collect()
}

/// Why the simulation of `truth` failed at `time_s` because its mass drifted away: at that
/// time the truth's inertia has fallen below half of its start (or to zero), so its motion
/// is no longer a vehicle's. `None` when the mass is still there.
fn drifted_away(
    truth: &Truth,
    vehicle: &crate::dynamics::VehicleParams,
    time_s: f64,
) -> Option<String> {
    let at = |t: f64| {
        let sample = crate::dynamics::truth::TruthSample {
            time_s: t,
            distance_m: 0.0,
            speed_m_s: 0.0,
            grade_rad: 0.0,
            heading: 1.0,
            run: 0,
            run_time_s: t,
        };
        truth.inertia_kg(vehicle, &sample)
    };
    let (start, then) = (at(0.0), at(time_s));
    // (NaN, where the drift has made the state meaningless, counts as drifted away)
    let kept = then > 0.5 * start;
    (!kept).then(|| {
        format!(
            "the truth's mass drifts from {start:.1} kg to {then:.1} kg by t = {time_s:.2} s, \
             where the simulation failed; make |truth.mass_rate| smaller or the drive shorter \
             so that the mass stays positive"
        )
    })
}

/// The index in [`scale_cycles`] of the cycle of scale `scale_index` and truth
/// `truth_index`: scale-major.
pub(super) fn cycle_index(vs: &VehicleStudy, scale_index: usize, truth_index: usize) -> usize {
    scale_index * vs.truth.combinations() + truth_index
}

/// The speeds the drag regressor reads at the samples of `cycle` when they are not its
/// speeds: with a measured air speed, V plus the wind of `truth` (`None`: the speeds).
pub(super) fn measured_speeds(
    vs: &VehicleStudy,
    truth: &Truth,
    cycle: &DriveCycle,
) -> Option<Vec<f64>> {
    (vs.air_speed == AirSpeed::Measured).then(|| truth.air_speeds(cycle))
}

/// Which samples of `cycle` a regression with acceleration `source` uses: those the row
/// selection keeps within `prefix`; a differentiated acceleration also leaves out the first
/// and last sample of every run, which have no neighbour of their run on one side (a speed
/// is differenced within a run, never across two). So a prefix's samples are those of the
/// whole cycle with t − t₀ ≤ the duration, or with run < the number of runs: what
/// cycles.parquet records (README, "Output files").
pub(super) fn used_samples(
    cycle: &DriveCycle,
    vs: &VehicleStudy,
    prefix: Prefix,
    source: Acceleration,
) -> Vec<bool> {
    let mut used = cycle.used(&vs.selection, prefix);
    // A cycle that brings its own selection (a replayed log's used rows) narrows it.
    if let Some(own) = vs.drive.used() {
        used.iter_mut().zip(own).for_each(|(u, &o)| *u &= o);
    }
    if source == Acceleration::Differentiated {
        for (i, u) in used.iter_mut().enumerate() {
            *u &= !cycle.at_run_edge(i);
        }
    }
    used
}

/// The prefixes of a study's cycles its conditions use, in the order of the `duration` and
/// `runs` axes (at most one of them has more than one level): `drive.durations`, or a
/// coast-down's `drive.runs`, or the whole cycle.
pub(super) fn prefixes(vs: &VehicleStudy) -> Vec<Prefix> {
    match (&vs.durations, vs.drive.runs()) {
        (Some(d), _) => d.iter().map(|&d| Prefix::Duration(d)).collect(),
        (None, Some(runs)) => runs.iter().map(|&k| Prefix::Runs(k)).collect(),
        (None, None) => vec![Prefix::Whole],
    }
}

/// The segment of every (cycle, prefix), cycle-major: index `k · prefixes + d` for cycle
/// `k` of [`scale_cycles`] and prefix `d` of [`prefixes`]. A duration longer than the
/// cycle, or a selection that leaves fewer than 3 rows, is an error naming the key.
pub(super) fn segments(
    vs: &VehicleStudy,
    cycles: &[ScaleCycle],
    error_at: &ErrorAt<'_>,
) -> Result<Vec<Segment>, StudyError> {
    let per_scale = cycles
        .par_iter()
        .map(|cycle| scale_segments(vs, cycle.scale_index, cycle, error_at))
        .collect::<Vec<_>>()
        // The first error in study order, whatever the thread count.
        .into_iter()
        .collect::<Result<Vec<_>, _>>()?;
    Ok(per_scale.into_iter().flatten().collect())
}

/// The segments of scale `s`, one per prefix in study order. The regressions of the
/// longest prefix are built once; a shorter one's rows are their first rows (t − t₀ ≤ T,
/// or the first k runs; docs/model.md#row-selection), so its regressions are prefixes
/// sharing their columns, and memory does not grow with the number of durations or runs.
fn scale_segments(
    vs: &VehicleStudy,
    s: usize,
    scale: &ScaleCycle,
    error_at: &ErrorAt<'_>,
) -> Result<Vec<Segment>, StudyError> {
    let cycle = &scale.cycle;
    // The cycle as the regression reads it (samples are selected on the true one).
    let truth = vs.truth.truth(scale.truth_index).steady();
    let measured = match measured_speeds(vs, &truth, cycle) {
        None => cycle.clone(),
        Some(air) => Arc::new(DriveCycle {
            v_m_s: air,
            ..(**cycle).clone()
        }),
    };
    let length = cycle.length_s();
    let prefixes = prefixes(vs);
    let n = prefixes.len();
    // used[d][a]: the samples of prefix d with acceleration source a, checked in study
    // order.
    let mut used: Vec<Vec<Vec<bool>>> = Vec::with_capacity(n);
    for (d, &prefix) in prefixes.iter().enumerate() {
        let key = match prefix {
            Prefix::Duration(_) => format!("drive.durations[{d}]"),
            Prefix::Runs(_) => format!("drive.runs[{d}]"),
            Prefix::Whole => "drive.min_speed".to_string(),
        };
        if let Prefix::Duration(t) = prefix
            && t > length
        {
            return Err(error_at(
                &key,
                format!("is {t} s but the drive cycle lasts {length} s"),
            ));
        }
        let mut per_source = Vec::new();
        for &source in &vs.acceleration {
            let u = used_samples(cycle, vs, prefix, source);
            let rows = u.iter().filter(|u| **u).count();
            if rows < 3 {
                return Err(error_at(
                    &key,
                    format!(
                        "leaves {rows} samples of the cycle at scale {} for the regression \
                         (min_speed, exclude_braking and durations or runs select them{}); at least 3 are needed",
                        vs.scales[s],
                        if source == Acceleration::Differentiated {
                            "; a differentiated acceleration also leaves out the first and last sample of each run"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            per_source.push(u);
        }
        used.push(per_source);
    }
    let longest = (0..n)
        .max_by(|&a, &b| {
            let length_of = |d: usize| prefixes[d].length_s(cycle);
            length_of(a).total_cmp(&length_of(b))
        })
        .expect("at least one prefix");
    let full: Vec<Vec<Arc<Regression>>> = vs
        .acceleration
        .iter()
        .zip(&used[longest])
        .map(|(&source, u)| regressions(vs, &measured, u, source))
        .collect();
    Ok((0..n)
        .map(|d| {
            let regressions = vs
                .acceleration
                .iter()
                .enumerate()
                .map(|(a, &source)| {
                    let (mine, theirs) = (&used[d][a], &used[longest][a]);
                    if !is_prefix(mine, theirs) {
                        // Times out of order (a trace): built on their own.
                        return regressions(vs, &measured, mine, source);
                    }
                    let rows = mine.iter().filter(|u| **u).count();
                    full[a]
                        .iter()
                        .map(|r| match rows == r.len() {
                            true => r.clone(),
                            false => Arc::new(r.prefix(rows)),
                        })
                        .collect()
                })
                .collect();
            let selection = used_samples(cycle, vs, prefixes[d], Acceleration::Model);
            let grades: Vec<f64> = cycle
                .grade_rad
                .iter()
                .zip(&selection)
                .filter(|(_, u)| **u)
                .map(|(g, _)| *g)
                .collect();
            Segment {
                regressions,
                metrics: vec![scale.terrain_ms_grid, mean_square(&grades)],
                duration_s: prefixes[d].length_s(cycle),
            }
        })
        .collect())
}

/// The regression of the samples `used` of `cycle` with acceleration `source`, one per
/// grade bias (the measured grade θ + b).
pub(super) fn regressions(
    vs: &VehicleStudy,
    cycle: &DriveCycle,
    used: &[bool],
    source: Acceleration,
) -> Vec<Arc<Regression>> {
    let selected = cycle.select(used);
    vs.levels[LevelAxis::GradeBias]
        .iter()
        .map(|&b| {
            Arc::new(match source {
                Acceleration::Differentiated => {
                    Regression::differentiated(cycle, used, b, &vs.vehicle)
                }
                Acceleration::Model if b == 0.0 => {
                    read_grade(vs, Regression::new(&selected, &vs.vehicle))
                }
                Acceleration::Model => {
                    let mut measured = selected.clone();
                    measured.grade_rad.iter_mut().for_each(|g| *g += b);
                    Regression::new(&measured, &vs.vehicle)
                }
            })
        })
        .collect()
}

/// `reg` as the study's estimators read it under a measured acceleration: without the
/// grade's column where `estimation.grade = "none"` ([`Regression::without_grade`]).
pub(super) fn read_grade(vs: &VehicleStudy, reg: Regression) -> Regression {
    match vs.settings.grade {
        GradeSource::Measured => reg,
        GradeSource::None => reg.without_grade(),
    }
}

/// Whether the samples marked in `short` are the first of those marked in `long`.
fn is_prefix(short: &[bool], long: &[bool]) -> bool {
    let mut remaining = short.iter().filter(|u| **u).count();
    for (s, l) in short.iter().zip(long) {
        if remaining == 0 {
            return true;
        }
        if s != l {
            return false;
        }
        remaining -= usize::from(*s);
    }
    remaining == 0
}
