//! `design`: the smallest drive duration or terrain scale (or the largest speed-noise level)
//! at which a target on one parameter's relative RMSE, relative EmpSE or relative bias holds
//! for one estimator (see docs/model.md#design).
//!
//! The first-order predictions (the bound's SE and the first-order bias of
//! [`VehicleModel::first_order`]) on a grid of the key bracket the answer in milliseconds;
//! Monte Carlo runs of the study at the bracket's ends and by bisection then decide it. A
//! value *holds* when the Monte Carlo estimate of the measure is at most the target; the
//! answer is the smallest value that holds (the largest, for a noise level) within the
//! search's resolution of one that does not, with the measure's MCSE there.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::{ArrayRef, BooleanArray, Float64Array, RecordBatch, StringArray};
use arrow::datatypes::{DataType, Field, Schema};
use thiserror::Error;

use crate::figures::{self, FigureError};
use crate::model::Model;
use crate::model::vehicle::{PARAMETERS, VehicleModel};
use crate::output::lock::DirLock;
use crate::output::{self, FileMetadata, OutputError, ParquetSink, PendingFile, set};
use crate::run::{RunError, summarise_in_memory};
use crate::study::{Study, StudyError};

/// Points of the first-order grid over [from, to].
const GRID: usize = 25;

/// The search stops when the bracket is narrower than this fraction of [from, to] (or one
/// time step, for a duration).
const RESOLUTION: f64 = 0.01;

/// The output file of `design`.
pub const DESIGN_FILE: &str = "design.parquet";

/// The footer key holding the answer (empty when there is none in the range).
pub const ANSWER_KEY: &str = "chassis_mc.design.answer";

/// A study key `design` can vary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DesignKey {
    /// `drive.duration` \[s\] (torque drive mode): longer is better.
    Duration,
    /// `terrain.scale` (one of `terrain.scales`): more terrain variability is better.
    Scale,
    /// `noise.velocity_sd` \[m/s\]: the largest level that still meets the target.
    VelocitySd,
}

impl DesignKey {
    /// Every key, as named on the command line.
    pub const ALL: [DesignKey; 3] = [DesignKey::Duration, DesignKey::Scale, DesignKey::VelocitySd];

    /// The name on the command line and in `design.parquet`.
    pub fn name(self) -> &'static str {
        match self {
            DesignKey::Duration => "drive.duration",
            DesignKey::Scale => "terrain.scale",
            DesignKey::VelocitySd => "noise.velocity_sd",
        }
    }

    /// The key's unit.
    fn unit(self) -> &'static str {
        match self {
            DesignKey::Duration => "s",
            DesignKey::Scale => "-",
            DesignKey::VelocitySd => "m/s",
        }
    }

    /// Parse a command-line name.
    pub fn parse(text: &str) -> Result<DesignKey, String> {
        DesignKey::ALL
            .into_iter()
            .find(|k| k.name() == text)
            .ok_or_else(|| {
                let names: Vec<&str> = DesignKey::ALL.map(DesignKey::name).to_vec();
                format!("unknown key \"{text}\"; expected one of {names:?}")
            })
    }

    /// True when the answer is the largest value that holds (a noise level), false when it
    /// is the smallest.
    fn largest(self) -> bool {
        self == DesignKey::VelocitySd
    }
}

/// A measure `design` can target, as a fraction of the parameter's true value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DesignMeasure {
    /// RMSE / |θ|.
    RelRmse,
    /// EmpSE / |θ|.
    RelEmpSe,
    /// |bias| / |θ|.
    AbsRelBias,
}

impl DesignMeasure {
    const ALL: [DesignMeasure; 3] = [
        DesignMeasure::RelRmse,
        DesignMeasure::RelEmpSe,
        DesignMeasure::AbsRelBias,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DesignMeasure::RelRmse => "rel_rmse",
            DesignMeasure::RelEmpSe => "rel_emp_se",
            DesignMeasure::AbsRelBias => "abs_rel_bias",
        }
    }

    /// The measure from a bias and an SE.
    fn of(self, bias: f64, se: f64, truth: f64) -> f64 {
        match self {
            DesignMeasure::RelRmse => bias.hypot(se) / truth.abs(),
            DesignMeasure::RelEmpSe => se / truth.abs(),
            DesignMeasure::AbsRelBias => bias.abs() / truth.abs(),
        }
    }
}

