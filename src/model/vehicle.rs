//! The thesis's vehicle study as a [`Model`]: one drive cycle per terrain scale; noise on
//! the measured speed, output, grade and force; OLS and BCLS on the same draw of each
//! realisation (common random numbers); and every bound that applies.

use std::sync::Arc;

use nalgebra::Vector3;
use rayon::prelude::*;

use arrow::array::{ArrayRef, Float64Array, Int32Array, RecordBatch};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use arrow::error::ArrowError;

use super::{
    Axis, AxisValue, BoundInfo, ConditionInfo, ExtraInfo, ExtraTable, FigureX, Layout, Model,
    ParameterInfo, Status,
};
use crate::estimate::bounds::scaled_inverse_sd;
use crate::estimate::conversions::{mass_and_drag, thesis_error_conversions};
use crate::estimate::estimators::solve;
use crate::estimate::moments::{BlockNoise, MomentAccumulator, Moments};
use crate::estimate::regression::Regression;
use crate::noise::{BLOCK, Channel, NoiseLevels, NormalStream};
use crate::numeric::linalg::condition_number;
use crate::study::{EstimatorKind, Study, StudyError, VehicleStudy};
use crate::vehicle::{DriveCycle, simulate};

/// Parameter names of θ = [1/M, Cd/M, Cr] as used in every output column.
pub const PARAMETERS: [&str; 3] = ["inv_mass", "drag_over_mass", "rolling_resistance"];

/// Bounds, in layout order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Bound {
    Thesis = 0,
    CrlbOutput = 1,
    EivSandwich = 2,
    EivCrlbLinearized = 3,
}

/// Extras, in layout order.
const MASS_HAT: usize = 0;
const CD_HAT: usize = 1;
const FISHER_CONDITION: usize = 2;
const MASS_SD_THESIS: usize = 3;
const CD_SD_THESIS: usize = 4;

/// One prepared condition: its noise and the regression of its drive cycle.
#[derive(Debug)]
struct Condition {
    info: ConditionInfo,
    scale_index: usize,
    noise: NoiseLevels,
    regression: Arc<Regression>,
    /// Standard errors of the bounds that are constant over realisations (NaN when absent).
    constant_bounds: [[f64; 3]; 4],
}

/// The vehicle model with all its conditions prepared (drive cycles simulated).
#[derive(Debug)]
pub struct VehicleModel {
    study: VehicleStudy,
    layout: Layout,
    conditions: Vec<Condition>,
    /// One simulated cycle per terrain scale (kept for cycles.parquet and figures).
    cycles: Vec<Arc<DriveCycle>>,
}

impl VehicleModel {
    /// Prepare every condition of `study`: simulate one cycle per terrain scale. A scale at
    /// which the vehicle stalls or runs off the terrain is an error naming that scale.
    pub fn new(study: &Study) -> Result<Self, StudyError> {
        let vs = study
            .vehicle()
            .ok_or_else(|| study.error_at("model", "is not a vehicle study"))?
            .clone();
        let truth = vs.vehicle.theta();
        // One drive cycle per scale, simulated in parallel (each is independent).
        let prepared: Vec<(Vec<f64>, Arc<Regression>, Arc<DriveCycle>)> = vs
            .scales
            .par_iter()
            .enumerate()
            .map(|(i, &scale)| {
                let table = vs.terrain.grade_table(scale);
                let cycle = simulate(&vs.vehicle, &vs.drive, &table).map_err(|e| {
                    study.error_at(
                        &format!("terrain.scales[{i}]"),
                        format!("at scale {scale}: {e}"),
                    )
                })?;
                let metrics = vec![table.mean_square(), cycle.terrain_mean_square()];
                let regression = Arc::new(Regression::new(&cycle, &vs.vehicle));
                Ok((metrics, regression, Arc::new(cycle)))
            })
            .collect::<Result<_, StudyError>>()?;
        let layout = layout(&vs.estimators);
        let pairs: Vec<(usize, NoiseLevels)> = (0..vs.scales.len())
            .flat_map(|s| vs.noise.levels().into_iter().map(move |n| (s, n)))
            .collect();
        let conditions = pairs
            .par_iter()
            .map(|&(scale_index, noise)| {
                let (metrics, regression, _) = &prepared[scale_index];
                let regression = regression.clone();
                let nan = [f64::NAN; 3];
                let mut constant_bounds = [nan; 4];
                if noise.output_only() {
                    constant_bounds[Bound::CrlbOutput as usize] =
                        scaled_inverse_sd(&regression.xtx, noise.output_sd).unwrap_or(nan);
                }
                if noise.in_regressors() {
                    constant_bounds[Bound::EivSandwich as usize] =
                        regression.sandwich_se(&truth, &noise).unwrap_or(nan);
                    constant_bounds[Bound::EivCrlbLinearized as usize] =
                        regression.linearized_crlb_se(&truth, &noise).unwrap_or(nan);
                }
                let applies_row = vec![
                    noise.velocity_sd > 0.0,
                    noise.output_only(),
                    noise.in_regressors(),
                    noise.in_regressors(),
                ];
                Condition {
                    info: ConditionInfo {
                        axes: [
                            vs.scales[scale_index],
                            noise.velocity_sd,
                            noise.output_sd,
                            noise.grade_sd,
                            noise.force_sd,
                        ]
                        .into_iter()
                        .map(AxisValue::Number)
                        .collect(),
                        metrics: metrics.clone(),
                        truth: truth.to_vec(),
                        applies: vec![applies_row; vs.estimators.len()],
                    },
                    scale_index,
                    noise,
                    regression,
                    constant_bounds,
                }
            })
            .collect();
        Ok(VehicleModel {
            study: vs,
            layout,
            conditions,
            cycles: prepared.into_iter().map(|(_, _, cycle)| cycle).collect(),
        })
    }

