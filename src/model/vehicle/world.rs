//! What a condition draws anew in every realisation beyond its sensor noise: the truth's
//! drawn model errors (gusts, a random force calibration) and the elevation map's error in
//! the measured grade. Such a realisation has its own regression, made as the condition's
//! is, from its own truth and map (docs/model.md#model-errors, docs/model.md#grade-map).

use std::borrow::Cow;
use std::sync::{Arc, OnceLock};

mod map;

pub(super) use map::GradeMap;
use map::{MapRows, mapped_tangent};

use super::prepare::{measured_speeds, read_grade, used_samples};
use crate::dynamics::filter_truth::FilterTruth;
use crate::dynamics::{DriveCycle, Prefix, Road, Truth};
use crate::estimate::channels::Acceleration;
use crate::estimate::regression::Regression;
use crate::noise::NormalSequence;
use crate::study::VehicleStudy;
use crate::terrain::GradeTable;

/// The times each run's drawn entries are realised at: a drive of one run, its sample times
/// from `start` (the cycle's first); a coast-down's run, the times from its first sample
/// on its time step, over twice its calm length (its samples, then as many again), since
/// gusts may lengthen a run; beyond that a gust series holds its last value
/// (docs/model.md#coastdown).
fn run_times(cycle: &DriveCycle, start: f64) -> Vec<Arc<[f64]>> {
    if cycle.runs() <= 1 {
        return vec![cycle.t_s.iter().map(|t| t - start).collect()];
    }
    (0..cycle.runs())
        .map(|k| {
            let first = cycle.run.partition_point(|&r| (r as usize) < k);
            let end = cycle.run.partition_point(|&r| (r as usize) <= k);
            let step = cycle.t_s[first + 1] - cycle.t_s[first];
            (0..2 * (end - first)).map(|j| j as f64 * step).collect()
        })
        .collect()
}

/// A realisation's cycle driven by its own truth, and that truth
/// ([`World::moved_cycles`]).
pub(super) type MovedCycle = (DriveCycle, Truth);

/// A condition whose realisations each have their own regression.
#[derive(Debug)]
pub(super) struct World {
    /// The condition's truth, its drawn entries included.
    truth: Truth,
    /// Its drawn entries alone, and its steady ones alone.
    drawn: Truth,
    steady: Truth,
    /// The condition's noise-free cycle (the steady entries only), and per run the times
    /// the drawn entries are realised at ([`run_times`]).
    cycle: Arc<DriveCycle>,
    run_times_s: Vec<Arc<[f64]>>,
    /// Its grade table, when the study has a terrain profile.
    table: Option<Arc<GradeTable>>,
    /// Its terrain scale.
    scale: f64,
    /// The part of the cycle it uses.
    prefix: Prefix,
    /// Its acceleration source.
    source: Acceleration,
    /// Its grade bias \[rad\].
    grade_bias_rad: f64,
    /// The map's error (`None`: the map is exact).
    pub grade_map: Option<GradeMap>,
    /// A truth that follows the filters' model (drawn when it [is](FilterTruth::is_drawn)).
    filter_truth: FilterTruth,
    /// The condition's rows as the map reads them, when only the map's error is drawn.
    map_rows: OnceLock<MapRows>,
}

/// Where a condition's realisations are made: its cycle, road and row selection.
#[derive(Debug)]
pub(super) struct Place {
    /// The condition's noise-free cycle (the steady entries only).
    pub cycle: Arc<DriveCycle>,
    /// Its grade table, when the study has a terrain profile.
    pub table: Option<Arc<GradeTable>>,
    /// Its terrain scale.
    pub scale: f64,
    /// The part of the cycle it uses (a duration, a number of runs, or all of it).
    pub prefix: Prefix,
    /// Its acceleration source.
    pub source: Acceleration,
    /// Its grade bias \[rad\].
    pub grade_bias_rad: f64,
}

