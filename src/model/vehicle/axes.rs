//! The condition axes of the vehicle model, one variant of [`VehicleAxis`] each: its column,
//! its levels in the study, and what it sets in a [`Point`] of the condition grid. The
//! conditions are the product of [`axes`] in order (the last varies fastest); the layout's
//! axis columns and every condition's axis values are derived from the same list. The axes
//! of plain levels are the study's registry ([`LevelAxis`]): a new one is an entry there.

use super::super::{Axis, AxisValue};
use crate::dynamics::truth::{MODEL_ERROR_COUNT, MODEL_ERRORS};
use crate::estimate::channels::{Channel, NoiseLevels};
use crate::study::{LEVEL_AXIS_COUNT, LevelAxis, VehicleStudy};

/// A condition axis of the vehicle model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VehicleAxis {
    /// The terrain scale factor (`terrain.scales`): each level is its own drive cycle.
    Scale,
    /// The first T seconds of the cycle (`drive.durations`; one level, the whole cycle,
    /// without it).
    Duration,
    /// The first k runs of a coast-down (`drive.runs`; one level, 1, in every other drive
    /// mode: its cycle is one run).
    Runs,
    /// The standard deviation of one noise channel (`noise.<channel>_sd`; a channel whose
    /// level a level axis sets has none: [`Channel::own_axis`]).
    Noise(Channel),
    /// A level axis of the study's registry (`noise.<key>`).
    Level(LevelAxis),
    /// The source of the acceleration in the output (`estimation.acceleration`).
    Acceleration,
    /// The value of model error `i` of [`MODEL_ERRORS`] (`truth.<key>`, an axis entry).
    Truth(usize),
    /// The filters' grade walk (`estimation.grade_walk`): an axis only of a study that lists
    /// a filter ([`axes_of`]).
    GradeWalk,
}

/// Every axis, outermost first. The acceleration's source nests inside the grade bias and
/// outside the later level axes (the conditions' order of the files written before the
/// level axes were a registry); a new level axis comes after the others.
pub fn axes() -> impl Iterator<Item = VehicleAxis> {
    let (outer, inner) = LevelAxis::ALL.split_at(LevelAxis::GradeBias as usize + 1);
    [VehicleAxis::Scale, VehicleAxis::Duration, VehicleAxis::Runs]
        .into_iter()
        .chain(
            Channel::ALL
                .into_iter()
                .filter(|c| c.own_axis())
                .map(VehicleAxis::Noise),
        )
        .chain(outer.iter().copied().map(VehicleAxis::Level))
        .chain([VehicleAxis::Acceleration])
        .chain(inner.iter().copied().map(VehicleAxis::Level))
        .chain(
            (0..MODEL_ERROR_COUNT)
                .filter(|&i| MODEL_ERRORS[i].axis)
                .map(VehicleAxis::Truth),
        )
        .chain([VehicleAxis::GradeWalk])
}

/// The axes of `study`: [`axes`], the filters' grade walk only where a filter is listed (so
/// that a study without one has the columns it had before the filters).
pub fn axes_of(study: &VehicleStudy) -> impl Iterator<Item = VehicleAxis> + '_ {
    let filters = study.estimators.iter().any(|e| e.estimates_grade());
    axes().filter(move |&a| filters || a != VehicleAxis::GradeWalk)
}

/// One condition: the level of every axis.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Point {
    /// Index into `terrain.scales`; conditions with the same index share a drive cycle.
    pub scale_index: usize,
    /// Index into `drive.durations` (0 without it).
    pub duration_index: usize,
    /// Index into a coast-down's `drive.runs` (0 in other drive modes).
    pub runs_index: usize,
    /// The noise levels.
    pub noise: NoiseLevels,
    /// Per level axis, the index of its level in the study ([`Point::level`]).
    pub level_indices: [usize; LEVEL_AXIS_COUNT],
    /// Per entry of [`MODEL_ERRORS`], the index of its value in `[truth]`.
    pub truth_levels: [usize; MODEL_ERROR_COUNT],
    /// Index into the filters' `estimation.grade_walk` (0 without the axis).
    pub grade_walk_index: usize,
}

impl Point {
    /// The index of the point's prefix of its cycle among the study's (the `duration` and
    /// `runs` axes, in their order; at most one has more than one level).
    pub fn prefix_index(&self, study: &VehicleStudy) -> usize {
        self.duration_index * VehicleAxis::Runs.len(study) + self.runs_index
    }