    /// Every condition's drive cycle (conditions with the same terrain scale share one).
    pub fn cycles(&self) -> Vec<Arc<DriveCycle>> {
        self.conditions
            .iter()
            .map(|c| self.cycles[c.scale_index].clone())
            .collect()
    }

    /// The validated study settings.
    pub fn study(&self) -> &VehicleStudy {
        &self.study
    }

    /// The moments of realisation `r` of condition `c`: the kernel. Draws each active
    /// channel's normals block by block and accumulates the normal-equation sums.
    pub fn moments(&self, seed: u64, c: usize, r: u64) -> Moments {
        let cond = &self.conditions[c];
        let reg = &*cond.regression;
        let noise = cond.noise;
        let stream = |on: bool, channel| {
            on.then(|| NormalStream::for_realisation(seed, c as u64, channel, r))
        };
        let mut speed = stream(noise.velocity_sd > 0.0, Channel::Velocity);
        let mut output = stream(noise.output_sd > 0.0, Channel::Output);
        let mut grade = stream(noise.grade_sd > 0.0, Channel::Grade);
        let mut force = stream(noise.force_sd > 0.0, Channel::Force);
        let mut buffers = [[0.0; BLOCK]; 4];
        let mut acc = MomentAccumulator::new(reg, noise);
        let n = reg.len();
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            let [bv, bo, bg, bf] = &mut buffers;
            acc.add_block(
                start,
                len,
                BlockNoise {
                    velocity: draw(&mut speed, &mut bv[..len]),
                    output: draw(&mut output, &mut bo[..len]),
                    grade: draw(&mut grade, &mut bg[..len]),
                    force: draw(&mut force, &mut bf[..len]),
                },
            );
        }
        acc.finish()
    }
}

/// The next block of a channel's draws into `buf`, or `None` when the channel is off.
fn draw<'b>(stream: &mut Option<NormalStream>, buf: &'b mut [f64]) -> Option<&'b [f64]> {
    stream.as_mut()?.fill_block(buf);
    Some(buf)
}

/// The row layout of the vehicle model running `estimators`.
pub fn layout(estimators: &[EstimatorKind]) -> Layout {
    Layout {
        axes: vec![
            Axis::number("scale", ""),
            Axis::number("velocity_sd", "m/s"),
            Axis::number("output_sd", "m/s^2"),
            Axis::number("grade_sd", "rad"),
            Axis::number("force_sd", "N"),
        ],
        condition_metrics: vec!["terrain_ms_grid", "terrain_ms_cycle"],
        figure_x: Some(FigureX {
            metric: "terrain_ms_grid",
            label: "terrain variability ς = mean θ² over the terrain table [rad²]",
            replaces: "scale",
        }),
        parameters: vec![
            ParameterInfo {
                name: PARAMETERS[0],
                unit: "1/kg",
                description: "1/M, inverse vehicle mass",
            },
            ParameterInfo {
                name: PARAMETERS[1],
                unit: "1/kg",
                description: "Cd/M, drag coefficient over mass",
            },
            ParameterInfo {
                name: PARAMETERS[2],
                unit: "1",
                description: "Cr, rolling-resistance coefficient",
            },
        ],
        estimators: estimators.iter().map(|e| e.name()).collect(),
        extras: vec![
            ExtraInfo {
                name: "mass_hat",
                unit: "kg",
                description: "M̂ = 1/θ̂₁ (thesis eq. 38)",
            },
            ExtraInfo {
                name: "cd_hat",
                unit: "1",
                description: "Ĉd = M̂ θ̂₂ (thesis eq. 39)",
            },
            ExtraInfo {
                name: "fisher_condition",
                unit: "1",
                description: "2-norm condition number of the noisy X̃ᵀX̃ (the thesis's cond(FI))",
            },
            ExtraInfo {
                name: "mass_sd_thesis",
                unit: "kg",
                description: "σ_M = 1/(θ̂₁ − σ₁) − M̂ from the thesis bound (thesis eq. 41)",
            },
            ExtraInfo {
                name: "cd_sd_thesis",
                unit: "1",
                description: "σ_Cd = (θ̂₂ + σ₂)/(θ̂₁ + σ₁) − Ĉd from the thesis bound (thesis eq. 42)",
            },
        ],
        bounds: vec![
            BoundInfo {
                name: "thesis_bound",
                description: "sqrt(diag((X̃ᵀX̃/σ_v²)⁻¹)) with the noisy regressors (thesis eqs. 21, 40); reported under speed noise, where it is not a valid bound",
            },
            BoundInfo {
                name: "crlb_output",
                description: "sqrt(diag(σ_y² (XᵀX)⁻¹)), noise-free X: the Cramér–Rao bound when output noise is the only noise",
            },
            BoundInfo {
                name: "eiv_sandwich",
                description: "first-order covariance (XᵀX)⁻¹ XᵀΩX (XᵀX)⁻¹ of OLS/BCLS under regressor noise, Ω the equation-error variance",
            },
            BoundInfo {
                name: "eiv_crlb_linearized",
                description: "(XᵀΩ⁻¹X)⁻¹: the bound of the linearised equation-error model (what a weighted unbiased estimator could reach)",
            },
        ],
    }
}

