//! What `design` writes: `design.parquet` (every evaluated value), `figures/design.svg`,
//! `report.html`, and the answer in one sentence.

use std::path::Path;
use std::sync::Arc;

use arrow::array::{ArrayRef, BooleanArray, Float64Array, RecordBatch, StringArray};
use arrow::datatypes::{DataType, Field, Schema};

use super::{
    ANSWER_KEY, DESIGN_FILE, DesignError, DesignKey, DesignPoint, DesignRequest, DesignResult,
    largest,
};
use crate::figures;
use crate::model::vehicle::PARAMETERS;
use crate::output::lock::DirLock;
use crate::output::{self, FileMetadata, OutputError, ParquetSink, PendingFile, set};
use crate::study::Study;

/// Sort the evaluated values, write the outputs and measure the answer's Monte Carlo
/// spread.
pub(super) fn finish(
    study: &Study,
    request: &DesignRequest,
    estimator: &str,
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
    pending.push(draw(out, request, estimator, &points)?);
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
        estimator: estimator.to_string(),
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
    write_table(out, schema, columns, meta)
}

/// `design.parquet` of `columns` under `schema`, staged.
pub(crate) fn write_table(
    out: &Path,
    schema: Arc<Schema>,
    columns: Vec<ArrayRef>,
    meta: &FileMetadata,
) -> Result<PendingFile, OutputError> {
    let batch =
        RecordBatch::try_new(schema.clone(), columns).map_err(|e| OutputError::arrow(out, e))?;
    let mut sink = ParquetSink::create(out, DESIGN_FILE, schema, meta, "design")?;
    sink.write(&batch)?;
    sink.finish()
}

/// Where `figures/design.svg` is drawn before it is committed, and the staged file.
pub(crate) fn staged_figure(out: &Path) -> Result<(std::path::PathBuf, PendingFile), OutputError> {
    let dir = out.join(output::temporary_name(figures::FIGURES));
    std::fs::create_dir_all(&dir).map_err(|e| OutputError::io(&dir, e))?;
    let path = dir.join("design.svg");
    let pending = PendingFile::new(path.clone(), out.join(figures::FIGURES).join("design.svg"));
    Ok((path, pending))
}

fn draw(
    out: &Path,
    request: &DesignRequest,
    estimator: &str,
    points: &[DesignPoint],
) -> Result<PendingFile, DesignError> {
    let (path, pending) = staged_figure(out)?;
    let predicted: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.predicted.is_finite())
        .map(|p| (p.value, p.predicted))
        .collect();
    let simulated: Vec<(f64, f64, f64)> = points
        .iter()
        .filter_map(|p| p.simulated.map(|(m, s)| (p.value, m, s)))
        .collect();
    let measure = request.target.measure;
    let title = match measure.of_parameter() {
        true => format!(
            "{} of {} ({}) against {}",
            measure.name(),
            PARAMETERS[request.target.parameter],
            estimator,
            request.key.name()
        ),
        false => format!("{} against {}", measure.name(), request.key.name()),
    };
    let x_label = format!("{} [{}]", request.key.name(), request.key.unit());
    let y_label = match measure.of_parameter() {
        true => format!("{} (fraction of the truth)", measure.name()),
        false => measure.name().to_string(),
    };
    figures::design_chart(
        &path,
        [&title, &x_label, &y_label],
        &predicted,
        &simulated,
        request.target.value,
    )?;
    Ok(pending)
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
    output::write_pending(out, "report.html", html.as_bytes())
}

/// A value of `key`: a count (the number of runs) as the whole number it is, any other
/// value with five significant digits.
fn value_text(key: DesignKey, v: f64) -> String {
    match key.count_step() {
        Some(_) => format!("{v}"),
        None => short(v),
    }
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
    let which = if largest(request.key) {
        "largest"
    } else {
        "smallest"
    };
    match answer {
        Some(a) => {
            let (m, s) = a.simulated.unwrap_or((f64::NAN, f64::NAN));
            let bracket = neighbour.map_or("the end of the range".to_string(), |n| {
                format!("{} fails", value_text(request.key, n))
            });
            let sd = answer_sd.map_or(String::new(), |d| {
                format!(", ± {} from the Monte Carlo error", short(d))
            });
            // A probability as one, a parameter's measure in scientific notation.
            let (m, s) = match request.target.measure.of_parameter() {
                true => (format!("{m:.4e}"), format!("{s:.1e}")),
                false => (format!("{m:.4}"), format!("{s:.4}")),
            };
            format!(
                "{which} {} meeting {}: {} {} ({bracket}{sd}); there {} = {m} ± {s} \
                 (MCSE), {}. Rule: a value holds when the Monte Carlo estimate is {} the \
                 target.",
                request.key.name(),
                request.target,
                value_text(request.key, a.value),
                request.key.unit(),
                request.target.measure.name(),
                match a.predicted.is_nan() {
                    true => "no first-order prediction (decided by Monte Carlo alone)".to_string(),
                    false => format!("first-order prediction {:.4e}", a.predicted),
                },
                match request.target.measure.of_parameter() {
                    true => "at most",
                    false => "at least",
                }
            )
        }
        None => format!(
            "{} holds at no {} in [{}, {}] (Monte Carlo estimate {} the target at the best end)",
            request.target,
            request.key.name(),
            request.from,
            request.to,
            match request.target.measure.of_parameter() {
                true => "above",
                false => "below",
            }
        ),
    }
}