impl World {
    /// The world of a condition with `truth`, `grade_map` and `filter_truth` at `place`;
    /// `None` when its realisations draw nothing beyond their sensor noise.
    pub fn new(
        truth: Truth,
        grade_map: Option<GradeMap>,
        filter_truth: FilterTruth,
        place: Place,
    ) -> Option<World> {
        if !truth.is_drawn() && grade_map.is_none() && !filter_truth.is_drawn() {
            return None;
        }
        let start = place.cycle.t_s.first().copied().unwrap_or(0.0);
        Some(World {
            drawn: truth.drawn_part(),
            steady: truth.steady(),
            truth,
            run_times_s: run_times(&place.cycle, start),
            cycle: place.cycle,
            table: place.table,
            scale: place.scale,
            prefix: place.prefix,
            source: place.source,
            grade_bias_rad: place.grade_bias_rad,
            grade_map,
            filter_truth,
            map_rows: OnceLock::new(),
        })
    }

    /// Whether the measured grade enters the regression by its sine and cosine alone, taken
    /// from its tangent (a model acceleration without a grade bias), not as an angle.
    fn grade_by_tangent(&self) -> bool {
        self.source == Acceleration::Model && self.grade_bias_rad == 0.0
    }

    /// The normals of realisation `r`'s map error.
    fn map_normals(seed: u64, key: u64, r: u64) -> NormalSequence {
        NormalSequence::for_realisation(seed, key, crate::noise::Stream::GradeMap, r)
    }

    /// Realisation `r`'s true cycle when the world draws nothing but a truth that follows
    /// the filters' model at the vehicle's own mass (a path, a grade walk, the process
    /// noise); `None` otherwise. An error says why the path cannot be used.
    pub fn filter_cycle(
        &self,
        vs: &VehicleStudy,
        seed: u64,
        key: u64,
        r: u64,
    ) -> Option<Result<DriveCycle, String>> {
        let only = self.filter_truth.is_drawn()
            && self.filter_truth.mass_prior.is_none()
            && !self.truth.is_drawn()
            && self.grade_map.is_none();
        only.then(|| {
            self.filter_truth
                .cycle(
                    &self.cycle,
                    &vs.vehicle,
                    self.table.as_deref(),
                    self.scale,
                    (seed, key, r),
                )
                .map(|(cycle, _)| cycle)
        })
    }

    /// The regression of realisation `r`: its truth (each drawn entry from its own stream
    /// of (`seed`, `key`)) driven or logged, its map's grade, the rows selected as the
    /// condition's are; and its own 1/M where the truth draws one. An error says why the
    /// realisation's truth cannot be used (the vehicle stalled or ran off the terrain, or
    /// too few rows are left).
    ///
    /// `condition` is the condition's own regression: a realisation that only draws a
    /// calibration is it with the force logged anew ([`Regression::with_force`]).
    pub fn regression(
        &self,
        vs: &VehicleStudy,
        condition: &Regression,
        ids: (u64, u64, u64),
    ) -> Result<(Regression, Option<f64>), String> {
        self.regression_given(vs, condition, ids, None)
    }

    /// The truths of realisations `first .. first + count` and the cycles they drive, made
    /// side by side where the drive mode integrates several at once (each what
    /// [`World::regression`] makes alone), when the truth moves the vehicle in every
    /// realisation: else `None`. An error says why a realisation's truth cannot be used.
    pub fn moved_cycles(
        &self,
        vs: &VehicleStudy,
        (seed, key): (u64, u64),
        first: u64,
        count: usize,
    ) -> Option<Vec<Result<MovedCycle, String>>> {
        if !self.moves_side_by_side() {
            return None;
        }
        let truths: Vec<Truth> = (first..first + count as u64)
            .map(|r| self.truth.realise(seed, key, r, &self.run_times_s))
            .collect();
        let road = Road {
            table: self.table.as_deref(),
            scale: self.scale,
        };
        let cycles = vs.drive.cycles(&vs.vehicle, road, &truths);
        Some(
            cycles
                .into_iter()
                .zip(truths)
                .map(|(cycle, truth)| Ok((cycle.map_err(|e| e.to_string())?, truth)))
                .collect(),
        )
    }

