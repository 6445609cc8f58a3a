//! The condition's posterior Cramér–Rao bound of the filters' model (`pcrlb_*` metrics of
//! the summary): the recursion with each expectation the mean over the condition's truths
//! (docs/model.md#pcrlb).

use std::borrow::Cow;
use std::sync::Arc;

use super::world::World;
use crate::estimate::channels::NoiseLevels;
use crate::estimate::estimators::EstimatorSettings;
use crate::estimate::filtering::{PCRLB_INV_MASS, TrueGrades, true_grades};
use crate::estimate::filters::{CHECKPOINTS_S, TruePath, pcrlb};
use crate::estimate::regression::Regression;
use crate::study::VehicleStudy;

/// The truths the bound averages over where every realisation has its own: those of
/// realisations 0 … 99 (the same whatever R, so that an extension keeps the bound).
pub(super) const TRUTHS: u64 = 100;

/// The metrics' names: the bound's SD of 1/M and of the grade at the last row, then at
/// each of [`CHECKPOINTS_S`], then M's at the last row by the delta method.
pub(super) const METRICS: [&str; 9] = [
    PCRLB_INV_MASS,
    "pcrlb_grade",
    "pcrlb_inv_mass_60s",
    "pcrlb_inv_mass_120s",
    "pcrlb_inv_mass_300s",
    "pcrlb_grade_60s",
    "pcrlb_grade_120s",
    "pcrlb_grade_300s",
    "pcrlb_mass",
];

/// A truth's path: its regression's rows (the condition's, or a realisation's own), their
/// true grade and 1/M.
struct Path<'a> {
    reg: Cow<'a, Regression>,
    grade: Arc<TrueGrades>,
    inv_mass: f64,
}

impl<'a> Path<'a> {
    fn new(reg: Cow<'a, Regression>, inv_mass: f64) -> Path<'a> {
        Path {
            grade: true_grades(&reg),
            reg,
            inv_mass,
        }
    }

    fn view(&self) -> TruePath<'_> {
        TruePath {
            t: &self.reg.t,
            v: &self.reg.v,
            grade: &self.grade.0,
            force: &self.reg.f,
            inv_mass: self.inv_mass,
        }
    }
}

/// The metrics of a condition with `settings`, `regression` and `noise`: along its one truth, or the
/// mean over the first [`TRUTHS`] of its `world`'s (drawn from (`seed`, `key`); those that
/// cannot be simulated, or whose rows differ from the first's, left out). NaN where the
/// bound is undefined (no speed noise, or the information singular).
pub(super) fn metrics(
    vs: &VehicleStudy,
    settings: &EstimatorSettings,
    regression: &Regression,
    world: Option<&World>,
    noise: &NoiseLevels,
    (seed, key): (u64, u64),
) -> [f64; METRICS.len()] {
    let settings = &settings.filter;
    let model = settings.model(regression.k, regression.g, noise.speed_sd());
    let inv_mass = 1.0 / vs.vehicle.mass_kg;
    let paths: Vec<Path> = match world {
        None => vec![Path::new(Cow::Borrowed(regression), inv_mass)],
        Some(world) => (0..TRUTHS)
            .filter_map(|r| world.regression(vs, regression, (seed, key, r)).ok())
            .map(|(reg, own)| Path::new(Cow::Owned(reg), own.unwrap_or(inv_mass)))
            .collect(),
    };
    let Some(first) = paths.first() else {
        return [f64::NAN; METRICS.len()];
    };
    let views: Vec<TruePath<'_>> = paths
        .iter()
        .filter(|p| p.reg.t[..] == first.reg.t[..])
        .map(Path::view)
        .collect();
    let Ok(bound) = pcrlb::bound(&model, &settings.prior, &views) else {
        return [f64::NAN; METRICS.len()];
    };
    let mut out = [f64::NAN; METRICS.len()];
    out[0] = bound.end.inv_mass_var.sqrt();
    // M = 1/θ₁ by the delta method, (M̂ − M)² ≈ M⁴(θ̂₁ − θ₁)², averaged over the truths:
    // SD(1/M)·√(mean M⁴) (SD(1/M)·M² where they share M).
    let mean_m4 = views.iter().map(|v| v.inv_mass.powi(-4)).sum::<f64>() / views.len() as f64;
    out[2 + 2 * CHECKPOINTS_S.len()] = out[0] * mean_m4.sqrt();
    out[1] = bound.end.grade_var.sqrt();
    for (i, c) in bound.checkpoints.iter().enumerate() {
        if let Some(c) = c {
            out[2 + i] = c.inv_mass_var.sqrt();
            out[2 + CHECKPOINTS_S.len() + i] = c.grade_var.sqrt();
        }
    }
    out
}
