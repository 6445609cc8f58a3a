//! What a campaign design writes: `design.parquet` (every combination at every amount: its
//! cost, predicted and simulated measures, whether it is on the Pareto front and whether it
//! is the answer), `figures/design.svg` (the front of cost against the first target's
//! measure, with the Monte Carlo confirmations) and `report.html`.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{ArrayRef, BooleanArray, Float64Array, StringArray, UInt64Array};
use arrow::datatypes::{DataType, Field, Schema};

use super::{Campaign, CampaignPoint, CampaignResult, DesignError, describe};
use crate::design::output::{staged_figure, write_table};
use crate::design::{ANSWER_KEY, DESIGN_FILE};
use crate::figures;
use crate::output::lock::DirLock;
use crate::output::{self, FileMetadata, OutputError, PendingFile, set};
use crate::report::escape;

/// The answer in one sentence.
pub fn answer_sentence(campaign: &Campaign, result: &CampaignResult) -> String {
    let targets: Vec<String> = campaign.targets.iter().map(ToString::to_string).collect();
    match result.answer {
        Some(i) => {
            let p = &result.points[i];
            let measured: Vec<String> = campaign
                .targets
                .iter()
                .zip(p.simulated.as_deref().unwrap_or_default())
                .map(|(t, (m, s))| {
                    format!(
                        "{} {} = {m:.4e} ± {s:.1e}",
                        crate::model::vehicle::PARAMETERS[t.parameter],
                        t.measure.name()
                    )
                })
                .collect();
            format!(
                "cheapest design meeting {}: {}; Monte Carlo there: {} (MCSE). Rule: the \
                 cheapest combination whose first-order prediction holds is run by Monte \
                 Carlo, and holds when every estimate is at most its target.",
                targets.join(" and "),
                describe(campaign, p),
                measured.join(", ")
            )
        }
        None => format!(
            "no design meets {}: no combination is predicted to, or none that is is \
             confirmed by Monte Carlo",
            targets.join(" and ")
        ),
    }
}

/// Write the outputs of the search and return its result.
pub(super) fn finish(
    campaign: &Campaign,
    estimator: &str,
    points: Vec<CampaignPoint>,
    answer: Option<usize>,
    log: Vec<String>,
) -> Result<CampaignResult, DesignError> {
    let mut result = CampaignResult {
        points,
        answer,
        log,
        estimator: estimator.to_string(),
        realisations: campaign.study.realisations(),
        files: Vec::new(),
    };
    let out = &campaign.out;
    std::fs::create_dir_all(out).map_err(|e| OutputError::io(out, e))?;
    let _lock = DirLock::acquire(out)?;
    set::ensure_complete(out)?;
    let meta = FileMetadata::of_study(&campaign.study, String::new()).with(
        ANSWER_KEY,
        answer.map_or(String::new(), |i| describe(campaign, &result.points[i])),
    );
    let mut pending = vec![write_points(out, campaign, &result, &meta)?];
    pending.push(draw(out, campaign, &result)?);
    pending.push(write_report(out, campaign, &result, &pending[1])?);
    result.files = set::commit(out, pending, &|path| {
        path == DESIGN_FILE || path == "report.html" || path == "figures/design.svg"
    })?;
    let _ = std::fs::remove_dir(out.join(output::temporary_name(figures::FIGURES)));
    Ok(result)
}

fn write_points(
    out: &Path,
    campaign: &Campaign,
    result: &CampaignResult,
    meta: &FileMetadata,
) -> Result<PendingFile, OutputError> {
    let points = &result.points;
    let mut fields = vec![Field::new("combination", DataType::UInt64, false)];
    let mut columns: Vec<ArrayRef> = vec![Arc::new(UInt64Array::from_iter_values(
        points.iter().map(|p| p.combination as u64),
    ))];
    for (i, c) in campaign.choices.iter().enumerate() {
        fields.push(Field::new(c.name.clone(), DataType::Utf8, false));
        columns.push(Arc::new(StringArray::from_iter_values(
            points.iter().map(|p| c.options[p.options[i]].0.clone()),
        )));
    }
    if let Some(m) = &campaign.amount {
        fields.push(Field::new(m.key.name(), DataType::Float64, false));
        columns.push(Arc::new(Float64Array::from_iter_values(
            points.iter().map(|p| p.amount.unwrap_or(f64::NAN)),
        )));
    }
    fields.push(Field::new("cost", DataType::Float64, false));
    columns.push(Arc::new(Float64Array::from_iter_values(
        points.iter().map(|p| p.cost),
    )));
    for (t, target) in campaign.targets.iter().enumerate() {
        let name = format!(
            "{}_{}",
            crate::model::vehicle::PARAMETERS[target.parameter],
            target.measure.name()
        );
        fields.push(Field::new(
            format!("{name}_predicted"),
            DataType::Float64,
            true,
        ));
        columns.push(Arc::new(Float64Array::from_iter(
            points
                .iter()
                .map(|p| Some(p.predicted[t]).filter(|v| v.is_finite())),
        )));
        fields.push(Field::new(
            format!("{name}_simulated"),
            DataType::Float64,
            true,
        ));
        columns.push(Arc::new(Float64Array::from_iter(
            points.iter().map(|p| p.simulated.as_ref().map(|s| s[t].0)),
        )));
        fields.push(Field::new(format!("{name}_mcse"), DataType::Float64, true));
        columns.push(Arc::new(Float64Array::from_iter(
            points.iter().map(|p| p.simulated.as_ref().map(|s| s[t].1)),
        )));
    }
    fields.push(Field::new("predicted_to_hold", DataType::Boolean, false));
    columns.push(Arc::new(BooleanArray::from_iter(
        points.iter().map(|p| Some(p.predicted_to_hold(campaign))),
    )));
    fields.push(Field::new("holds", DataType::Boolean, true));
    columns.push(Arc::new(BooleanArray::from_iter(
        points.iter().map(|p| p.holds(campaign)),
    )));
    fields.push(Field::new("pareto", DataType::Boolean, false));
    columns.push(Arc::new(BooleanArray::from_iter(
        points.iter().map(|p| Some(p.pareto)),
    )));
    fields.push(Field::new("is_answer", DataType::Boolean, false));
    columns.push(Arc::new(BooleanArray::from_iter(
        (0..points.len()).map(|i| Some(result.answer == Some(i))),
    )));
    write_table(out, Arc::new(Schema::new(fields)), columns, meta)
}