/// `PARAMETER:MEASURE<=VALUE`.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignTarget {
    /// Index into θ.
    pub parameter: usize,
    /// The measure.
    pub measure: DesignMeasure,
    /// Its largest acceptable value (a fraction of the truth).
    pub value: f64,
}

impl DesignTarget {
    /// Parse `PARAMETER:MEASURE<=VALUE`.
    pub fn parse(text: &str) -> Result<DesignTarget, String> {
        let form = "expected PARAMETER:MEASURE<=VALUE, e.g. drag_over_mass:rel_rmse<=0.01";
        let (lhs, value) = text
            .split_once("<=")
            .ok_or_else(|| format!("{form}; got \"{text}\""))?;
        let (parameter, measure) = lhs
            .split_once(':')
            .ok_or_else(|| format!("{form}; got \"{text}\""))?;
        let parameter = PARAMETERS
            .iter()
            .position(|p| *p == parameter.trim())
            .ok_or_else(|| {
                format!("unknown parameter \"{parameter}\"; expected one of {PARAMETERS:?}")
            })?;
        let measure = DesignMeasure::ALL
            .into_iter()
            .find(|m| m.name() == measure.trim())
            .ok_or_else(|| {
                let names: Vec<&str> = DesignMeasure::ALL.map(DesignMeasure::name).to_vec();
                format!("unknown measure \"{measure}\"; expected one of {names:?}")
            })?;
        let value: f64 = value
            .trim()
            .parse()
            .map_err(|_| format!("the target \"{value}\" is not a number"))?;
        if !(value > 0.0 && value.is_finite()) {
            return Err(format!(
                "the target must be positive and finite, got {value}"
            ));
        }
        Ok(DesignTarget {
            parameter,
            measure,
            value,
        })
    }
}

impl fmt::Display for DesignTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}<={}",
            PARAMETERS[self.parameter],
            self.measure.name(),
            self.value
        )
    }
}

/// What to search.
#[derive(Debug, Clone)]
pub struct DesignRequest {
    /// The key varied.
    pub key: DesignKey,
    /// The range searched.
    pub from: f64,
    /// The range searched.
    pub to: f64,
    /// The target.
    pub target: DesignTarget,
    /// The estimator (a name in the study's list; `None`: its first).
    pub estimator: Option<String>,
    /// Output directory.
    pub out: PathBuf,
}

/// One evaluated value of the key.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignPoint {
    /// The key's value.
    pub value: f64,
    /// The first-order prediction of the measure.
    pub predicted: f64,
    /// The Monte Carlo estimate and its MCSE, where one was run.
    pub simulated: Option<(f64, f64)>,
}

/// What `design` found.
#[derive(Debug, Clone)]
pub struct DesignResult {
    /// Every evaluated value, in increasing order.
    pub points: Vec<DesignPoint>,
    /// The answer (`None`: the target holds nowhere in the range).
    pub answer: Option<DesignPoint>,
    /// The nearest evaluated value on the other side of the answer, which does not hold
    /// (`None`: the answer is the end of the range).
    pub neighbour: Option<f64>,
    /// How far the answer could move with the Monte Carlo error of the measure there: its
    /// MCSE divided by the slope of the predicted measure against the key (`None` where
    /// that slope is not defined).
    pub answer_sd: Option<f64>,
    /// The estimator's name.
    pub estimator: String,
    /// Realisations per Monte Carlo evaluation.
    pub realisations: u64,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// Why `design` cannot search.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DesignError {
    /// The study, or the study with the key set, is invalid.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// A Monte Carlo evaluation failed.
    #[error(transparent)]
    Run(#[from] RunError),
    /// Writing the output failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Drawing the figure failed.
    #[error(transparent)]
    Figure(#[from] FigureError),
    /// The request does not fit the study.
    #[error("{0}")]
    Request(String),
}

impl DesignError {
    /// Whether the cause is the user's input (exit status 2 at the command line): an invalid
    /// study or request, or an output directory that cannot be used as it is
    /// ([`OutputError::is_bad_input`]). A Monte Carlo evaluation that fails is a failure
    /// while running (exit status 1), whatever its cause.
    pub fn is_bad_input(&self) -> bool {
        match self {
            DesignError::Study(_) | DesignError::Request(_) => true,
            DesignError::Output(e) => e.is_bad_input(),
            DesignError::Figure(e) => e.is_bad_input(),
            DesignError::Run(_) => false,
        }
    }
}

/// The study with `key` set to `value`, and its prepared model.
struct Variant {
    study: Study,
    model: VehicleModel,
}

struct Search<'a> {
    base: &'a Study,
    request: &'a DesignRequest,
    estimator: usize,
    truth: f64,
    step: Option<f64>,
}

impl Search<'_> {
    /// `value` made valid for the key: a duration a whole number of time steps.
    fn snap(&self, value: f64) -> f64 {
        match self.step {
            Some(dt) => (value / dt).round().max(1.0) * dt,
            None => value,
        }
    }