    /// Whether [`World::moved_cycles`] makes the realisations' cycles: the truth moves the
    /// vehicle in every realisation (and the cycle is not cut to a coast-down's first runs).
    pub fn moves_side_by_side(&self) -> bool {
        !self.filter_truth.is_drawn()
            && self.truth.is_drawn()
            && self.truth.moves_per_realisation()
            && !matches!(self.prefix, Prefix::Runs(_))
    }

    /// [`World::regression`] of a realisation whose truth and cycle [`World::moved_cycles`]
    /// made already (`moved`; `None`: made here).
    pub fn regression_given(
        &self,
        vs: &VehicleStudy,
        condition: &Regression,
        (seed, key, r): (u64, u64, u64),
        moved: Option<Result<MovedCycle, String>>,
    ) -> Result<(Regression, Option<f64>), String> {
        let only_calibration = self.truth.is_drawn()
            && !self.truth.moves_per_realisation()
            && self.grade_map.is_none()
            && !self.filter_truth.is_drawn()
            && self.grade_bias_rad == 0.0;
        if only_calibration {
            let drawn = self.drawn.realise(seed, key, r, &self.run_times_s);
            // The condition's rows are the realisation's unless braking rows are left out
            // and the calibration (a scale) turns the force's sign.
            let keeps_signs = drawn.logged_force(1.0) > 0.0 && drawn.logged_force(-1.0) < 0.0;
            if !vs.selection.exclude_braking || keeps_signs {
                return Ok((condition.with_force(|f| drawn.log_forces(f)), None));
            }
        }
        let only_map = !self.truth.is_drawn() && !self.filter_truth.is_drawn();
        if let (Some(map), true) = (&self.grade_map, only_map && self.grade_by_tangent()) {
            let rows = self.map_rows.get_or_init(|| {
                let used = used_samples(&self.cycle, vs, self.prefix, self.source);
                MapRows::new(&self.cycle, &used)
            });
            let (sin, cos) =
                map.differences(&mut Self::map_normals(seed, key, r), rows.end_m, |d| {
                    rows.sin_cos(d)
                });
            return Ok((read_grade(vs, condition.with_grade(sin, cos)), None));
        }
        let nominal = &*self.cycle;
        let mut inv_mass = None;
        // With the cycle, whether it was integrated for this realisation alone: its memory
        // then goes to the thread's spares once read, for the next realisation's integration.
        let (mut cycle, truth, integrated) = if self.filter_truth.is_drawn() {
            // The filters' model: its own Euler path (validated to come without model
            // errors).
            let (cycle, drawn) = self.filter_truth.cycle(
                nominal,
                &vs.vehicle,
                self.table.as_deref(),
                self.scale,
                (seed, key, r),
            )?;
            inv_mass = self.filter_truth.mass_prior.map(|_| drawn);
            (cycle, Cow::Borrowed(&self.truth), false)
        } else if !self.truth.is_drawn() {
            (nominal.clone(), Cow::Borrowed(&self.truth), false)
        } else if self.truth.moves_per_realisation() {
            // The force the truth needs changes: the drive mode makes the cycle again
            // (integrates it, or logs another force for the same motion).
            let (cycle, truth) = match moved {
                Some(moved) => moved?,
                None => {
                    let truth = self.truth.realise(seed, key, r, &self.run_times_s);
                    let road = Road {
                        table: self.table.as_deref(),
                        scale: self.scale,
                    };
                    // Only the runs the condition uses (a coast-down's first k).
                    let cycle = match self.prefix {
                        Prefix::Runs(k) => vs.drive.cycle_of_runs(&vs.vehicle, road, &truth, k),
                        _ => vs.drive.cycle(&vs.vehicle, road, &truth),
                    }
                    .map_err(|e| e.to_string())?;
                    (cycle, truth)
                }
            };
            // Given back to the spares once read where the mode builds its cycles in them
            // (a speed trace's or a replay's would pile up there unused).
            (cycle, Cow::Owned(truth), vs.drive.reuses_spares())
        } else {
            // Only a calibration is drawn: the noise-free cycle's log through it.
            let drawn = self.drawn.realise(seed, key, r, &self.run_times_s);
            let mut cycle = nominal.clone();
            drawn.log_forces(&mut cycle.f_prop_n);
            (cycle, Cow::Borrowed(&self.steady), false)
        };
        let used = used_samples(&cycle, vs, self.prefix, self.source);
        if used.iter().filter(|u| **u).count() < 3 {
            return Err("fewer than 3 samples are left for the regression".into());
        }
        if let Some(air) = measured_speeds(vs, &truth, &cycle) {
            cycle.v_m_s = air;
        }
        // The measured grade's sine and cosine at the used rows, where the map reads it and
        // the regression takes it by its tangent.
        let mut mapped = None;
        if let Some(map) = &self.grade_map {
            // The map reaches as far as the rows the regression uses.
            let rows = MapRows::new(&cycle, &used);
            map.differences(&mut Self::map_normals(seed, key, r), rows.end_m, |d| {
                if self.grade_by_tangent() {
                    mapped = Some(rows.sin_cos(d));
                } else {
                    for i in 0..cycle.len() {
                        let t = mapped_tangent(
                            cycle.grade_rad[i].tan(),
                            cycle.x_m[i],
                            cycle.heading(i),
                            d,
                        );
                        cycle.grade_rad[i] = t.atan();
                    }
                }
            });
        }
        let regression = match self.source {
            Acceleration::Differentiated => {
                let regression =
                    Regression::differentiated(&cycle, &used, self.grade_bias_rad, &vs.vehicle);
                give_back(cycle, integrated);
                regression
            }
            Acceleration::Model if mapped.is_some() => {
                let (sin, cos) = mapped.expect("the map's grade");
                let (selected, own) = selected_rows(cycle, &used, integrated);
                let regression = Regression::with_sin_cos(&selected, sin, cos, &vs.vehicle);
                give_back(selected, own);
                read_grade(vs, regression)
            }
            Acceleration::Model => {
                let (mut selected, own) = selected_rows(cycle, &used, integrated);
                if self.grade_bias_rad != 0.0 {
                    selected
                        .grade_rad
                        .iter_mut()
                        .for_each(|g| *g += self.grade_bias_rad);
                }
                let regression = Regression::new(&selected, &vs.vehicle);
                give_back(selected, own);
                read_grade(vs, regression)
            }
        };
        Ok((regression, inv_mass))
    }
}

