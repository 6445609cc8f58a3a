//! `design FILE` with a design file: the cheapest combination of priced choices that meets
//! every target (docs/model.md#design-campaign).
//!
//! A design file names the study, one or more targets (all must hold), discrete choices
//! (each a study key, or several keys at once, with options and a cost per option) and at
//! most one amount on a grid with a cost rate (`drive.duration`, `drive.runs`,
//! `terrain.scale`). `search.rs` predicts every combination's measures by the bound on the
//! amount's grid, confirms the cheapest predicted candidate by Monte Carlo (moving to the
//! next when it fails), and `output.rs` writes `design.parquet` with the Pareto front, a
//! figure and the report.

mod output;
mod search;

use std::path::{Path, PathBuf};

use super::{DesignError, DesignKey, DesignTarget};
use crate::settings::{KeyError, Params};
use crate::study::spans::KeySpans;
use crate::study::{Study, StudyError};

pub use output::answer_sentence;

/// A discrete choice: its options, each setting one or more study keys, and their costs.
#[derive(Debug, Clone, PartialEq)]
pub struct Choice {
    /// What the choice is called in tables: its key, or the keys its options set.
    pub name: String,
    /// Whether it sets one key (its options' labels are values) rather than several (its
    /// labels name the keys).
    pub keyed: bool,
    /// Per option: its label and the study keys it sets (dotted) with their values.
    pub options: Vec<(String, Vec<(String, toml::Value)>)>,
    /// The cost of each option.
    pub costs: Vec<f64>,
}

/// The amount: a key on a grid, with a cost per unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Amount {
    /// The key.
    pub key: DesignKey,
    /// Its grid, increasing.
    pub values: Vec<f64>,
    /// Cost per unit of the key.
    pub cost_rate: f64,
}

/// A design file, read.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// The file.
    pub file: PathBuf,
    /// The study it designs.
    pub study: Study,
    /// The targets, all of which must hold.
    pub targets: Vec<DesignTarget>,
    /// The estimator judged (a name in the study's list; `None`: its first).
    pub estimator: Option<String>,
    /// The discrete choices.
    pub choices: Vec<Choice>,
    /// The amount, when there is one.
    pub amount: Option<Amount>,
    /// Output directory.
    pub out: PathBuf,
}

/// Whether `text` is a design file (it has a `[design]` table) rather than a study; a text
/// that does not parse is one when a line opens `[design]` or `[[design.…` (its loader then
/// names the syntax error's line).
pub fn is_design_file(text: &str) -> bool {
    match toml::from_str::<toml::Table>(text) {
        Ok(t) => t.contains_key("design"),
        Err(_) => text.lines().any(|l| {
            let l = l.trim_start();
            l.starts_with("[design]") || l.starts_with("[design.") || l.starts_with("[[design.")
        }),
    }
}