    fn variant(&self, value: f64) -> Result<Variant, DesignError> {
        let mut table: toml::Table = toml::from_str(&self.base.to_toml())
            .map_err(|e| DesignError::Request(format!("the study as run does not parse: {e}")))?;
        let (section, key, item) = match self.request.key {
            DesignKey::Duration => ("drive", "duration", toml::Value::Float(value)),
            DesignKey::Scale => (
                "terrain",
                "scales",
                toml::Value::Array(vec![toml::Value::Float(value)]),
            ),
            DesignKey::VelocitySd => (
                "noise",
                "velocity_sd",
                toml::Value::Array(vec![toml::Value::Float(value)]),
            ),
        };
        let section = table
            .get_mut(section)
            .and_then(toml::Value::as_table_mut)
            .ok_or_else(|| {
                DesignError::Request(format!(
                    "--vary {}: the study has no [{section}] table",
                    self.request.key.name()
                ))
            })?;
        if self.request.key == DesignKey::Duration && !section.contains_key("duration") {
            return Err(DesignError::Request(
                "--vary drive.duration: the study's drive mode has no duration (a speed trace \
                 lasts as long as its log; vary it with drive.durations in a run)"
                    .into(),
            ));
        }
        section.insert(key.into(), item);
        let text = toml::to_string(&table).expect("a TOML table serialises");
        let origin = format!(
            "{} with {} = {value}",
            self.base.origin(),
            self.request.key.name()
        );
        let study = Study::from_toml_in(&text, &origin, self.base.dir())?;
        let model = VehicleModel::new(&study)?;
        if model.condition_count() != 1 {
            return Err(DesignError::Request(format!(
                "design needs a study with one condition once {} is set; this one has {} \
                 (give every other axis one level)",
                self.request.key.name(),
                model.condition_count()
            )));
        }
        Ok(Variant { study, model })
    }

    fn predicted(&self, v: &Variant) -> f64 {
        let (bias, se) = v.model.first_order(0, self.estimator);
        let p = self.request.target.parameter;
        self.request.target.measure.of(bias[p], se[p], self.truth)
    }

    fn simulated(&self, v: &Variant) -> Result<(f64, f64), DesignError> {
        let rows = summarise_in_memory(&v.study, &v.model)?;
        let p = self.request.target.parameter;
        let row = rows
            .iter()
            .find(|r| r.estimator == self.estimator && r.parameter == p)
            .expect("the summary has a row per estimator and parameter");
        let t = self.truth.abs();
        Ok(match self.request.target.measure {
            DesignMeasure::RelRmse => (row.rmse.value / t, row.rmse.mcse / t),
            DesignMeasure::RelEmpSe => (row.emp_se.value / t, row.emp_se.mcse / t),
            DesignMeasure::AbsRelBias => (row.bias.value.abs() / t, row.bias.mcse / t),
        })
    }
}

