//! `report.html`: one self-contained page per output directory (no network, figures inline)
//! with the study, its provenance, the per-condition table, the figures and plain-language
//! warnings where a number is easy to misread.

use crate::stats::summary::Measure;
use std::fmt::Write as _;

use crate::model::{ConditionInfo, Layout};
use crate::output::FileMetadata;
use crate::stats::summary::SummaryRow;

use super::warnings::{model_error_warnings, warnings};

/// What a report page shows.
#[derive(Debug, Clone, Copy)]
pub struct Page<'a> {
    /// What wrote the directory, e.g. `run`.
    pub command: &'a str,
    /// The study's name.
    pub study_name: &'a str,
    /// The footer metadata of the directory's files (study as run, seed, R, identity).
    pub meta: &'a FileMetadata,
    /// The row layout.
    pub layout: &'a Layout,
    /// Every condition.
    pub infos: &'a [ConditionInfo],
    /// The summary rows.
    pub summary: &'a [SummaryRow],
    /// The figures: file name and SVG text, inlined in this order.
    pub figures: &'a [(String, String)],
}

/// `text` with `&`, `<`, `>` and `"` escaped for HTML.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
    out
}

/// An SVG document as an inline element: without its XML declaration.
fn inline_svg(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => svg,
    }
}

/// The start of every report page, up to and including its `<h1>`: the document head with
/// the one stylesheet of all report pages (`run`, `design`, `fit`).
pub fn head(title: &str) -> String {
    let title = escape(title);
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n{}\n<title>{title}</title>\n\
         <style>body{{font-family:sans-serif;max-width:72rem;margin:2rem auto;padding:0 1rem;line-height:1.4}}\
         pre{{background:#f6f6f6;padding:.75rem;overflow-x:auto;font-size:.8rem}}\
         .warning{{background:#fff4e0;border-left:4px solid #e69500;padding:.5rem .75rem;margin:.5rem 0}}\
         figure{{margin:1rem 0}}figure svg{{max-width:100%;height:auto}}\
         figcaption{{font-size:.85rem;color:#444}}td,th{{padding:.1rem .6rem}}\
         table.meta td{{padding:.1rem .75rem .1rem 0}}\
         table.vehicle{{border-collapse:collapse;font-size:.85rem}}\
         table.vehicle td{{text-align:right;border-top:1px solid #ddd}}</style>\n</head>\n<body>\n<h1>{title}</h1>\n",
        crate::output::REPORT_MARK
    )
}

/// The page, as well-formed XHTML-compatible HTML5.
/// The per-condition table (as printed after a run) and the vehicle parameters list the
/// same conditions ([`listed_conditions`](super::listed_conditions)), chosen once here.
pub fn page(p: &Page<'_>) -> String {
    let listed = super::listed_conditions(p.layout, p.infos, p.summary);
    let mut out = head(&format!("{} — chassis-mc {}", p.study_name, p.command));
    // Provenance.
    let _ = write!(
        out,
        "<h2>Provenance</h2>\n<table class=\"meta\">\n\
         <tr><td>study</td><td>{}</td></tr>\n\
         <tr><td>chassis-mc version</td><td>{}</td></tr>\n\
         <tr><td>seed</td><td>{}</td></tr>\n\
         <tr><td>realisations per condition (R)</td><td>{}</td></tr>\n\
         <tr><td>conditions</td><td>{}</td></tr>\n\
         <tr><td>identity</td><td><code>{:016x}</code> (FNV-1a of the study as run and the \
         engine's numbers; a resumed or extended run must match it)</td></tr>\n</table>\n",
        escape(p.study_name),
        escape(env!("CARGO_PKG_VERSION")),
        p.meta.seed,
        p.meta.realisations,
        p.infos.len(),
        fnv1a(&p.meta.identity)
    );
    // Warnings.
    let mut warnings = warnings(p.layout, p.infos, p.summary);
    if shares_draws(&p.meta.study_toml) {
        warnings.push(
            "The terrain scales share their noise draws (noise.share_across_scales): their \
             estimates move together, so a bias flag seen at several scales can be one chance \
             excursion of the shared draws rather than a pattern; differences between scales \
             are measured sharply, but their MCSEs are not the per-scale ones \
             (docs/model.md#shared-noise)."
                .to_string(),
        );
    }
    warnings.extend(model_error_warnings(p.layout, p.infos, p.summary, &listed));
    if !warnings.is_empty() {
        out.push_str("<h2>Read with care</h2>\n");
        for w in &warnings {
            let _ = writeln!(out, "<p class=\"warning\">{}</p>", escape(w));
        }
    }
    out.push_str(&super::fleet::section(p.layout, p.infos, p.summary));
    out.push_str(&vehicle_parameters(p.layout, p.infos, p.summary, &listed));
    out.push_str(&super::identification::section(p.layout, p.infos, &listed));
    // Figures.
    if !p.figures.is_empty() {
        out.push_str("<h2>Figures</h2>\n");
        for (name, svg) in p.figures {
            let _ = write!(
                out,
                "<figure>\n{}\n<figcaption>figures/{}</figcaption>\n</figure>\n",
                inline_svg(svg),
                escape(name)
            );
        }
    }
    let what = if listed.len() < p.infos.len() {
        format!("{} of {} conditions", listed.len(), p.infos.len())
    } else {
        format!("{} conditions", p.infos.len())
    };
    let _ = write!(
        out,
        "<h2>Per condition</h2>\n<details><summary>the table printed after the run \
         ({what})</summary>\n<pre>{}</pre>\n</details>\n",
        escape(super::table_of(p.layout, p.infos, p.summary, &listed).trim_matches('\n'))
    );
    let _ = write!(
        out,
        "<h2>Study as run</h2>\n<pre>{}</pre>\n</body>\n</html>\n",
        escape(&p.meta.study_toml)
    );
    out
}

/// A quantity a vehicle engineer reads, derived from θ = [1/M, Cd/M, Cr]: its relative bias
/// (± MCSE) and relative spread, in % of its true value, from the summary of θ.
struct Derived {
    bias: f64,
    /// The MCSE of `bias`; for Cd an upper bound (the MCSEs of its two means added).
    bias_mcse: f64,
    /// The relative spread, or for Cd the interval it lies in.
    spread: (f64, f64),
}

/// M, Cd and Cr of one condition × estimator from its rows of 1/M, Cd/M and Cr, to first
/// order in the estimates' deviations (the delta method; docs/model.md#vehicle-parameters):
/// M̂ = 1/θ̂₁ has relative bias θ₁/μ₁ − 1 and relative spread ≈ θ₁S₁/μ₁²; Ĉd = θ̂₂/θ̂₁ has
/// relative bias (μ₂/μ₁)/(θ₂/θ₁) − 1 and a relative spread between |S₁/μ₁ − S₂/μ₂| and
/// S₁/μ₁ + S₂/μ₂ times (μ₂/μ₁)/(θ₂/θ₁) (where in that interval depends on the correlation of
/// θ̂₁ and θ̂₂, which the summary does not carry); Cr is θ₃ itself.
fn derived(inv_mass: &SummaryRow, drag: &SummaryRow, cr: &SummaryRow) -> [Derived; 3] {
    let (t1, m1, s1, e1) = (
        inv_mass.truth,
        inv_mass[Measure::Mean].value,
        inv_mass[Measure::EmpSe].value,
        inv_mass[Measure::Mean].mcse,
    );
    let (t2, m2, s2, e2) = (
        drag.truth,
        drag[Measure::Mean].value,
        drag[Measure::EmpSe].value,
        drag[Measure::Mean].mcse,
    );
    let ratio = (m2 / m1) / (t2 / t1);
    let (r1, r2) = (s1 / m1, s2 / m2);
    [
        Derived {
            bias: 100.0 * (t1 / m1 - 1.0),
            bias_mcse: 100.0 * t1 * e1 / (m1 * m1),
            spread: (100.0 * t1 * s1 / (m1 * m1), 100.0 * t1 * s1 / (m1 * m1)),
        },
        Derived {
            bias: 100.0 * (ratio - 1.0),
            bias_mcse: 100.0 * ratio * (e1 / m1.abs() + e2 / m2.abs()),
            spread: (
                100.0 * ratio * (r1 - r2).abs(),
                100.0 * ratio * (r1.abs() + r2.abs()),
            ),
        },
        Derived {
            bias: 100.0 * cr[Measure::RelBias].value,
            bias_mcse: 100.0 * cr[Measure::RelBias].mcse,
            spread: (
                100.0 * cr[Measure::EmpSe].value / cr.truth.abs(),
                100.0 * cr[Measure::EmpSe].value / cr.truth.abs(),
            ),
        },
    ]
}

/// The section "Vehicle parameters": M [kg], Cd and Cr per condition of `listed` ×
/// estimator, with their relative bias and spread ([`derived`]); empty for a model without
/// 1/M, Cd/M and Cr.
fn vehicle_parameters(
    layout: &Layout,
    infos: &[ConditionInfo],
    summary: &[SummaryRow],
    listed: &[usize],
) -> String {
    // A fleet's truths differ by vehicle: its own section shows them relative to each.
    if crate::stats::fleet::is_fleet(layout) {
        return String::new();
    }
    let index = |name: &str| layout.parameters.iter().position(|p| p.name == name);
    let (Some(pm), Some(pd), Some(pr)) = (
        index("inv_mass"),
        index("drag_over_mass"),
        index("rolling_resistance"),
    ) else {
        return String::new();
    };
    let row = |c: usize, e: usize, p: usize| {
        summary
            .iter()
            .find(|r| r.condition == c && r.estimator == e && r.parameter == p)
    };
    let Some(first) = infos.first() else {
        return String::new();
    };
    let varying: Vec<usize> = (0..layout.axes.len())
        .filter(|&a| infos.iter().any(|i| i.axes[a] != first.axes[a]))
        .collect();
    let truth = &first.truth;
    let mut out = String::new();
    let _ = write!(
        out,
        "<h2>Vehicle parameters</h2>\n<p>What the estimates of θ = [1/M, Cd/M, Cr] mean for \
         the mass M = 1/θ₁ (truth {:.1} kg), the drag coefficient Cd = θ₂/θ₁ (truth {:.4}) and \
         the rolling-resistance coefficient Cr (truth {:.5}): bias ± MCSE and spread (the SD \
         of the estimates), in % of the true value. For M and Cd these are first-order (delta \
         method) conversions of the summary of 1/M and Cd/M; the spread of Cd lies in the \
         interval shown, where depending on the correlation of 1/M̂ and Cd/M̂, and the ± of \
         its bias is an upper bound (docs/model.md#vehicle-parameters). Every realisation's \
         M̂ and Ĉd are in realisations.parquet (mass_hat, cd_hat).</p>\n",
        1.0 / truth[pm],
        truth[pd] / truth[pm],
        truth[pr]
    );
    out.push_str("<table class=\"vehicle\">\n<tr>");
    for &a in &varying {
        let _ = write!(out, "<th>{}</th>", escape(layout.axes[a].name));
    }
    out.push_str(
        "<th>estimator</th><th>M bias [%]</th><th>M spread [%]</th><th>Cd bias [%]</th>\
         <th>Cd spread [%]</th><th>Cr bias [%]</th><th>Cr spread [%]</th></tr>\n",
    );
    for &c in listed {
        for e in 0..layout.estimators.len() {
            let (Some(m), Some(d), Some(r)) = (row(c, e, pm), row(c, e, pd), row(c, e, pr)) else {
                continue;
            };
            out.push_str("<tr>");
            for &a in &varying {
                let _ = write!(out, "<td>{}</td>", escape(&infos[c].axes[a].to_string()));
            }
            let _ = write!(out, "<td>{}</td>", escape(layout.estimators[e]));
            for (k, x) in derived(m, d, r).iter().enumerate() {
                let bias = format!(
                    "{:+.3} ± {}{:.3}",
                    x.bias,
                    if k == 1 { "≤" } else { "" },
                    x.bias_mcse
                );
                let spread = if x.spread.0 == x.spread.1 {
                    format!("{:.3}", x.spread.0)
                } else {
                    format!("{:.3}–{:.3}", x.spread.0, x.spread.1)
                };
                let _ = write!(out, "<td>{bias}</td><td>{spread}</td>");
            }
            out.push_str("</tr>\n");
        }
    }
    out.push_str("</table>\n");
    out
}

/// Whether the study as run (`study_toml`) shares its draws across terrain scales.
fn shares_draws(study_toml: &str) -> bool {
    toml::from_str::<toml::Table>(study_toml).is_ok_and(|t| {
        t.get("noise")
            .and_then(|n| n.get("share_across_scales"))
            .and_then(toml::Value::as_bool)
            .unwrap_or(false)
    })
}

/// FNV-1a (64 bit) of `text`: a short fingerprint to show.
fn fnv1a(text: &str) -> u64 {
    crate::numeric::hash::Fnv1a::of(text.as_bytes())
}
