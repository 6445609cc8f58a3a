//! The thesis's vehicle study as a [`Model`]: one drive cycle per terrain scale, noise on
//! the measured speed and/or the output, OLS estimates and their bounds per realisation.

use std::sync::Arc;

use nalgebra::Vector3;

use super::{BoundInfo, ConditionInfo, ExtraInfo, Layout, Model, ParameterInfo, Status};
use crate::estimate::linalg::condition_number;
use crate::estimate::vehicle::{NoisySums, Regression, mass_and_drag, ols, scaled_inverse_sd};
use crate::noise::{BLOCK, Channel, NormalStream};
use crate::study::{EstimatorKind, Study, StudyError, VehicleStudy};
use crate::vehicle::{DriveCycle, simulate};

/// Parameter names of θ = [1/M, Cd/M, Cr] as used in every output column.
pub const PARAMETERS: [&str; 3] = ["inv_mass", "drag_over_mass", "rolling_resistance"];

/// Index of each bound in the layout.
const THESIS_BOUND: usize = 0;
const CRLB_OUTPUT: usize = 1;

/// Index of each extra in the layout.
const MASS_HAT: usize = 0;
const CD_HAT: usize = 1;
const FISHER_CONDITION: usize = 2;

/// One prepared condition: its axes and the regression of its drive cycle.
#[derive(Debug)]
struct Condition {
    info: ConditionInfo,
    scale_index: usize,
    sd_v: f64,
    sd_y: f64,
    regression: Arc<Regression>,
    /// sqrt(diag(σ_y² (XᵀX)⁻¹)) with the noise-free X, when output noise is the only noise.
    crlb_output: Option<[f64; 3]>,
}

/// The vehicle model with all its conditions prepared (drive cycles simulated).
#[derive(Debug)]
pub struct VehicleModel {
    study: VehicleStudy,
    layout: Layout,
    conditions: Vec<Condition>,
}

impl VehicleModel {
    /// Prepare every condition of `study`: simulate one cycle per terrain scale. A scale at
    /// which the vehicle stalls or runs off the terrain is an error naming that scale.
    pub fn new(study: &Study) -> Result<Self, StudyError> {
        let vs = study
            .vehicle()
            .ok_or_else(|| study.error_at("model", "is not a vehicle study"))?
            .clone();
        let truth = vs.vehicle.theta().to_vec();
        let mut regressions = Vec::with_capacity(vs.scales.len());
        let mut metrics = Vec::with_capacity(vs.scales.len());
        for (i, &scale) in vs.scales.iter().enumerate() {
            let table = vs.terrain.grade_table(scale);
            let cycle = simulate(&vs.vehicle, &vs.drive, &table).map_err(|e| {
                study.error_at(
                    &format!("terrain.scales[{i}]"),
                    format!("at scale {scale}: {e}"),
                )
            })?;
            metrics.push(vec![table.mean_square(), cycle.terrain_mean_square()]);
            regressions.push(Arc::new(Regression::new(&cycle, &vs.vehicle)));
        }
        let layout = layout(&vs.estimators);
        let mut conditions = Vec::new();
        for (scale_index, &scale) in vs.scales.iter().enumerate() {
            for &sd_v in &vs.noise.velocity_sd {
                for &sd_y in &vs.noise.output_sd {
                    let regression = regressions[scale_index].clone();
                    let output_only = sd_y > 0.0 && sd_v == 0.0;
                    let crlb_output = if output_only {
                        scaled_inverse_sd(&regression.xtx, sd_y).ok()
                    } else {
                        None
                    };
                    let applies_row = vec![sd_v > 0.0, crlb_output.is_some()];
                    conditions.push(Condition {
                        info: ConditionInfo {
                            axes: vec![scale, sd_v, sd_y],
                            metrics: metrics[scale_index].clone(),
                            truth: truth.clone(),
                            applies: vec![applies_row; vs.estimators.len()],
                        },
                        scale_index,
                        sd_v,
                        sd_y,
                        regression,
                        crlb_output,
                    });
                }
            }
        }
        Ok(VehicleModel {
            study: vs,
            layout,
            conditions,
        })
    }

