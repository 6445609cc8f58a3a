//! The condition axes of the vehicle model, one variant of [`VehicleAxis`] each: its column,
//! its levels in the study, and what it sets in a [`Point`] of the condition grid. The
//! conditions are the product of [`axes`] in order (the last varies fastest); the layout's
//! axis columns and every condition's axis values are derived from the same list.

use super::super::{Axis, AxisValue};
use crate::dynamics::truth::{MODEL_ERROR_COUNT, MODEL_ERRORS};
use crate::estimate::channels::{Channel, NoiseLevels, Signal};
use crate::study::{AIR_SPEED_SD, AirSpeed, GRADE_MAP_SD, VehicleStudy};

/// The speed's channel: with the air speed measured, its level is the air-speed sensor's
/// (the sensor in the drag regressor), set by the air-speed axis.
const SPEED: Channel = Channel::of(Signal::Speed);

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
    /// The standard deviation of one noise channel (`noise.<channel>_sd`).
    Noise(Channel),
    /// The correlation time of the speed noise (`noise.velocity_correlation_time`).
    VelocityCorrelation,
    /// A constant offset of the measured grade (`noise.grade_bias`).
    GradeBias,
    /// The source of the acceleration in the output (`estimation.acceleration`).
    Acceleration,
    /// The elevation map's error \[m\] (`noise.grade_map_sd`).
    GradeMap,
    /// The air-speed sensor's noise \[m/s\] (`noise.air_speed_sd`). With a measured air
    /// speed it is the level of the noise in the drag regressor: the speed channel's level
    /// of the condition (docs/model.md#air-speed).
    AirSpeed,
    /// The value of model error `i` of [`MODEL_ERRORS`] (`truth.<key>`, an axis entry).
    Truth(usize),
}

/// Every axis, outermost first.
pub fn axes() -> impl Iterator<Item = VehicleAxis> {
    [VehicleAxis::Scale, VehicleAxis::Duration, VehicleAxis::Runs]
        .into_iter()
        .chain(Channel::ALL.map(VehicleAxis::Noise))
        .chain([
            VehicleAxis::VelocityCorrelation,
            VehicleAxis::GradeBias,
            VehicleAxis::Acceleration,
            VehicleAxis::GradeMap,
            VehicleAxis::AirSpeed,
        ])
        .chain(
            (0..MODEL_ERROR_COUNT)
                .filter(|&i| MODEL_ERRORS[i].axis)
                .map(VehicleAxis::Truth),
        )
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
    /// Index into `noise.grade_bias`.
    pub grade_bias_index: usize,
    /// The elevation map's error \[m\] (0: the map is exact).
    pub grade_map_sd: f64,
    /// Per entry of [`MODEL_ERRORS`], the index of its value in `[truth]`.
    pub truth_levels: [usize; MODEL_ERROR_COUNT],
}

impl Point {
    /// The index of the point's prefix of its cycle among the study's (the `duration` and
    /// `runs` axes, in their order; at most one has more than one level).
    pub fn prefix_index(&self, study: &VehicleStudy) -> usize {
        self.duration_index * VehicleAxis::Runs.len(study) + self.runs_index
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
            VehicleAxis::VelocityCorrelation => Axis::number("velocity_correlation_time", "s"),
            VehicleAxis::GradeBias => Axis::number("grade_bias", "rad"),
            VehicleAxis::Acceleration => Axis::text("acceleration"),
            VehicleAxis::GradeMap => Axis::number(GRADE_MAP_SD, "m"),
            VehicleAxis::AirSpeed => Axis::number(AIR_SPEED_SD, SPEED.unit()),
            VehicleAxis::Truth(i) => Axis::number(MODEL_ERRORS[i].key, MODEL_ERRORS[i].unit),
        }
    }

    /// Number of levels in the study.
    fn len(self, study: &VehicleStudy) -> usize {
        match self {
            VehicleAxis::Scale => study.scales.len(),
            VehicleAxis::Duration => study.durations.as_ref().map_or(1, Vec::len),
            VehicleAxis::Runs => study.drive.runs().map_or(1, <[usize]>::len),
            VehicleAxis::Noise(c) => study.noise.levels(c).len(),
            VehicleAxis::VelocityCorrelation => study.velocity_correlation_s.len(),
            VehicleAxis::GradeBias => study.grade_bias.len(),
            VehicleAxis::Acceleration => study.acceleration.len(),
            VehicleAxis::GradeMap => study.grade_map_sd.len(),
            VehicleAxis::AirSpeed => study.air_speed_sd.len(),
            VehicleAxis::Truth(i) => study.truth.levels(i).len(),
        }
    }

    /// Set level `i` of this axis in `point`.
    fn set(self, study: &VehicleStudy, point: &mut Point, i: usize) {
        match self {
            VehicleAxis::Scale => point.scale_index = i,
            VehicleAxis::Duration => point.duration_index = i,
            VehicleAxis::Runs => point.runs_index = i,
            VehicleAxis::Noise(c) => point.noise[c] = study.noise.levels(c)[i],
            VehicleAxis::VelocityCorrelation => {
                point.noise.velocity_correlation_s = study.velocity_correlation_s[i]
            }
            VehicleAxis::GradeBias => point.grade_bias_index = i,
            VehicleAxis::Acceleration => point.noise.acceleration = study.acceleration[i],
            VehicleAxis::GradeMap => point.grade_map_sd = study.grade_map_sd[i],
            // The speed channel's level is then 0 (validated): the sensor in the drag
            // regressor is the air-speed sensor.
            VehicleAxis::AirSpeed if study.air_speed == AirSpeed::Measured => {
                point.noise[SPEED] = study.air_speed_sd[i]
            }
            VehicleAxis::AirSpeed => {}
            VehicleAxis::Truth(e) => point.truth_levels[e] = i,
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
            VehicleAxis::Noise(SPEED) if study.air_speed == AirSpeed::Measured => 0.0,
            VehicleAxis::Noise(c) => point.noise[c],
            VehicleAxis::GradeMap => point.grade_map_sd,
            VehicleAxis::AirSpeed if study.air_speed == AirSpeed::Measured => point.noise[SPEED],
            VehicleAxis::AirSpeed => 0.0,
            VehicleAxis::VelocityCorrelation => point.noise.velocity_correlation_s,
            VehicleAxis::GradeBias => study.grade_bias[point.grade_bias_index],
            VehicleAxis::Truth(e) => study.truth.levels(e)[point.truth_levels[e]],
            VehicleAxis::Acceleration => unreachable!("a text axis, returned above"),
        })
    }
}

/// Every condition of `study`: the product of the axes' levels, the last axis fastest.
pub fn grid(study: &VehicleStudy) -> Vec<Point> {
    let mut points = vec![Point::default()];
    for axis in axes() {
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
