//! The report page of `fit`: report.html (docs/model.md#fit).

use std::path::Path;

use super::outputs::{budget_table, table};
use super::{FIT_FIGURE, FitRow, FitSpec, SystematicRow};
use crate::output::{self, OutputError, PendingFile};

pub(super) fn write_report(
    out: &Path,
    spec: &FitSpec,
    rows: &[FitRow],
    budget: &[SystematicRow],
    svg: &str,
) -> Result<PendingFile, OutputError> {
    use crate::report::escape;
    let title = format!("{} — chassis-mc fit", spec.log.display());
    let svg = svg.find("<svg").map_or(svg, |i| &svg[i..]);
    let html = format!(
        "{head}<p>log {log}: {n} samples, {used} in the regression; \
         acceleration {acc}; bootstrap seed {seed}, {r} realisations; chassis-mc {ver}</p>\n\
         <p class=\"warning\">The sandwich SE assumes the noise levels of [noise] and ignores the \
         estimator's bias (for M and Cd it is the delta method's); the bootstrap interval is a \
         percentile interval of the estimator in a world where the fit is the truth, so it is \
         centred on the estimate plus the bias: for a biased estimator read the bias-corrected \
         estimate with it.</p>\n\
         <figure>\n{svg}\n<figcaption>{figure}: estimate and 95 % bootstrap interval per \
         estimator{against}</figcaption>\n</figure>\n\
         {kept}<pre>{table}</pre>\n{budget}<h2>Fit file</h2>\n<pre>{text}</pre>\n</body>\n</html>\n",
        head = crate::report::head(&title),
        log = escape(&spec.log.display().to_string()),
        n = spec.cycle.t_s.len(),
        used = spec.used.iter().filter(|u| **u).count(),
        acc = spec.acceleration.name(),
        seed = spec.seed,
        r = spec.realisations,
        ver = env!("CARGO_PKG_VERSION"),
        figure = FIT_FIGURE,
        against = if spec.reference.iter().any(Option::is_some) {
            ", against the fit file's [reference] (dashed)"
        } else {
            ""
        },
        table = escape(&table(rows)),
        kept = kept_note(spec, rows),
        budget = match budget.is_empty() {
            true => String::new(),
            false => format!(
                "<h2>Systematic-error budget</h2>\n<p>How far each estimate moves when the \
                 truth has one model error of the fit file's [systematic] at its magnitude: \
                 the estimator on the noise-free rows of the world its fit defines, with the \
                 error and without it (docs/model.md#fit). No interval above includes these \
                 shifts; compare each with the interval's half-width.</p>\n<pre>{}</pre>\n",
                escape(&budget_table(budget))
            ),
        },
        text = escape(&spec.text),
    );
    output::write_pending(out, "report.html", html.as_bytes())
}

/// A warning where a bootstrap kept fewer realisations than it drew (a filter's world
/// stalled in the others): the kept ones are those whose drawn grade let the vehicle run,
/// not a sample of every world.
fn kept_note(spec: &FitSpec, rows: &[FitRow]) -> String {
    let mut short: Vec<(&str, usize)> = rows
        .iter()
        .filter(|r| (r.boot_n as u64) < spec.realisations)
        .map(|r| (r.estimator, r.boot_n))
        .collect();
    short.dedup();
    short
        .iter()
        .map(|(est, n)| {
            format!(
                "<p class=\"warning\">{est}'s bootstrap kept {n} of {} realisations: the \
                 others' worlds stalled under the logged force, so its interval is of the \
                 worlds that ran, not of every world the model draws.</p>\n",
                spec.realisations
            )
        })
        .collect()
}