/// Schema of `cycles.parquet`: the noise-free time series of each condition.
pub fn cycles_schema() -> SchemaRef {
    let f64_field = |name| Field::new(name, DataType::Float64, false);
    Arc::new(Schema::new(vec![
        Field::new("condition", DataType::Int32, false),
        f64_field("t"),
        f64_field("x"),
        f64_field("v"),
        f64_field("grade"),
        f64_field("f_prop"),
        f64_field("accel"),
    ]))
}

/// One condition's drive cycle as a record batch.
pub fn cycles_batch(condition: usize, cycle: &DriveCycle) -> Result<RecordBatch, ArrowError> {
    let col = |v: &Vec<f64>| -> ArrayRef { Arc::new(Float64Array::from(v.clone())) };
    RecordBatch::try_new(
        cycles_schema(),
        vec![
            Arc::new(Int32Array::from(vec![condition as i32; cycle.len()])),
            col(&cycle.t_s),
            col(&cycle.x_m),
            col(&cycle.v_m_s),
            col(&cycle.grade_rad),
            col(&cycle.f_prop_n),
            col(&cycle.accel_m_s2),
        ],
    )
}

impl Model for VehicleModel {
    fn layout(&self) -> &Layout {
        &self.layout
    }

    fn extra_tables(&self) -> Vec<ExtraTable> {
        vec![ExtraTable {
            file: "cycles.parquet",
            table: "cycles",
            schema: cycles_schema(),
        }]
    }

    fn extra_batch(&self, table: usize, index: usize) -> Option<Result<RecordBatch, ArrowError>> {
        let condition = self.conditions.get(index).filter(|_| table == 0)?;
        Some(cycles_batch(index, &self.cycles[condition.scale_index]))
    }

    fn condition_count(&self) -> usize {
        self.conditions.len()
    }

    fn condition_info(&self, c: usize) -> &ConditionInfo {
        &self.conditions[c].info
    }

    fn realise(&self, seed: u64, c: usize, r: u64, slots: &mut [f64]) {
        let cond = &self.conditions[c];
        let k = cond.regression.k;
        let moments = self.moments(seed, c, r);
        let ols_system = moments.ols_system(k);
        let fisher_condition = condition_number(&ols_system.0);
        let thesis_bound = if cond.noise.velocity_sd > 0.0 {
            scaled_inverse_sd(&ols_system.0, cond.noise.velocity_sd).ok()
        } else {
            None
        };
        let mut bounds = cond.constant_bounds;
        bounds[Bound::Thesis as usize] = thesis_bound.unwrap_or([f64::NAN; 3]);
        let layout = &self.layout;
        for (ei, est) in self.study.estimators.iter().enumerate() {
            let estimate = match est {
                EstimatorKind::Ols => solve(&ols_system),
                EstimatorKind::Bcls => solve(&moments.bcls_system(k, cond.noise.velocity_sd)),
            };
            let status = if estimate.is_ok() {
                Status::Ok
            } else {
                Status::Singular
            };
            let theta = estimate.unwrap_or_else(|_| Vector3::repeat(f64::NAN));
            slots[layout.status_at(ei)] = status as u8 as f64;
            for p in 0..3 {
                slots[layout.theta_at(ei, p)] = theta[p];
                for (b, values) in bounds.iter().enumerate() {
                    slots[layout.bound_at(ei, b, p)] = values[p];
                }
            }
            let (mass, cd) = mass_and_drag(&theta);
            let (mass_sd, cd_sd) = thesis_bound.map_or((f64::NAN, f64::NAN), |b| {
                thesis_error_conversions(&theta, &b)
            });
            slots[layout.extra_at(ei, MASS_HAT)] = mass;
            slots[layout.extra_at(ei, CD_HAT)] = cd;
            slots[layout.extra_at(ei, FISHER_CONDITION)] = fisher_condition;
            slots[layout.extra_at(ei, MASS_SD_THESIS)] = mass_sd;
            slots[layout.extra_at(ei, CD_SD_THESIS)] = cd_sd;
        }
    }
}