impl Campaign {
    /// Read the design file at `path` (errors name its keys and lines).
    pub fn load(path: &Path, out: PathBuf) -> Result<Campaign, DesignError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| DesignError::Request(format!("{}: cannot read: {e}", path.display())))?;
        let origin = path.display().to_string();
        let spans = KeySpans::new(&text);
        let fail = |e: KeyError| -> DesignError {
            DesignError::Study(StudyError {
                file: origin.clone(),
                line: spans.line(&e.key),
                key: Some(e.key),
                reason: e.reason,
            })
        };
        let table: toml::Table = toml::from_str(&text).map_err(|e| {
            DesignError::Study(StudyError {
                file: origin.clone(),
                key: None,
                line: e.span().map(|s| spans.line_of(s.start)),
                reason: e.message().to_string(),
            })
        })?;
        let top = Params::new(&table, "");
        if let Some(k) = table.keys().find(|k| *k != "design") {
            return Err(fail(KeyError {
                key: k.clone(),
                reason: "a design file has one table, [design]".into(),
            }));
        }
        let design = match table.get("design") {
            Some(toml::Value::Table(t)) => t,
            _ => return Err(fail(top.error("design", "must be a table"))),
        };
        let dir = path.parent().unwrap_or(Path::new(""));
        let p = Params::new(design, "design").relative_to(dir);
        p.only(&["study", "targets", "estimator", "choices", "amount"])
            .map_err(fail)?;
        let study = Study::load(&p.file("study").map_err(fail)?)?;
        let targets = match p.value("targets").map_err(fail)? {
            toml::Value::Array(items) if !items.is_empty() => items
                .iter()
                .enumerate()
                .map(|(i, item)| {
                    let key = format!("targets[{i}]");
                    let text = item.as_str().ok_or_else(|| {
                        p.error(&key, "must be a string like \"inv_mass:rel_emp_se<=0.01\"")
                    })?;
                    let target =
                        DesignTarget::parse(text).map_err(|reason| p.error(&key, reason))?;
                    if !target.measure.of_parameter() {
                        return Err(p.error(
                            &key,
                            "a design file's targets are on the parameters' estimates; search \
                             the runs a campaign needs with `design STUDY --vary drive.runs \
                             --target 'pass_probability>=P'`",
                        ));
                    }
                    Ok(target)
                })
                .collect::<Result<Vec<_>, _>>()
                .map_err(fail)?,
            _ => {
                return Err(fail(
                    p.error("targets", "must be a non-empty list of targets"),
                ));
            }
        };
        let estimator = p
            .optional("estimator", |p, k| p.string(k))
            .map_err(fail)?
            .map(str::to_string);
        let choices = match design.get("choices") {
            None => Vec::new(),
            Some(_) => p.tables("choices", read_choice).map_err(fail)?,
        };
        let amount = match design.get("amount") {
            None => None,
            Some(toml::Value::Table(t)) => {
                Some(read_amount(&Params::new(t, "design.amount")).map_err(fail)?)
            }
            Some(_) => return Err(fail(p.error("amount", "must be a table"))),
        };
        if let Some(a) = &amount {
            check_grid(a, &study).map_err(|reason| {
                fail(KeyError {
                    key: "design.amount.step".into(),
                    reason,
                })
            })?;
        }
        if choices.is_empty() && amount.is_none() {
            return Err(fail(p.error(
                "choices",
                "is missing: a design needs at least one choice or an amount",
            )));
        }
        Ok(Campaign {
            file: path.to_path_buf(),
            study,
            targets,
            estimator,
            choices,
            amount,
            out,
        })
    }

    /// Number of combinations of the discrete choices.
    pub fn combinations(&self) -> usize {
        self.choices.iter().map(|c| c.options.len()).product()
    }

    /// The option index of each choice in combination `k` (the last choice varies
    /// fastest).
    pub fn options_of(&self, mut k: usize) -> Vec<usize> {
        let mut picks = vec![0; self.choices.len()];
        for (i, c) in self.choices.iter().enumerate().rev() {
            picks[i] = k % c.options.len();
            k /= c.options.len();
        }
        picks
    }
}