fn draw(
    out: &Path,
    campaign: &Campaign,
    result: &CampaignResult,
) -> Result<PendingFile, DesignError> {
    let (path, pending) = staged_figure(out)?;
    let mut front: Vec<(f64, f64)> = result
        .points
        .iter()
        .filter(|p| p.pareto)
        .map(|p| (p.cost, p.predicted[0]))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    let simulated: Vec<(f64, f64, f64)> = result
        .points
        .iter()
        .filter_map(|p| p.simulated.as_ref().map(|s| (p.cost, s[0].0, s[0].1)))
        .collect();
    let target = &campaign.targets[0];
    let title = format!(
        "Pareto front: cost against {} of {} ({})",
        target.measure.name(),
        crate::model::vehicle::PARAMETERS[target.parameter],
        result.estimator
    );
    let y_label = format!("{} (predicted; Monte Carlo ± MCSE)", target.measure.name());
    figures::design_chart(
        &path,
        [&title, "cost", &y_label],
        &front,
        &simulated,
        target.value,
    )?;
    Ok(pending)
}

fn write_report(
    out: &Path,
    campaign: &Campaign,
    result: &CampaignResult,
    figure: &PendingFile,
) -> Result<PendingFile, OutputError> {
    let study = &campaign.study;
    let svg = std::fs::read_to_string(figure.tmp_path())
        .map_err(|e| OutputError::io(figure.tmp_path(), e))?;
    let svg = svg.find("<svg").map_or(svg.as_str(), |i| &svg[i..]);
    let mut html = crate::report::head(&format!("{} — chassis-mc design", study.name()));
    let _ = write!(
        html,
        "<p>{}</p>\n<p>seed {}, {} realisations per Monte Carlo evaluation, estimator {}, \
         chassis-mc {}</p>\n<ul>\n",
        escape(&answer_sentence(campaign, result)),
        study.seed(),
        study.realisations(),
        escape(&result.estimator),
        env!("CARGO_PKG_VERSION")
    );
    for line in &result.log {
        let _ = writeln!(html, "<li>{}</li>", escape(line));
    }
    html.push_str(
        "</ul>\n<h2>The Pareto front and the Monte Carlo runs</h2>\n<table>\n<tr><th>design</th>",
    );
    for t in &campaign.targets {
        let _ = write!(
            html,
            "<th>{} predicted</th><th>simulated ± MCSE</th>",
            escape(&t.to_string())
        );
    }
    html.push_str("<th>front</th><th>answer</th></tr>\n");
    for (i, p) in result.points.iter().enumerate() {
        if !(p.pareto || p.simulated.is_some()) {
            continue;
        }
        let _ = write!(html, "<tr><td>{}</td>", escape(&describe(campaign, p)));
        for t in 0..campaign.targets.len() {
            let sim = p.simulated.as_ref().map_or(String::new(), |s| {
                format!("{:.4e} ± {:.1e}", s[t].0, s[t].1)
            });
            let _ = write!(html, "<td>{:.4e}</td><td>{sim}</td>", p.predicted[t]);
        }
        let _ = writeln!(
            html,
            "<td>{}</td><td>{}</td></tr>",
            if p.pareto { "●" } else { "" },
            if result.answer == Some(i) { "◀" } else { "" }
        );
    }
    let _ = write!(
        html,
        "</table>\n<p>design.parquet has every combination at every amount.</p>\n<figure>\n{svg}\n\
         <figcaption>figures/design.svg</figcaption>\n</figure>\n\
         <h2>The study the choices edit</h2>\n<pre>{}</pre>\n</body>\n</html>\n",
        escape(&study.to_toml())
    );
    output::write_pending(out, "report.html", html.as_bytes())
}
