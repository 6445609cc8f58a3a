//! `[truth]`: how the simulated vehicle differs from the regression's equation
//! (docs/model.md#model-errors; README, "Study file keys"). One key per entry of
//! [`MODEL_ERRORS`]; an axis entry takes a list of values, one condition each.

use super::StudyError;
use super::checker::Checker;
use super::checker::unknown_key;
use crate::dynamics::Truth;
use crate::dynamics::filter_truth::{FilterTruth, InvMassPrior};
use crate::dynamics::truth::{MODEL_ERROR_COUNT, MODEL_ERRORS, entry_index};
use crate::estimate::filters::Prior;
use crate::terrain::TerrainSpec;

/// The validated `[truth]` table: the values listed for each entry of [`MODEL_ERRORS`] (its
/// neutral value alone when the key is absent; one value for an entry that is not an axis).
#[derive(Debug, Clone, PartialEq)]
pub struct TruthAxes([Vec<f64>; MODEL_ERROR_COUNT]);

impl TruthAxes {
    /// Set entry `i`'s levels (a value the study implies rather than lists: a road-load
    /// vehicle's B/A).
    pub(super) fn set(&mut self, i: usize, levels: Vec<f64>) {
        self.0[i] = levels;
    }
}

impl Default for TruthAxes {
    /// The truth is the equation: every entry at its neutral value.
    fn default() -> Self {
        TruthAxes(MODEL_ERRORS.map(|e| vec![e.neutral]))
    }
}

impl TruthAxes {
    /// One truth: each entry of [`MODEL_ERRORS`] at its value in `values` (trusted: the
    /// caller has checked each with the entry's `check`).
    pub fn single(values: [f64; MODEL_ERROR_COUNT]) -> TruthAxes {
        TruthAxes(values.map(|v| vec![v]))
    }

    /// The values of entry `i` of [`MODEL_ERRORS`].
    pub fn levels(&self, i: usize) -> &[f64] {
        &self.0[i]
    }

    /// Number of distinct truths: the product of the entries' numbers of values.
    pub fn combinations(&self) -> usize {
        self.0.iter().map(Vec::len).product()
    }

    /// The index of the truth whose entries are at levels `levels` (the last entry
    /// fastest, as the condition axes nest).
    pub fn index(&self, levels: &[usize; MODEL_ERROR_COUNT]) -> usize {
        self.0
            .iter()
            .zip(levels)
            .fold(0, |index, (values, &l)| index * values.len() + l)
    }

    /// The values of truth `index` (of [`TruthAxes::index`]), per entry.
    pub fn values(&self, index: usize) -> [f64; MODEL_ERROR_COUNT] {
        let mut out = [0.0; MODEL_ERROR_COUNT];
        let mut rest = index;
        for (i, values) in self.0.iter().enumerate().rev() {
            out[i] = values[rest % values.len()];
            rest /= values.len();
        }
        out
    }

    /// The model errors of truth `index`.
    pub fn truth(&self, index: usize) -> Truth {
        Truth::from_values(&self.values(index))
    }
}

/// The keys of `[truth]`, in entry order.
pub(super) fn truth_keys() -> [&'static str; MODEL_ERROR_COUNT] {
    MODEL_ERRORS.map(|e| e.key)
}

/// Validate `[truth]` (absent: the truth is the equation).
pub(super) fn validate_truth(
    table: Option<&toml::Table>,
    c: &Checker<'_>,
) -> Result<TruthAxes, StudyError> {
    let mut axes = TruthAxes::default();
    let Some(table) = table else {
        return Ok(axes);
    };
    let keys = truth_keys();
    let known = |k: &str| keys.contains(&k) || FILTER_TRUTH_KEYS.contains(&k);
    if let Some(k) = table.keys().find(|k| !known(k)) {
        let mut all = keys.to_vec();
        all.extend(FILTER_TRUTH_KEYS);
        return Err(unknown_key(c, "truth", k, all, None));
    }
    for (i, entry) in MODEL_ERRORS.iter().enumerate() {
        let Some(value) = table.get(entry.key) else {
            continue;
        };
        let key = format!("truth.{}", entry.key);
        if !entry.axis && value.is_array() {
            return Err(c.fail(&key, "takes one number (it is not an axis), got a list"));
        }
        let numbers = c.numbers(&key, value)?;
        axes.0[i] = c.list(&key, &numbers, |c, k, v| match (entry.check)(v) {
            Some(reason) => Err(c.fail(k, format!("{reason}, got {}", crate::settings::shown(v)))),
            None => Ok(v),
        })?;
    }
    // A parameter of another entry without that entry on does nothing: say so.
    let gusts = entry_index("wind_gust_sd").expect("an entry");
    if table.contains_key("wind_gust_time") && axes.0[gusts].iter().all(|&s| s == 0.0) {
        return Err(c.fail(
            "truth.wind_gust_time",
            "is the gusts' correlation time, but truth.wind_gust_sd lists no level above 0",
        ));
    }
    Ok(axes)
}