    /// The index of the point's level on `axis` among the study's.
    pub fn level_index(&self, axis: LevelAxis) -> usize {
        self.level_indices[axis as usize]
    }

    /// The point's level on `axis`.
    pub fn level(&self, study: &VehicleStudy, axis: LevelAxis) -> f64 {
        study.levels[axis][self.level_index(axis)]
    }

    /// The index of the point's truth among the study's ([`TruthAxes::index`]).
    ///
    /// [`TruthAxes::index`]: crate::study::TruthAxes::index
    pub fn truth_index(&self, study: &VehicleStudy) -> usize {
        study.truth.index(&self.truth_levels)
    }
}

impl VehicleAxis {
    /// The axis column.
    pub fn column(self) -> Axis {
        match self {
            VehicleAxis::Scale => Axis::number("scale", ""),
            VehicleAxis::Duration => Axis::number("duration", "s"),
            VehicleAxis::Runs => Axis::number("runs", ""),
            VehicleAxis::Noise(c) => Axis::number(c.key(), c.unit()),
            VehicleAxis::Level(a) => Axis::number(a.key(), a.unit()),
            VehicleAxis::Acceleration => Axis::text("acceleration"),
            VehicleAxis::Truth(i) => Axis::number(MODEL_ERRORS[i].key, MODEL_ERRORS[i].unit),
            VehicleAxis::GradeWalk => Axis::number("grade_walk", "rad²/m"),
        }
    }

    /// Number of levels in the study.
    fn len(self, study: &VehicleStudy) -> usize {
        match self {
            VehicleAxis::Scale => study.scales.len(),
            VehicleAxis::Duration => study.durations.as_ref().map_or(1, Vec::len),
            VehicleAxis::Runs => study.drive.runs().map_or(1, <[usize]>::len),
            VehicleAxis::Noise(c) => study.noise.levels(c).len(),
            VehicleAxis::Level(a) => study.levels[a].len(),
            VehicleAxis::Acceleration => study.acceleration.len(),
            VehicleAxis::Truth(i) => study.truth.levels(i).len(),
            VehicleAxis::GradeWalk => study.grade_walks.len(),
        }
    }

    /// Set level `i` of this axis in `point`.
    fn set(self, study: &VehicleStudy, point: &mut Point, i: usize) {
        match self {
            VehicleAxis::Scale => point.scale_index = i,
            VehicleAxis::Duration => point.duration_index = i,
            VehicleAxis::Runs => point.runs_index = i,
            VehicleAxis::Noise(c) => point.noise[c] = study.noise.levels(c)[i],
            VehicleAxis::Level(a) => {
                point.level_indices[a as usize] = i;
                a.apply(study.levels[a][i], &mut point.noise);
            }
            VehicleAxis::Acceleration => point.noise.acceleration = study.acceleration[i],
            VehicleAxis::Truth(e) => point.truth_levels[e] = i,
            VehicleAxis::GradeWalk => point.grade_walk_index = i,
        }
    }

    /// This axis's value at `point`, whose cycle segment lasts `duration_s`.
    pub fn value(self, study: &VehicleStudy, point: &Point, duration_s: f64) -> AxisValue {
        if self == VehicleAxis::Acceleration {
            return AxisValue::Text(point.noise.acceleration.name().to_string());
        }
        AxisValue::Number(match self {
            VehicleAxis::Scale => study.scales[point.scale_index],
            VehicleAxis::Duration => duration_s,
            VehicleAxis::Runs => study.drive.runs().map_or(1, |r| r[point.runs_index]) as f64,
            VehicleAxis::Noise(c) => point.noise[c],
            VehicleAxis::Level(a) => point.level(study, a),
            VehicleAxis::Truth(e) => study.truth.levels(e)[point.truth_levels[e]],
            VehicleAxis::GradeWalk => study.grade_walks[point.grade_walk_index],
            VehicleAxis::Acceleration => unreachable!("a text axis, returned above"),
        })
    }
}

/// Every condition of `study`: the product of the axes' levels, the last axis fastest.
pub fn grid(study: &VehicleStudy) -> Vec<Point> {
    let mut points = vec![Point::default()];
    for axis in axes_of(study) {
        points = points
            .into_iter()
            .flat_map(|base| {
                (0..axis.len(study)).map(move |i| {
                    let mut p = base;
                    axis.set(study, &mut p, i);
                    p
                })
            })
            .collect();
    }
    points
}
