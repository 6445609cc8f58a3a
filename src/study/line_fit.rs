//! The line-fit example: its validated settings ([`LineFitStudy`]) and their validation from
//! `[line_fit]`.

use super::checker::Checker;
use super::estimation::validate_estimators;
use super::raw::RawStudy;
use super::{MAX_SAMPLES, StudyError};
use crate::estimate::estimators::{EstimatorRef, Ols};

/// Shape of the measurement noise of the line-fit example.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseShape {
    /// Uniform on \[−√3 σ, √3 σ\] (the thesis's `18*(rand − 0.5)` has σ = 18/√12 = 5.196).
    Uniform,
    /// Normal N(0, σ²).
    Gaussian,
}

impl NoiseShape {
    /// All noise shapes.
    pub const ALL: [NoiseShape; 2] = [NoiseShape::Uniform, NoiseShape::Gaussian];

    pub(super) fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The name used in study files and output columns.
    pub fn name(self) -> &'static str {
        match self {
            NoiseShape::Uniform => "uniform",
            NoiseShape::Gaussian => "gaussian",
        }
    }
}

/// The validated worked example of thesis §3.2–3.3: y = θ₁ + θ₂ t with i.i.d. noise.
#[derive(Debug, Clone, PartialEq)]
pub struct LineFitStudy {
    /// True intercept θ₁.
    pub intercept: f64,
    /// True slope θ₂.
    pub slope: f64,
    /// Sample times t_i.
    pub times: Vec<f64>,
    /// The σ the bound assumes (the thesis uses 7.5).
    pub assumed_sd: f64,
    /// Noise shapes, one condition axis.
    pub noise: Vec<NoiseShape>,
    /// True noise standard deviations, one condition axis.
    pub noise_sd: Vec<f64>,
}

pub(super) fn validate(raw: &RawStudy, c: &Checker<'_>) -> Result<LineFitStudy, StudyError> {
    let l = raw
        .line_fit
        .as_ref()
        .ok_or_else(|| c.missing_table("line_fit"))?;
    if let Some(e) = &raw.estimation {
        validate_estimators(&e.estimators, &[EstimatorRef(&Ols)], c)?;
        if e.forgetting.is_some() {
            return Err(c.fail(
                "estimation.forgetting",
                "applies to the vehicle model's rls estimator only",
            ));
        }
        if e.acceleration.is_some() {
            return Err(c.fail(
                "estimation.acceleration",
                "applies to the vehicle model only",
            ));
        }
    }
    let t_start = c.finite("line_fit.t_start", l.t_start)?;
    let t_step = c.positive("line_fit.t_step", l.t_step)?;
    let t_end = c.finite("line_fit.t_end", l.t_end)?;
    let span = (t_end - t_start) / t_step;
    let steps = span.round();
    if steps < 1.0 || (steps - span).abs() > 1e-9 * span.abs().max(1.0) {
        return Err(c.fail(
            "line_fit.t_end",
            format!(
                "must lie a whole number (≥ 1) of t_step = {t_step} after t_start = {t_start}, got {t_end}"
            ),
        ));
    }
    if steps + 1.0 > MAX_SAMPLES as f64 {
        return Err(c.fail("line_fit.t_step", "gives too many samples"));
    }
    let times = (0..=steps as usize)
        .map(|i| t_start + i as f64 * t_step)
        .collect();
    if l.noise.is_empty() {
        return Err(c.fail("line_fit.noise", "must list at least one noise shape"));
    }
    let mut noise = Vec::new();
    for (i, name) in l.noise.iter().enumerate() {
        let shape = NoiseShape::parse(name).ok_or_else(|| {
            let names: Vec<String> = NoiseShape::ALL
                .iter()
                .map(|s| format!("\"{}\"", s.name()))
                .collect();
            c.fail(
                &format!("line_fit.noise[{i}]"),
                format!("unknown noise \"{name}\"; expected {}", names.join(" or ")),
            )
        })?;
        noise.push(shape);
    }
    Ok(LineFitStudy {
        intercept: c.finite("line_fit.intercept", l.intercept)?,
        slope: c.finite("line_fit.slope", l.slope)?,
        times,
        assumed_sd: c.positive("line_fit.assumed_sd", l.assumed_sd)?,
        noise,
        noise_sd: c.list("line_fit.noise_sd", &l.noise_sd, Checker::non_negative)?,
    })
}