/// Search `request` on `study` (its realisations per Monte Carlo evaluation, its seed), and
/// write `design.parquet`, `figures/design.svg` and `report.html` into the output directory.
pub fn design(study: &Study, request: &DesignRequest) -> Result<DesignResult, DesignError> {
    let (from, to) = (request.from, request.to);
    if !(from.is_finite() && to.is_finite() && from > 0.0 && from < to) {
        return Err(DesignError::Request(format!(
            "--from {from} --to {to}: need 0 < from < to"
        )));
    }
    let vs = study
        .vehicle()
        .ok_or_else(|| DesignError::Request("design needs a vehicle study".into()))?;
    let names: Vec<&str> = vs.estimators.iter().map(|e| e.name()).collect();
    let estimator = match &request.estimator {
        Some(name) => names.iter().position(|n| n == name).ok_or_else(|| {
            DesignError::Request(format!(
                "--estimator {name}: the study runs {names:?}; add it to estimation.estimators"
            ))
        })?,
        None => 0,
    };
    let step = match request.key {
        DesignKey::Duration => {
            let table: toml::Table = toml::from_str(&study.to_toml()).unwrap_or_default();
            table
                .get("drive")
                .and_then(|d| d.get("time_step"))
                .and_then(toml::Value::as_float)
        }
        _ => None,
    };
    let search = Search {
        base: study,
        request,
        estimator,
        truth: vs.vehicle.theta()[request.target.parameter],
        step,
    };
    let target = request.target.value;
    let largest = request.key.largest();

    // First-order predictions on a grid bracket the answer.
    let mut points: Vec<DesignPoint> = Vec::new();
    let mut variants: Vec<(f64, Variant)> = Vec::new();
    for i in 0..GRID {
        let value = search.snap(from + (to - from) * i as f64 / (GRID - 1) as f64);
        if points.last().is_some_and(|p| p.value == value) {
            continue;
        }
        let v = search.variant(value)?;
        points.push(DesignPoint {
            value,
            predicted: search.predicted(&v),
            simulated: None,
        });
        variants.push((value, v));
    }
    let holds = |m: f64| m <= target;
    // In search order (ascending for a duration or scale, descending for a noise level):
    // the first grid value predicted to hold.
    let order: Vec<usize> = if largest {
        (0..points.len()).rev().collect()
    } else {
        (0..points.len()).collect()
    };
    let hit = order
        .iter()
        .position(|&i| holds(points[i].predicted))
        .unwrap_or(order.len() - 1);
    // good: a value known (or expected) to hold; bad: one that does not, nearer the start.
    let mut good = points[order[hit]].value;
    let mut bad = (hit > 0).then(|| points[order[hit - 1]].value);

    let mut evaluate = |value: f64, points: &mut Vec<DesignPoint>| -> Result<f64, DesignError> {
        if let Some(p) = points
            .iter()
            .find(|p| p.value == value && p.simulated.is_some())
        {
            return Ok(p.simulated.unwrap().0);
        }
        let v = match variants.iter().position(|(x, _)| *x == value) {
            Some(i) => variants.swap_remove(i).1,
            None => search.variant(value)?,
        };
        let simulated = search.simulated(&v)?;
        let predicted = search.predicted(&v);
        match points.iter_mut().find(|p| p.value == value) {
            Some(p) => p.simulated = Some(simulated),
            None => points.push(DesignPoint {
                value,
                predicted,
                simulated: Some(simulated),
            }),
        }
        Ok(simulated.0)
    };
    let start = if largest { to } else { from };
    let end = if largest { from } else { to };
    // Confirm the bracket by Monte Carlo, widening it to the range's ends where needed.
    if !holds(evaluate(good, &mut points)?) {
        bad = Some(good);
        good = search.snap(end);
        if !holds(evaluate(good, &mut points)?) {
            return finish(study, request, &search, points, None, None);
        }
    }
    if let Some(b) = bad
        && holds(evaluate(b, &mut points)?)
    {
        good = b;
        bad = None;
        let first = search.snap(start);
        if good != first {
            if holds(evaluate(first, &mut points)?) {
                good = first;
            } else {
                bad = Some(first);
            }
        }
    }
    // Bisect between the last value that fails and the first that holds.
    let resolution = (RESOLUTION * (to - from)).max(step.unwrap_or(0.0));
    while let Some(b) = bad {
        if (good - b).abs() <= resolution {
            break;
        }
        let mid = search.snap(0.5 * (good + b));
        if mid == good || mid == b {
            break;
        }
        if holds(evaluate(mid, &mut points)?) {
            good = mid;
        } else {
            bad = Some(mid);
        }
    }
    let answer = points.iter().find(|p| p.value == good).copied();
    finish(study, request, &search, points, answer, bad)
}