/// The rows of `cycle` that `used` keeps: the cycle itself where it keeps every row, else a
/// copy, the cycle then given to the thread's spares when it was `integrated` for one
/// realisation ([`DriveCycle::recycle`]). With it, whether the rows are that integrated
/// cycle, to be given back once read.
fn selected_rows(cycle: DriveCycle, used: &[bool], integrated: bool) -> (DriveCycle, bool) {
    if used.len() == cycle.len() && used.iter().all(|&u| u) {
        return (cycle, integrated);
    }
    let selected = cycle.select(used);
    give_back(cycle, integrated);
    (selected, false)
}

/// `cycle` to the thread's spares when `integrated` for one realisation: only such a cycle
/// has the room the next realisation's integration asks for.
fn give_back(cycle: DriveCycle, integrated: bool) {
    if integrated {
        cycle.recycle();
    }
}

/// What a realisation of a condition draws beyond its sensor noise (for `simulate-log`).
impl super::VehicleModel {
    /// Realisation `r`'s true cycle of condition `c` under `seed` when its world draws
    /// nothing but a truth that follows the filters' model at the vehicle's mass
    /// ([`World::filter_cycle`]): `None` otherwise.
    pub fn filter_cycle(&self, c: usize, seed: u64, r: u64) -> Option<Result<DriveCycle, String>> {
        self.conditions[c]
            .world
            .as_ref()?
            .filter_cycle(&self.study, seed, self.stream_key(c), r)
    }

