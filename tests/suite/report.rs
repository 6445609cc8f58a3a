//! What a run tells its reader: `report.html`, the page every `run` and `summarize` writes
//! next to its files, and the `--replications-for` plan.

use super::common::*;

/// The text of every element named `name` under `node`, in document order.
fn texts<'a>(doc: &'a roxmltree::Document<'a>, name: &str) -> Vec<String> {
    doc.descendants()
        .filter(|n| n.tag_name().name() == name)
        .map(|n| {
            n.descendants()
                .filter(|d| d.is_text())
                .map(|d| d.text().unwrap_or(""))
                .collect()
        })
        .collect()
}

#[test]
fn the_report_parses_and_names_the_study_seed_r_and_embeds_every_figure() {
    // Speed noise with OLS and BCLS: the thesis bound is reported (and must be warned
    // about), OLS is biased (warned), BCLS is not.
    let study = study("bias_compensation.toml", 5);
    let (dir, _) = run(&study, None);
    let text = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
    assert!(text.starts_with("<!DOCTYPE html>"));
    // Well-formed (XHTML-compatible) HTML: an XML parser reads it whole.
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(&text, options)
        .unwrap_or_else(|e| panic!("report.html: {e}"));
    let title = &texts(&doc, "title")[0];
    assert!(title.contains("bias_compensation"), "{title}");
    let cells = texts(&doc, "td");
    let value = |label: &str| {
        let i = cells.iter().position(|c| c.starts_with(label)).unwrap();
        cells[i + 1].clone()
    };
    assert_eq!(value("seed"), "2018");
    assert_eq!(value("realisations per condition"), "5");
    assert_eq!(value("study"), "bias_compensation");
    // Every figure of the run, inline, in the order of the captions.
    let mut written: Vec<String> = std::fs::read_dir(dir.path().join("figures"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    written.sort();
    let mut captions: Vec<String> = texts(&doc, "figcaption")
        .iter()
        .map(|c| c.trim_start_matches("figures/").to_string())
        .collect();
    let svgs = doc
        .descendants()
        .filter(|n| {
            n.tag_name().name() == "svg"
                && n.parent().is_some_and(|p| p.tag_name().name() == "figure")
        })
        .count();
    assert_eq!(svgs, captions.len());
    captions.sort();
    assert_eq!(captions, written);
    assert!(written.len() >= 12, "{written:?}");
    // The warnings a reader needs.
    let warnings: Vec<String> = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("warning"))
        .map(|n| n.text().unwrap_or("").to_string())
        .collect();
    assert!(
        warnings
            .iter()
            .any(|w| w.starts_with("thesis_bound is not a valid bound")),
        "{warnings:?}"
    );
    assert!(
        warnings.iter().any(|w| w.starts_with("ols is biased")),
        "{warnings:?}"
    );
    assert!(
        !warnings
            .iter()
            .any(|w| w.contains("share their noise draws")),
        "no sharing warning without sharing: {warnings:?}"
    );
    // The study as run, escaped and complete.
    let pre = texts(&doc, "pre");
    assert!(
        pre.iter()
            .any(|p| p.contains("name = \"bias_compensation\""))
    );
}

#[test]
fn replications_for_plans_the_r_that_reaches_a_target_mcse() {
    // A pilot of R₀ = 40 (bias_compensation at scale 1 and σ_v = 1), then the R it plans
    // for half its largest bias MCSE of Cd/M: R ≈ 4·R₀. Run at that R (extending the
    // pilot), the largest MCSE must be near the target: the ratio of the two runs' MCSEs
    // has a relative SE of √(1/(2·40) + 1/(2·160)) ≈ 12.5 %, so 3 SE allow 1.375. The same
    // for the control-variate bias (its MCSE falls as 1/√R too; a few per cent optimistic
    // at R = 40, docs/model.md#control-variates).
    for measure in ["bias", "bias_cv"] {
        plan_and_check(measure);
    }
}

fn plan_and_check(measure: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let text = set_key(&study_text("bias_compensation.toml"), "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", "[1.0]");
    let path = tmp.path().join("pilot.toml");
    std::fs::write(&path, text).unwrap();
    let out = tmp.path().join("out");
    let run = |r: &str, extra: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> = vec![
            "run".as_ref(),
            path.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
            "--realisations".as_ref(),
            r.as_ref(),
            "--quiet".as_ref(),
        ];
        args.extend(extra.iter().map(|a| std::ffi::OsStr::new(*a)));
        let (code, stdout, stderr) = cli(&args, tmp.path());
        assert_eq!(code, 0, "{stderr}");
        stdout
    };
    run("40", &[]);
    let worst = |dir: &std::path::Path| {
        let s = read_table(&dir.join("summary.parquet"));
        let param = str_col(&s, "parameter");
        f64_col(&s, &format!("{measure}_mcse"))
            .into_iter()
            .zip(param)
            .filter(|(_, p)| p == "drag_over_mass")
            .map(|(m, _)| m)
            .fold(0.0, f64::max)
    };
    let target = worst(&out) / 2.0;
    let planned = run(
        "40",
        &[
            "--replications-for",
            &format!("drag_over_mass:{measure}={target:e}"),
        ],
    );
    let r: u64 = planned
        .split("R = ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no R in: {planned}"));
    assert!((159..=161).contains(&r), "{planned}");
    assert!(planned.contains("s at this run's pace"), "{planned}");
    run(&r.to_string(), &[]);
    let ratio = worst(&out) / target;
    assert!(
        (1.0 / 1.375..1.375).contains(&ratio),
        "{measure}: MCSE / target = {ratio}"
    );
}

#[test]
fn replications_for_says_when_a_target_is_out_of_reach_or_has_nothing_to_plan() {
    // A pilot of R = 20 on one scale, OLS only. bias_cv's MCSE there is ~1e-8 (Cr, docs/
    // model.md#control-variates): 1e-30 would need ~1e46 realisations, far past 2^40.
    // rel_precision compares estimators with the first: with OLS alone it is 0 exactly.
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("pilot.toml");
    std::fs::write(
        &path,
        set_key(&study_text("thesis.toml"), "scales", "[1.0]"),
    )
    .unwrap();
    let out = tmp.path().join("out");
    let args: Vec<&std::ffi::OsStr> = vec![
        "run".as_ref(),
        path.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--realisations".as_ref(),
        "20".as_ref(),
        "--quiet".as_ref(),
        "--no-figures".as_ref(),
        "--replications-for".as_ref(),
        "bias_cv=1e-30".as_ref(),
        "--replications-for".as_ref(),
        "rel_precision=0.1".as_ref(),
    ];
    let (code, stdout, stderr) = cli(&args, tmp.path());
    assert_eq!(code, 0, "{stderr}");
    let lines: Vec<&str> = stdout.lines().collect();
    let cv = lines.iter().find(|l| l.contains("bias_cv")).unwrap();
    assert!(cv.contains("out of reach"), "{cv}");
    assert!(
        cv.contains("1099511627776"),
        "names the largest R accepted: {cv}"
    );
    assert!(!cv.contains("R = "), "recommends no R: {cv}");
    let rp = lines.iter().find(|l| l.contains("rel_precision")).unwrap();
    assert!(rp.contains("nothing to plan"), "{rp}");
    assert!(!rp.contains("R = "), "recommends no R: {rp}");
}
