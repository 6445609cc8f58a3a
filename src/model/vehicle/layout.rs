//! The vehicle model's face to the executor: its row layout and its [`Model`]
//! implementation.

use std::cell::RefCell;

use arrow::array::RecordBatch;
use arrow::error::ArrowError;

use super::designed_tables;
use super::prepare::used_samples;
use super::{
    ExtraColumn, PARAMETERS, VehicleAxis, VehicleModel, axes_of, cycles_batch, cycles_schema,
    study_controls, study_extras,
};
use crate::dynamics::Prefix;
use crate::estimate::bounds::BOUNDS;
use crate::estimate::controls::CONTROLS;
use crate::estimate::estimator::RowScans;
use crate::estimate::moments::Rows;
use crate::model::{
    BoundInfo, ConditionInfo, ExtraInfo, ExtraTable, FigureX, Layout, Model, ParameterInfo,
    realise_one_by_one,
};
use crate::study::VehicleStudy;

/// The row layout of the vehicle model running `estimators`.
pub fn layout(study: &VehicleStudy) -> Layout {
    let terrain = match &study.terrain {
        Some(t) => format!(
            "{}, {} km",
            t.profile.describe(),
            t.length_m as f64 / 1000.0
        ),
        None if study.drive.uses_terrain() => "a flat road".to_string(),
        None => "the trace's grade".to_string(),
    };
    let estimators = &study.estimators;
    Layout {
        context: {
            let mut lines = vec![format!(
                "route: {terrain}; drive: {}",
                study.drive.describe()
            )];
            lines.extend(study.drive.designed().map(designed_tables::context));
            lines
        },
        axes: axes_of(study).map(VehicleAxis::column).collect(),
        condition_metrics: {
            let mut metrics = vec!["terrain_ms_grid", "terrain_ms_cycle"];
            metrics.extend(super::identification::names(study.settings.parameters));
            if estimators.iter().any(|e| e.estimates_grade()) {
                metrics.extend(super::pcrlb::METRICS);
            }
            metrics
        },
        figure_x: Some(FigureX {
            metric: "terrain_ms_grid",
            label: "terrain variability ς = mean θ² over the terrain table [rad²]",
            replaces: "scale",
        }),
        // The fitted ones: without 1/M when the mass is known.
        parameters: study
            .settings
            .parameters
            .free()
            .iter()
            .map(|&i| parameter_info(i))
            .collect(),
        estimators: estimators.iter().map(|e| e.name()).collect(),
        extras: study_extras(study)
            .into_iter()
            .map(ExtraColumn::info)
            .collect(),
        bounds: BOUNDS
            .iter()
            .map(|b| BoundInfo {
                name: b.name,
                description: b.description,
                not_valid: b.not_valid,
            })
            .collect(),
        controls: study_controls(study)
            .into_iter()
            .map(|j| ExtraInfo::from(&CONTROLS[j]))
            .collect(),
    }
}

/// The layout entry of θ component `i`.
fn parameter_info(i: usize) -> ParameterInfo {
    let (unit, description) = [
        ("1/kg", "1/M, inverse vehicle mass"),
        ("1/kg", "Cd/M, drag coefficient over mass"),
        ("1", "Cr, rolling-resistance coefficient"),
    ][i];
    ParameterInfo {
        name: PARAMETERS[i],
        unit,
        description,
    }
}

thread_local! {
    /// The measured rows of this thread's current realisation and the sums taken over them
    /// (memory reused).
    pub(super) static ROWS: RefCell<(Rows, RowScans)> = RefCell::default();
}

impl Model for VehicleModel {
    fn layout(&self) -> &Layout {
        &self.layout
    }

    fn extra_tables(&self) -> Vec<ExtraTable> {
        let mut tables = vec![ExtraTable {
            file: "cycles.parquet",
            table: "cycles",
            schema: cycles_schema(),
        }];
        if self.study.drive.designed().is_some() {
            tables.extend(designed_tables::tables());
        }
        tables
    }

    /// cycles.parquet: block `index` is cycle `index / sources` (of a scale and a truth,
    /// scale-major) with acceleration source `index % sources` (study order), whatever the
    /// other axes.
    fn extra_batch(&self, table: usize, index: usize) -> Option<Result<RecordBatch, ArrowError>> {
        if table > 0 {
            // A designed drive's trace and comparison, one batch each; its study has one
            // cycle.
            let designed = self.study.drive.designed().filter(|_| index == 0)?;
            return Some(match table {
                1 => designed_tables::trace_batch(designed, &self.cycles[0].cycle),
                _ => designed_tables::candidates_batch(designed),
            });
        }
        let sources = &self.study.acceleration;
        let scale = self
            .cycles
            .get(index / sources.len())
            .filter(|_| table == 0)?;
        let source = sources[index % sources.len()];
        let used = used_samples(&scale.cycle, &self.study, Prefix::Whole, source);
        Some(cycles_batch(
            self.study.scales[scale.scale_index],
            &self.study.truth.values(scale.truth_index),
            source.name(),
            &scale.cycle,
            &used,
        ))
    }

    fn condition_count(&self) -> usize {
        self.conditions.len()
    }

    fn condition_info(&self, c: usize) -> &ConditionInfo {
        &self.conditions[c].info
    }

    fn realise(&self, seed: u64, c: usize, r: u64, slots: &mut [f64]) {
        ROWS.with_borrow_mut(|(rows, scans)| {
            self.realise_with(seed, c, r, rows, scans, slots, None, None)
        });
    }

    fn draw_group(&self, c: usize) -> usize {
        self.conditions[c].group
    }

    fn realise_group(
        &self,
        seed: u64,
        conditions: &[usize],
        first: u64,
        count: usize,
        slots: &mut [f64],
    ) {
        if let [c] = *conditions
            && self.spans_filtered_together(c)
        {
            return self.realise_filtered_spans(seed, c, first, count, slots);
        }
        if !self.one_draw_serves(conditions) {
            if conditions.iter().any(|&c| self.moves_per_realisation(c)) {
                return self.realise_moved(seed, conditions, first, count, slots);
            }
            return realise_one_by_one(self, seed, conditions, first, count, slots);
        }
        let mut slots = slots.chunks_exact_mut(self.layout.realisation_stride());
        for moments in self.measure_group(seed, conditions, first, count) {
            for (&c, (moments, slots)) in conditions.iter().zip(moments.iter().zip(&mut slots)) {
                self.conclude(
                    c,
                    &self.conditions[c].regression,
                    &self.truth,
                    moments,
                    None,
                    slots,
                );
            }
        }
    }
}