/// One `[[design.choices]]`: `key` with `options` (values), or `options` as inline tables of
/// dotted keys to values; `costs` (one per option, ≥ 0); `labels` (optional).
fn read_choice(p: &Params<'_>) -> Result<Choice, KeyError> {
    p.only(&["key", "options", "costs", "labels"])?;
    let key = p.optional("key", |p, k| p.string(k))?;
    let options = match p.value("options")? {
        toml::Value::Array(items) if !items.is_empty() => items,
        _ => return Err(p.error("options", "must be a non-empty list")),
    };
    let settings: Vec<Vec<(String, toml::Value)>> = options
        .iter()
        .enumerate()
        .map(|(j, option)| match (key, option) {
            (Some(key), value) => Ok(vec![(key.to_string(), value.clone())]),
            (None, toml::Value::Table(t)) if !t.is_empty() => {
                Ok(t.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
            }
            (None, _) => Err(p.error(
                &format!("options[{j}]"),
                "must be a table of study keys to values when the choice has no key",
            )),
        })
        .collect::<Result<_, _>>()?;
    let costs = match p.value("costs")? {
        toml::Value::Array(items) if items.len() == options.len() => items
            .iter()
            .enumerate()
            .map(|(j, c)| match c {
                toml::Value::Integer(n) if *n >= 0 => Ok(*n as f64),
                toml::Value::Float(f) if *f >= 0.0 && f.is_finite() => Ok(*f),
                _ => Err(p.error(&format!("costs[{j}]"), "must be a number >= 0")),
            })
            .collect::<Result<Vec<f64>, _>>()?,
        _ => {
            return Err(p.error(
                "costs",
                format!(
                    "must be a list of {} numbers, one per option",
                    options.len()
                ),
            ));
        }
    };
    let labels: Vec<String> = match p.optional("labels", |p, k| p.value(k))? {
        None => settings
            .iter()
            .map(|s| {
                s.iter()
                    .map(|(k, v)| match key {
                        Some(_) => value_text(v),
                        None => format!("{k} = {}", value_text(v)),
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .collect(),
        Some(toml::Value::Array(items)) if items.len() == options.len() => items
            .iter()
            .enumerate()
            .map(|(j, l)| {
                l.as_str()
                    .map(str::to_string)
                    .ok_or_else(|| p.error(&format!("labels[{j}]"), "must be a string"))
            })
            .collect::<Result<_, _>>()?,
        Some(_) => {
            return Err(p.error(
                "labels",
                format!(
                    "must be a list of {} strings, one per option",
                    options.len()
                ),
            ));
        }
    };
    let name = match key {
        Some(key) => key.to_string(),
        None => {
            let mut keys: Vec<&str> = settings.iter().flatten().map(|(k, _)| k.as_str()).collect();
            keys.sort_unstable();
            keys.dedup();
            keys.join(" + ")
        }
    };
    Ok(Choice {
        name,
        keyed: key.is_some(),
        options: labels.into_iter().zip(settings).collect(),
        costs,
    })
}

/// `[design.amount]`: `key`, `from`, `to`, `step`, `cost_rate`.
fn read_amount(p: &Params<'_>) -> Result<Amount, KeyError> {
    p.only(&["key", "from", "to", "step", "cost_rate"])?;
    let key = DesignKey::parse(p.string("key")?).map_err(|r| p.error("key", r))?;
    if !matches!(
        key,
        DesignKey::Duration | DesignKey::Runs | DesignKey::Scale
    ) {
        return Err(p.error(
            "key",
            format!(
                "must be drive.duration, drive.runs or terrain.scale (an amount whose measure \
                 improves as it grows), got {}",
                key.name()
            ),
        ));
    }
    let (from, to, step) = (p.positive("from")?, p.positive("to")?, p.positive("step")?);
    if to <= from {
        return Err(p.error("to", format!("must be above from ({from}), got {to}")));
    }
    let count = ((to - from) / step + 1e-9).floor() as usize + 1;
    if count > 1000 {
        return Err(p.error("step", format!("gives {count} values; at most 1000")));
    }
    let values = (0..count).map(|i| from + i as f64 * step).collect();
    Ok(Amount {
        key,
        values,
        cost_rate: p.non_negative("cost_rate")?,
    })
}

/// Whether every value of the amount's grid is one the key takes: a duration a whole number
/// of the study's time steps, a number of runs a multiple of its step (a run each way).
fn check_grid(amount: &Amount, study: &Study) -> Result<(), String> {
    let step = match amount.key {
        DesignKey::Duration => study.vehicle().and_then(|v| v.drive.duration_step()),
        key => key.count_step().map(|s| s as f64),
    };
    let Some(step) = step else {
        return Ok(());
    };
    match amount.values.iter().find(|v| {
        let k = (*v / step).round();
        k < 1.0 || (k * step - *v).abs() > 1e-9 * v.abs()
    }) {
        Some(v) => Err(format!(
            "gives {} = {v}, which is not a whole multiple of {step} (the study's step of the \
             key): choose from and step as multiples of it",
            amount.key.name()
        )),
        None => Ok(()),
    }
}

/// A TOML value as a label: a string without its quotes.
fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// One evaluated design: a combination of options at an amount.
#[derive(Debug, Clone, PartialEq)]
pub struct CampaignPoint {
    /// The combination's index (the last choice varies fastest).
    pub combination: usize,
    /// The option of each choice.
    pub options: Vec<usize>,
    /// The amount (`None` without one).
    pub amount: Option<f64>,
    /// The options' costs plus the amount's.
    pub cost: f64,
    /// Per target, the first-order prediction of its measure (the bound's SE, the
    /// first-order bias).
    pub predicted: Vec<f64>,
    /// Per target, the Monte Carlo estimate of its measure and its MCSE, where one was run.
    pub simulated: Option<Vec<(f64, f64)>>,
    /// Whether no other point is at most as costly with at most the first target's
    /// predicted measure (one of them strictly less).
    pub pareto: bool,
}

impl CampaignPoint {
    /// Whether every target is predicted to hold.
    pub fn predicted_to_hold(&self, campaign: &Campaign) -> bool {
        self.predicted
            .iter()
            .zip(&campaign.targets)
            .all(|(m, t)| *m <= t.value)
    }

    /// Whether the Monte Carlo estimate of every target is at most its value (`None`
    /// without a Monte Carlo run).
    pub fn holds(&self, campaign: &Campaign) -> Option<bool> {
        self.simulated.as_ref().map(|s| {
            s.iter()
                .zip(&campaign.targets)
                .all(|((m, _), t)| *m <= t.value)
        })
    }
}

/// What the campaign's search found.
#[derive(Debug, Clone)]
pub struct CampaignResult {
    /// Every combination at every amount, combination-major.
    pub points: Vec<CampaignPoint>,
    /// The answer's index in `points` (`None`: no candidate was confirmed).
    pub answer: Option<usize>,
    /// What happened to each candidate confirmed by Monte Carlo, in order.
    pub log: Vec<String>,
    /// The estimator judged.
    pub estimator: String,
    /// Realisations per Monte Carlo evaluation.
    pub realisations: u64,
    /// Files written.
    pub files: Vec<std::path::PathBuf>,
}

/// Search `campaign` and write its outputs: `design.parquet`, `figures/design.svg`,
/// `report.html`.
pub fn campaign(campaign: &Campaign) -> Result<CampaignResult, DesignError> {
    let (points, answer, log, estimator) = search::search(campaign)?;
    output::finish(campaign, &estimator, points, answer, log)
}

/// The cost of the options `picks` at `amount`.
pub(crate) fn cost(campaign: &Campaign, picks: &[usize], amount: Option<f64>) -> f64 {
    let fixed: f64 = campaign
        .choices
        .iter()
        .zip(picks)
        .map(|(c, &j)| c.costs[j])
        .sum();
    fixed
        + amount.map_or(0.0, |a| {
            a * campaign.amount.as_ref().map_or(0.0, |m| m.cost_rate)
        })
}

/// A point in words: its options and amount.
pub(crate) fn describe(campaign: &Campaign, p: &CampaignPoint) -> String {
    let mut parts: Vec<String> = campaign
        .choices
        .iter()
        .zip(&p.options)
        .map(|(c, &j)| match c.keyed {
            true => format!("{} = {}", c.name, c.options[j].0),
            false => c.options[j].0.clone(),
        })
        .collect();
    if let (Some(a), Some(m)) = (p.amount, &campaign.amount) {
        parts.push(format!("{} = {a}", m.key.name()));
    }
    format!("{} (cost {})", parts.join(", "), p.cost)
}