    /// The noise-free drive cycle of condition `c` (simulated again: cycles are not kept).
    pub fn cycle(&self, c: usize) -> DriveCycle {
        let scale = self.study.scales[self.conditions[c].scale_index];
        let table = self.study.terrain.grade_table(scale);
        simulate(&self.study.vehicle, &self.study.drive, &table)
            .expect("the cycle simulated when the model was prepared")
    }

    /// The validated study settings.
    pub fn study(&self) -> &VehicleStudy {
        &self.study
    }
}

fn layout(estimators: &[EstimatorKind]) -> Layout {
    Layout {
        axes: vec!["scale", "velocity_sd", "output_sd"],
        condition_metrics: vec!["terrain_ms_grid", "terrain_ms_cycle"],
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
        ],
        bounds: vec![
            BoundInfo {
                name: "thesis_bound",
                description: "sqrt(diag((X̃ᵀX̃/σ_v²)⁻¹)) with the noisy regressors (thesis eqs. 21, 40); not a valid bound under speed noise",
            },
            BoundInfo {
                name: "crlb_output",
                description: "sqrt(diag(σ_y² (XᵀX)⁻¹)), noise-free X: the Cramér–Rao bound when output noise is the only noise",
            },
        ],
    }
}

impl Model for VehicleModel {
    fn layout(&self) -> &Layout {
        &self.layout
    }

    fn condition_count(&self) -> usize {
        self.conditions.len()
    }

    fn condition_info(&self, c: usize) -> &ConditionInfo {
        &self.conditions[c].info
    }

    fn realise(&self, seed: u64, c: usize, r: u64, slots: &mut [f64]) {
        let cond = &self.conditions[c];
        let reg = &*cond.regression;
        let n = reg.len();
        let mut speed = (cond.sd_v > 0.0)
            .then(|| NormalStream::for_realisation(seed, c as u64, Channel::Velocity, r));
        let mut output = (cond.sd_y > 0.0)
            .then(|| NormalStream::for_realisation(seed, c as u64, Channel::Output, r));
        let mut e = [0.0; BLOCK];
        let mut eta = [0.0; BLOCK];
        let mut sums = NoisySums::default();
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            if let Some(s) = speed.as_mut() {
                s.fill_block(&mut e[..len]);
            }
            if let Some(s) = output.as_mut() {
                s.fill_block(&mut eta[..len]);
            }
            sums.accumulate_block(
                reg,
                start,
                cond.sd_v,
                &e[..len],
                output.is_some().then_some(&eta[..len]),
            );
        }

        let system = sums.ols_system(reg, cond.sd_y);
        let fisher_condition = condition_number(&system.0);
        let thesis_bound = if cond.info.applies[0][THESIS_BOUND] {
            scaled_inverse_sd(&system.0, cond.sd_v).ok()
        } else {
            None
        };
        let layout = &self.layout;
        for (ei, est) in self.study.estimators.iter().enumerate() {
            let estimate = match est {
                EstimatorKind::Ols => ols(&system),
            };
            let theta = estimate.unwrap_or_else(|_| Vector3::repeat(f64::NAN));
            let status = if estimate.is_ok() {
                Status::Ok
            } else {
                Status::Singular
            };
            slots[layout.status_at(ei)] = status as u8 as f64;
            for p in 0..3 {
                slots[layout.theta_at(ei, p)] = theta[p];
                slots[layout.bound_at(ei, THESIS_BOUND, p)] =
                    thesis_bound.map_or(f64::NAN, |b| b[p]);
                slots[layout.bound_at(ei, CRLB_OUTPUT, p)] =
                    cond.crlb_output.map_or(f64::NAN, |b| b[p]);
            }
            let (mass, cd) = mass_and_drag(&theta);
            slots[layout.extra_at(ei, MASS_HAT)] = mass;
            slots[layout.extra_at(ei, CD_HAT)] = cd;
            slots[layout.extra_at(ei, FISHER_CONDITION)] = fisher_condition;
        }
    }
}