    /// The key that makes condition `c`'s realisations more than its cycle and its sensor
    /// noise — an entry drawn per realisation, the map's error, or a measured air speed —
    /// when one does (`None`: each realisation is the condition's regression with its
    /// channels' draws).
    pub fn draws_a_world(&self, c: usize) -> Option<&'static str> {
        let cond = &self.conditions[c];
        if self.study.air_speed == crate::study::AirSpeed::Measured {
            return Some("estimation.air_speed");
        }
        let world = cond.world.as_ref()?;
        Some(match world.grade_map {
            Some(_) => "noise.grade_map_sd",
            None => "truth",
        })
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::dynamics::{clear_spares, spare_cycles};
    use crate::model::Model;
    use crate::model::vehicle::VehicleModel;
    use crate::study::Study;

    /// `spare_cycles()` after eight gusty realisations of a two-minute drive in `[drive]`
    /// mode `drive` on this thread (the spares emptied first), with a flat trace at 20 m/s
    /// written in `dir` for the modes that read one.
    fn spares_after_gusts(dir: &Path, drive: &str) -> usize {
        let trace: String = (0..=1200)
            .map(|i| format!("{},20.0,0.0\n", i as f64 * 0.1))
            .collect();
        std::fs::write(dir.join("trace.csv"), format!("t,v,grade\n{trace}")).unwrap();
        let text = format!(
            r#"
            name = "spares"
            seed = 1
            realisations = 8
            [vehicle]
            mass = 1800.0
            drag_coefficient = 0.35
            rolling_resistance = 0.0125
            frontal_area = 2.2
            air_density = 1.2
            gravity = 9.81
            final_drive_ratio = 2.7
            wheel_radius = 0.3
            [drive]
            {drive}
            [terrain]
            profile = "cos2"
            height = 5.0
            period = 300.0
            length = 20000
            scales = [1.0]
            scale_applies_to = "grade"
            [noise]
            velocity_sd = [0.1]
            output_sd = [0.0]
            [estimation]
            estimators = ["ols"]
            [truth]
            wind_gust_sd = [2.0]
            "#
        );
        let study = Study::from_toml_in(&text, "(test)", dir).unwrap();
        let model = VehicleModel::new(&study).unwrap();
        clear_spares();
        let mut slots = vec![0.0; 8 * model.layout().realisation_stride()];
        model.realise_group(1, &[0], 0, 8, &mut slots);
        spare_cycles()
    }

    #[test]
    fn only_a_mode_that_integrates_into_the_spares_gives_its_gusty_cycles_back() {
        let dir = tempfile::tempdir().unwrap();
        let torque = r#"duration = 120.0
            time_step = 0.1
            initial_speed = 20.0
            torque_mean = 225.0
            torque_amplitude = 0.1
            torque_frequency = 0.1"#;
        let trace = r#"mode = "speed_trace"
            trace = "trace.csv"
            time_column = "t"
            speed_column = "v"
            speed_unit = "m/s""#;
        // The torque drive takes its spares back: some are left over, never more than a few.
        let kept = spares_after_gusts(dir.path(), torque);
        assert!(
            (1..=8).contains(&kept),
            "{kept} spare cycles after the torque drive"
        );
        // A speed trace builds its cycles elsewhere: none of them goes to the spares.
        assert_eq!(spares_after_gusts(dir.path(), trace), 0);
    }
}
