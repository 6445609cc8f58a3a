//! The worked example of thesis §3.2–3.3 as a [`Model`]: `y = θ₁ + θ₂ t` at
//! t = 0, 0.5, …, 10 with i.i.d. noise, fitted by OLS, with the Fisher bound computed from an
//! *assumed* σ (7.5 in the thesis) next to the exact OLS standard error for the true σ.
//!
//! It shows, in a setting small enough to reason about by hand, how a wrong σ moves
//! EmpSE/bound away from 1 and how a non-Gaussian noise shape shows in coverage even when
//! the SE is right. (The thesis's Appendix A divides the information by σ instead of σ² and
//! prints 3 × variance as an error bar; neither slip is copied here.)

use nalgebra::{Matrix2, Vector2};

use super::{Axis, AxisValue, BoundInfo, ConditionInfo, Layout, Model, ParameterInfo, Status};
use crate::estimate::estimators::{Estimator, Ols};
use crate::noise::{BLOCK, NormalStream};
use crate::numeric::linalg::{inverse_spd, solve_spd};
use crate::study::{LineFitStudy, NoiseShape, Study, StudyError};

const ASSUMED_SIGMA: usize = 0;
const TRUE_SIGMA: usize = 1;

/// √12: a uniform variable on [−½, ½] has SD 1/√12.
const SQRT_12: f64 = 3.464_101_615_137_754_6;

#[derive(Debug)]
struct Condition {
    info: ConditionInfo,
    shape: NoiseShape,
    sd: f64,
}

/// The line-fit model with its design prepared.
#[derive(Debug)]
pub struct LineFitModel {
    study: LineFitStudy,
    layout: Layout,
    conditions: Vec<Condition>,
    xtx: Matrix2<f64>,
    /// sqrt(diag((XᵀX)⁻¹)): bounds are σ times this.
    unit_se: [f64; 2],
}

impl LineFitModel {
    /// Prepare the study's conditions (noise shape × noise SD).
    pub fn new(study: &Study) -> Result<Self, StudyError> {
        let ls = study
            .line_fit()
            .ok_or_else(|| study.error_at("model", "is not a line_fit study"))?
            .clone();
        let n = ls.times.len() as f64;
        let st: f64 = ls.times.iter().sum();
        let stt: f64 = ls.times.iter().map(|t| t * t).sum();
        let xtx = Matrix2::new(n, st, st, stt);
        let inv = inverse_spd(&xtx)
            .map_err(|e| study.error_at("line_fit.t_step", format!("design is degenerate: {e}")))?;
        let unit_se = [inv[(0, 0)].sqrt(), inv[(1, 1)].sqrt()];
        let truth = vec![ls.intercept, ls.slope];
        // The line has no model error: the noise-free fit, minus the truth.
        let (sy, sty) = ls.times.iter().fold((0.0, 0.0), |(sy, sty), t| {
            let y = ls.intercept + ls.slope * t;
            (sy + y, sty + t * y)
        });
        let bias_model = match solve_spd(&xtx, &Vector2::new(sy, sty)) {
            Ok(theta) => vec![vec![theta[0] - truth[0], theta[1] - truth[1]]],
            Err(_) => vec![vec![f64::NAN; 2]],
        };
        let mut conditions = Vec::new();
        for &shape in &ls.noise {
            for &sd in &ls.noise_sd {
                conditions.push(Condition {
                    info: ConditionInfo {
                        axes: vec![
                            AxisValue::Text(shape.name().to_string()),
                            AxisValue::Number(sd),
                        ],
                        metrics: vec![],
                        truth: truth.clone(),
                        bias_model: bias_model.clone(),
                        model_errors: Vec::new(),
                        applies: vec![vec![true, sd > 0.0]],
                        controls: Vec::new(),
                        control_covariance: None,
                    },
                    shape,
                    sd,
                });
            }
        }
        let layout = layout();
        Ok(LineFitModel {
            study: ls,
            layout,
            conditions,
            xtx,
            unit_se,
        })
    }
}

/// The row layout of the line-fit model.
pub fn layout() -> Layout {
    Layout {
        context: Vec::new(),
        axes: vec![Axis::text("noise"), Axis::number("noise_sd", "")],
        condition_metrics: vec![],
        figure_x: None,
        controls: Vec::new(),
        parameters: vec![
            ParameterInfo {
                name: "intercept",
                unit: "",
                description: "θ₁, the intercept",
            },
            ParameterInfo {
                name: "slope",
                unit: "1/t",
                description: "θ₂, the slope",
            },
        ],
        estimators: vec![Ols.name()],
        extras: vec![],
        bounds: vec![
            BoundInfo {
                name: "assumed_sigma",
                description: "sqrt(diag(σ_a² (XᵀX)⁻¹)) with the assumed σ_a (the thesis's 7.5)",
                // The thesis's example of a wrong σ: a bound only when σ_a is the truth.
                not_valid: Some(": σ_a is an assumed value, not the noise's standard deviation"),
            },
            BoundInfo {
                name: "true_sigma",
                description: "sqrt(diag(σ² (XᵀX)⁻¹)) with the true noise SD: the exact OLS SE; the CRLB only for Gaussian noise",
                not_valid: None,
            },
        ],
    }
}

impl Model for LineFitModel {
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
        let times = &self.study.times;
        let mut source =
            NormalStream::for_realisation(seed, c as u64, crate::noise::Stream::LineFit, r);
        let mut draws = [0.0; BLOCK];
        let (mut sy, mut sty) = (0.0, 0.0);
        for ts in times.chunks(BLOCK) {
            let d = &mut draws[..ts.len()];
            match cond.shape {
                NoiseShape::Gaussian => source.fill_block(d),
                NoiseShape::Uniform => {
                    source.fill_uniform(d);
                    // centred and scaled to SD 1
                    d.iter_mut().for_each(|u| *u = SQRT_12 * (*u - 0.5));
                }
            }
            for (t, e) in ts.iter().zip(d.iter()) {
                let y = self.study.intercept + self.study.slope * t + cond.sd * e;
                sy += y;
                sty += t * y;
            }
        }
        let estimate = solve_spd(&self.xtx, &Vector2::new(sy, sty));
        let layout = &self.layout;
        let status = if estimate.is_ok() {
            Status::Ok
        } else {
            Status::Singular
        };
        let theta = estimate.unwrap_or_else(|_| Vector2::repeat(f64::NAN));
        slots[layout.status_at(0)] = status as u8 as f64;
        for p in 0..2 {
            slots[layout.theta_at(0, p)] = theta[p];
            slots[layout.bound_at(0, ASSUMED_SIGMA, p)] = self.study.assumed_sd * self.unit_se[p];
            slots[layout.bound_at(0, TRUE_SIGMA, p)] = if cond.sd > 0.0 {
                cond.sd * self.unit_se[p]
            } else {
                f64::NAN
            };
        }
    }
}