fn finish(
    study: &Study,
    request: &DesignRequest,
    search: &Search<'_>,
    mut points: Vec<DesignPoint>,
    answer: Option<DesignPoint>,
    neighbour: Option<f64>,
) -> Result<DesignResult, DesignError> {
    points.sort_by(|a, b| a.value.total_cmp(&b.value));
    let out = &request.out;
    std::fs::create_dir_all(out).map_err(|e| OutputError::io(out, e))?;
    let _lock = DirLock::acquire(out)?;
    set::ensure_complete(out)?;
    let mut meta = FileMetadata::of_study(study, String::new());
    meta = meta.with(
        ANSWER_KEY,
        answer.map_or(String::new(), |a| a.value.to_string()),
    );
    let mut pending = vec![write_points(out, request, &points, answer, &meta)?];
    pending.push(draw(out, request, search, &points)?);
    pending.push(write_report(
        out,
        study,
        request,
        &points,
        answer,
        neighbour,
        &pending[1],
    )?);
    let files = set::commit(out, pending, &|path| {
        path == DESIGN_FILE || path == "report.html" || path == "figures/design.svg"
    })?;
    let _ = std::fs::remove_dir(out.join(output::temporary_name(figures::FIGURES)));
    let answer_sd = answer.and_then(|a| {
        let (_, mcse) = a.simulated?;
        let i = points.iter().position(|p| p.value == a.value)?;
        let (lo, hi) = (
            &points[i.saturating_sub(1)],
            &points[(i + 1).min(points.len() - 1)],
        );
        let slope = (hi.predicted - lo.predicted) / (hi.value - lo.value);
        (slope.is_finite() && slope != 0.0).then(|| mcse / slope.abs())
    });
    Ok(DesignResult {
        points,
        answer,
        answer_sd,
        neighbour,
        estimator: study.vehicle().map_or(String::new(), |v| {
            v.estimators[search.estimator].name().to_string()
        }),
        realisations: study.realisations(),
        files,
    })
}

fn write_points(
    out: &Path,
    request: &DesignRequest,
    points: &[DesignPoint],
    answer: Option<DesignPoint>,
    meta: &FileMetadata,
) -> Result<PendingFile, OutputError> {
    let schema = Arc::new(Schema::new(vec![
        Field::new("key", DataType::Utf8, false),
        Field::new("value", DataType::Float64, false),
        Field::new("target", DataType::Utf8, false),
        Field::new("predicted", DataType::Float64, true),
        Field::new("simulated", DataType::Float64, true),
        Field::new("simulated_mcse", DataType::Float64, true),
        Field::new("is_answer", DataType::Boolean, false),
    ]));
    let n = points.len();
    let finite = |v: f64| v.is_finite().then_some(v);
    let columns: Vec<ArrayRef> = vec![
        Arc::new(StringArray::from(vec![request.key.name(); n])),
        Arc::new(Float64Array::from_iter_values(
            points.iter().map(|p| p.value),
        )),
        Arc::new(StringArray::from(vec![request.target.to_string(); n])),
        Arc::new(Float64Array::from_iter(
            points.iter().map(|p| finite(p.predicted)),
        )),
        Arc::new(Float64Array::from_iter(
            points.iter().map(|p| p.simulated.map(|s| s.0)),
        )),
        Arc::new(Float64Array::from_iter(
            points.iter().map(|p| p.simulated.map(|s| s.1)),
        )),
        Arc::new(BooleanArray::from_iter(
            points
                .iter()
                .map(|p| Some(answer.is_some_and(|a| a.value == p.value))),
        )),
    ];
    let batch =
        RecordBatch::try_new(schema.clone(), columns).map_err(|e| OutputError::arrow(out, e))?;
    let mut sink = ParquetSink::create(out, DESIGN_FILE, schema, meta, "design")?;
    sink.write(&batch)?;
    sink.finish()
}

fn draw(
    out: &Path,
    request: &DesignRequest,
    search: &Search<'_>,
    points: &[DesignPoint],
) -> Result<PendingFile, DesignError> {
    let staging = out.join(output::temporary_name(figures::FIGURES));
    std::fs::create_dir_all(&staging).map_err(|e| OutputError::io(&staging, e))?;
    let path = staging.join("design.svg");
    let predicted: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.predicted.is_finite())
        .map(|p| (p.value, p.predicted))
        .collect();
    let simulated: Vec<(f64, f64, f64)> = points
        .iter()
        .filter_map(|p| p.simulated.map(|(m, s)| (p.value, m, s)))
        .collect();
    let title = format!(
        "{} of {} ({}) against {}",
        request.target.measure.name(),
        PARAMETERS[request.target.parameter],
        search
            .base
            .vehicle()
            .map_or("", |v| v.estimators[search.estimator].name()),
        request.key.name()
    );
    let x_label = format!("{} [{}]", request.key.name(), request.key.unit());
    let y_label = format!("{} (fraction of the truth)", request.target.measure.name());
    figures::design_chart(
        &path,
        [&title, &x_label, &y_label],
        &predicted,
        &simulated,
        request.target.value,
    )?;
    Ok(PendingFile::new(
        path,
        out.join(figures::FIGURES).join("design.svg"),
    ))
}