/// Validate a fit file's `[systematic]` (absent: empty): the keys of `[truth]`, one number
/// each, checked as `[truth]` checks it. Returns (index into [`MODEL_ERRORS`], magnitude)
/// of each key given, in the order of [`MODEL_ERRORS`] (docs/model.md#fit).
pub(super) fn validate_systematic(
    table: Option<&toml::Table>,
    c: &Checker<'_>,
) -> Result<Vec<(usize, f64)>, StudyError> {
    let Some(table) = table else {
        return Ok(Vec::new());
    };
    // The steady entries: a budget is what the estimate settles on under each, and an
    // entry drawn anew in every realisation moves the spread instead.
    let keys: Vec<&str> = MODEL_ERRORS
        .iter()
        .filter(|e| !e.drawn)
        .map(|e| e.key)
        .collect();
    if let Some(k) = table.keys().find(|k| !keys.contains(&k.as_str())) {
        if MODEL_ERRORS.iter().any(|e| e.drawn && e.key == k) {
            return Err(c.fail(
                &format!("systematic.{k}"),
                format!(
                    "is drawn anew in every realisation, so it moves the estimate's spread, \
                     not where it settles; a systematic budget takes the steady model errors \
                     {keys:?}"
                ),
            ));
        }
        return Err(unknown_key(c, "systematic", k, keys, None));
    }
    let mut out = Vec::new();
    for (i, entry) in MODEL_ERRORS.iter().enumerate() {
        let Some(value) = table.get(entry.key) else {
            continue;
        };
        let key = format!("systematic.{}", entry.key);
        let one = match value {
            toml::Value::Float(x) => *x,
            toml::Value::Integer(n) => *n as f64,
            other => {
                return Err(c.fail(
                    &key,
                    format!("takes one number (the magnitude of the model error), got {other}"),
                ));
            }
        };
        if let Some(reason) = (entry.check)(one) {
            return Err(c.fail(
                &key,
                format!("{reason}, got {}", crate::settings::shown(one)),
            ));
        }
        out.push((i, one));
    }
    Ok(out)
}

/// `[truth]`'s keys of a truth that follows the filters' model (not model errors).
pub(super) const FILTER_TRUTH_KEYS: [&str; 2] = ["speed_process_sd", "mass_from_prior"];

/// A truth that follows the filters' model (docs/model.md#filter-truth):
/// `truth.speed_process_sd` (≥ 0 m/s per step, one number), `truth.mass_from_prior` (the
/// filters' prior `prior`), the walk of a `random_walk` terrain; only in the drive mode
/// `torque` (whose force does not depend on the motion) and without model errors.
pub(super) fn validate_filter_truth(
    table: Option<&toml::Table>,
    terrain: Option<&TerrainSpec>,
    prior: Prior,
    mode: &str,
    model_errors: &TruthAxes,
    c: &Checker<'_>,
) -> Result<FilterTruth, StudyError> {
    let speed_process_sd = match table.and_then(|t| t.get("speed_process_sd")) {
        None => 0.0,
        Some(toml::Value::Float(v)) => c.non_negative("truth.speed_process_sd", *v)?,
        Some(toml::Value::Integer(v)) => c.non_negative("truth.speed_process_sd", *v as f64)?,
        Some(_) => {
            return Err(c.fail(
                "truth.speed_process_sd",
                "must be one number (m/s per step), not a list",
            ));
        }
    };
    let mass_from_prior = match table.and_then(|t| t.get("mass_from_prior")) {
        None => false,
        Some(toml::Value::Boolean(b)) => *b,
        Some(_) => return Err(c.fail("truth.mass_from_prior", "must be true or false")),
    };
    let truth = FilterTruth {
        speed_process_sd,
        mass_prior: mass_from_prior.then(|| InvMassPrior {
            mean: prior.inv_mass(),
            sd: prior.inv_mass_var().sqrt(),
        }),
        grade_walk: terrain.and_then(|t| t.profile.grade_walk()),
    };
    if !truth.is_drawn() {
        return Ok(truth);
    }
    let key = match () {
        _ if speed_process_sd > 0.0 => "truth.speed_process_sd",
        _ if mass_from_prior => "truth.mass_from_prior",
        _ => "terrain.profile",
    };
    if mode != "torque" {
        return Err(c.fail(
            key,
            format!(
                "a truth that follows the filters' model needs drive.mode = \"torque\" (a force \
                 that does not depend on the motion), got \"{mode}\""
            ),
        ));
    }
    if let Some(entry) = MODEL_ERRORS
        .iter()
        .zip(&model_errors.0)
        .find(|(e, values)| values.iter().any(|&v| v != e.neutral))
        .map(|(e, _)| e)
    {
        return Err(c.fail(
            key,
            format!(
                "a truth that follows the filters' model has no model errors, but truth.{} is set",
                entry.key
            ),
        ));
    }
    Ok(truth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_truth_index_round_trips_through_its_levels() {
        let mut axes = TruthAxes::default();
        axes.0[0] = vec![0.0, 1.0, 2.0];
        axes.0[4] = vec![1.0, 1.1];
        assert_eq!(axes.combinations(), 6);
        let mut levels = [0; MODEL_ERROR_COUNT];
        levels[0] = 2;
        levels[4] = 1;
        let i = axes.index(&levels);
        assert_eq!(i, 5);
        assert_eq!(axes.values(i)[0], 2.0);
        assert_eq!(axes.values(i)[4], 1.1);
    }
}