fn write_report(
    out: &Path,
    study: &Study,
    request: &DesignRequest,
    points: &[DesignPoint],
    answer: Option<DesignPoint>,
    neighbour: Option<f64>,
    figure: &PendingFile,
) -> Result<PendingFile, OutputError> {
    use crate::report::escape;
    use std::fmt::Write as _;
    let svg = std::fs::read_to_string(figure.tmp_path())
        .map_err(|e| OutputError::io(figure.tmp_path(), e))?;
    let svg = svg.find("<svg").map_or(svg.as_str(), |i| &svg[i..]);
    let mut html = crate::report::head(&format!("{} — chassis-mc design", study.name()));
    let _ = write!(
        html,
        "<p>{}</p>\n<p>seed {}, {} realisations per Monte Carlo evaluation, chassis-mc {}</p>\n",
        escape(&answer_sentence(request, answer, None, neighbour)),
        study.seed(),
        study.realisations(),
        env!("CARGO_PKG_VERSION")
    );
    html.push_str("<table>\n<tr><th>value</th><th>predicted</th><th>simulated</th><th>MCSE</th><th>answer</th></tr>\n");
    for p in points {
        let (m, s) = p
            .simulated
            .map_or((String::new(), String::new()), |(m, s)| {
                (format!("{m:.4e}"), format!("{s:.1e}"))
            });
        let _ = writeln!(
            html,
            "<tr><td>{}</td><td>{:.4e}</td><td>{m}</td><td>{s}</td><td>{}</td></tr>",
            p.value,
            p.predicted,
            if answer.is_some_and(|a| a.value == p.value) {
                "◀"
            } else {
                ""
            }
        );
    }
    let _ = write!(
        html,
        "</table>\n<figure>\n{svg}\n<figcaption>figures/design.svg</figcaption>\n</figure>\n\
         <h2>Study as run</h2>\n<pre>{}</pre>\n</body>\n</html>\n",
        escape(&study.to_toml())
    );
    let tmp = out.join(output::temporary_name("report.html"));
    std::fs::write(&tmp, html).map_err(|e| OutputError::io(&tmp, e))?;
    Ok(PendingFile::new(tmp, out.join("report.html")))
}

/// A key value with five significant digits.
fn short(v: f64) -> String {
    let digits = 4 - v.abs().log10().floor().clamp(-10.0, 4.0) as i32;
    format!("{:.*}", digits.max(0) as usize, v)
}

/// The answer in one sentence, with the rule that decided it.
pub fn answer_sentence(
    request: &DesignRequest,
    answer: Option<DesignPoint>,
    answer_sd: Option<f64>,
    neighbour: Option<f64>,
) -> String {
    let which = if request.key.largest() {
        "largest"
    } else {
        "smallest"
    };
    match answer {
        Some(a) => {
            let (m, s) = a.simulated.unwrap_or((f64::NAN, f64::NAN));
            let bracket = neighbour.map_or("the end of the range".to_string(), |n| {
                format!("{} fails", short(n))
            });
            let sd = answer_sd.map_or(String::new(), |d| {
                format!(", ± {} from the Monte Carlo error", short(d))
            });
            format!(
                "{which} {} meeting {}: {} {} ({bracket}{sd}); there {} = {m:.4e} ± {s:.1e} \
                 (MCSE), first-order prediction {:.4e}. Rule: a value holds when the Monte \
                 Carlo estimate is at most the target.",
                request.key.name(),
                request.target,
                short(a.value),
                request.key.unit(),
                request.target.measure.name(),
                a.predicted
            )
        }
        None => format!(
            "{} holds at no {} in [{}, {}] (Monte Carlo estimate above the target at the best end)",
            request.target,
            request.key.name(),
            request.from,
            request.to
        ),
    }
}
