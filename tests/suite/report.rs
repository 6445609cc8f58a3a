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

/// The cells of the rows of the table of class `class` in `doc` (header rows excluded).
fn table_rows(doc: &roxmltree::Document<'_>, class: &str) -> Vec<Vec<String>> {
    let table = doc
        .descendants()
        .find(|n| n.has_tag_name("table") && n.attribute("class") == Some(class))
        .unwrap_or_else(|| panic!("no table of class {class}"));
    table
        .children()
        .filter(|n| n.has_tag_name("tr"))
        .map(|tr| {
            tr.children()
                .filter(|c| c.has_tag_name("td"))
                .map(|c| c.text().unwrap_or("").to_string())
                .collect::<Vec<_>>()
        })
        .filter(|cells| !cells.is_empty())
        .collect()
}

fn parse_report(text: &str) -> roxmltree::Document<'_> {
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    roxmltree::Document::parse_with_options(text, options).unwrap()
}

#[test]
fn printed_table_leads_with_a_valid_bound_and_names_it_in_the_header() {
    // Speed noise only: thesis_bound is reported but never valid; eiv_sandwich applies to
    // OLS and BCLS, and WBCLS reports eiv_crlb_linearized but not the sandwich (README "What
    // the numbers mean").
    let (_dir, report) = run(&study("bias_compensation.toml", 5), None);
    let text = chassis_mc::report::table(&report.layout, &report.infos, &report.summary);
    let headers: Vec<&str> = text
        .lines()
        .filter(|l| l.trim_start().starts_with("cond"))
        .collect();
    assert_eq!(headers.len(), 3, "{text}");
    for h in &headers {
        assert!(h.contains("EmpSE/eiv_sandwich"), "{h}");
        assert!(!h.contains("thesis"), "{h}");
    }
    assert!(!text.contains("(thesis)"), "{text}");
    // Each line's ratio is the summary's EmpSE / eiv_sandwich of that row.
    let b = report
        .layout
        .bounds
        .iter()
        .position(|b| b.name == "eiv_sandwich")
        .unwrap();
    let first = &report.summary[0];
    let s = first.bounds[b].as_ref().unwrap();
    let expected = format!("{:.4} ± {:.4}", s.emp_over.value, s.emp_over.mcse);
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{} ", first.condition)))
        .unwrap();
    assert!(line.ends_with(&expected), "{line} vs {expected}");

    // Estimators whose valid bounds differ: the header says "bound", each line names its own.
    let mixed = set_key(
        &study_text("bias_compensation.toml"),
        "estimators",
        "[\"ols\", \"wbcls\"]",
    );
    let mixed = set_key(&set_key(&mixed, "scales", "[1.0]"), "velocity_sd", "[1.0]");
    let study = chassis_mc::study::Study::from_toml(&mixed, "mixed")
        .unwrap()
        .with_overrides(Some(5), None)
        .unwrap();
    let (_dir, report) = run(&study, None);
    let text = chassis_mc::report::table(&report.layout, &report.infos, &report.summary);
    for line in text.lines().filter(|l| l.contains(" ols ")) {
        assert!(line.contains("eiv_sandwich"), "{line}");
    }
    let wbcls: Vec<&str> = text.lines().filter(|l| l.contains("wbcls")).collect();
    assert_eq!(wbcls.len(), 3, "{text}");
    for line in wbcls {
        assert!(line.contains("eiv_crlb_linearized"), "{line}");
    }
    assert!(text.contains("EmpSE/bound"), "{text}");
}

/// Where the second moment's control variates apply (docs/model.md#spread-control-variates),
/// the printed table (and report.html's copy of it) gives EmpSE / bound by them beside the
/// plain ratio, with an explanation line, and the warning about a bound that is not valid
/// gives their range too; where none apply (the line fit) the column and the line are absent.
#[test]
fn tables_give_the_control_variate_ratio_beside_the_plain_one_where_it_applies() {
    // One condition, OLS and BCLS, speed noise, R = 40: the spread's control variates (the
    // five speed controls, defined from q + 3 = 8 realisations on) apply to every row.
    let study = speed_noise_study("[1.0]", "[1.0]", 40, None);
    let (dir, report) = run(&study, None);
    let table = chassis_mc::report::table(&report.layout, &report.infos, &report.summary);
    let headers: Vec<&str> = table
        .lines()
        .filter(|l| l.trim_start().starts_with("cond"))
        .collect();
    assert_eq!(headers.len(), 3, "{table}");
    for h in &headers {
        assert!(h.ends_with("EmpSE/eiv_sandwich              (CV)"), "{h}");
    }
    assert!(
        table.contains("(CV) = EmpSE/bound with EmpSE by the second moment's control variates"),
        "{table}"
    );
    assert!(table.contains("docs/model.md#spread-control-variates"));
    let b = report
        .layout
        .bounds
        .iter()
        .position(|b| b.name == "eiv_sandwich")
        .unwrap();
    // Each line (parameter-major, then estimator): the plain ratio, then the same by
    // control variates, of its own row.
    let mut lines = table
        .lines()
        .filter(|l| l.trim_start().starts_with("0 "))
        .collect::<Vec<_>>()
        .into_iter();
    let by_parameter = (0..report.layout.parameters.len())
        .flat_map(|p| report.summary.iter().filter(move |r| r.parameter == p));
    for r in by_parameter {
        let s = r.bounds[b].as_ref().unwrap();
        assert!(s.emp_over_cv.value.is_finite(), "{r:?}");
        let plain = format!("{:.4} ± {:.4}", s.emp_over.value, s.emp_over.mcse);
        let cv = format!("{:.5} ± {:.1e}", s.emp_over_cv.value, s.emp_over_cv.mcse);
        let line = lines.next().unwrap();
        assert!(
            line.ends_with(&format!("{plain}  {cv}")),
            "{line} vs {plain}, {cv}"
        );
    }
    assert!(lines.next().is_none());
    // report.html carries the same table, and the thesis bound's warning the sharper range.
    let html = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
    let doc = parse_report(&html);
    let pre = texts(&doc, "pre");
    assert!(
        pre.iter()
            .any(|p| p.trim_matches('\n') == table.trim_matches('\n')),
        "report.html's table differs from the printed one"
    );
    let warning = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("warning"))
        .filter_map(|n| n.text())
        .find(|w| w.starts_with("thesis_bound is not a valid bound"))
        .unwrap();
    assert!(
        warning.contains("with the spread by control variates"),
        "{warning}"
    );

    // The line fit has no controls: no column, no explanation.
    let (_dir, report) = run(&super::common::study("line_fit.toml", 40), None);
    let table = chassis_mc::report::table(&report.layout, &report.infos, &report.summary);
    assert!(
        table
            .lines()
            .filter(|l| l.trim_start().starts_with("cond"))
            .all(|h| h.ends_with("EmpSE/true_sigma")),
        "{table}"
    );
    assert!(!table.contains("spread-control-variates"), "{table}");
}

/// `--replications-for` plans `emp_se_cv` like any measure with an MCSE: R = ⌈R₀ ·
/// (MCSE / target)²⌉ from the pilot's largest `emp_se_cv_mcse`, and far fewer realisations
/// than `emp_se` needs for the same target.
#[test]
fn replications_for_plans_the_control_variate_spread_with_far_fewer_realisations() {
    // A pilot of R₀ = 40 (bias_compensation at scale 1 and σ_v = 1, OLS and BCLS). The
    // target 1e-11 for 1/M lies below the pilot's control-variate MCSE (~2.7e-10), so the
    // plan is the formula's, not the least R at which the estimate is defined (at 1e-9 the
    // pilot already reaches it and the plan is that least R, q + 3 = 8).
    let tmp = tempfile::tempdir().unwrap();
    let text = set_key(&study_text("bias_compensation.toml"), "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", "[1.0]");
    let path = tmp.path().join("pilot.toml");
    std::fs::write(&path, text).unwrap();
    let out = tmp.path().join("out");
    let args: Vec<&std::ffi::OsStr> = vec![
        "run".as_ref(),
        path.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--realisations".as_ref(),
        "40".as_ref(),
        "--quiet".as_ref(),
        "--no-figures".as_ref(),
        "--replications-for".as_ref(),
        "inv_mass:emp_se_cv=1e-11".as_ref(),
        "--replications-for".as_ref(),
        "inv_mass:emp_se=1e-11".as_ref(),
    ];
    let (code, stdout, stderr) = cli(&args, tmp.path());
    assert_eq!(code, 0, "{stderr}");
    let planned = |measure: &str| -> u64 {
        let line = stdout
            .lines()
            .find(|l| l.contains(&format!("inv_mass:{measure} MCSE")))
            .unwrap_or_else(|| panic!("no plan for {measure}: {stdout}"));
        line.split("R = ")
            .nth(1)
            .and_then(|t| t.split_whitespace().next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no R in: {line}"))
    };
    let (cv, plain) = (planned("emp_se_cv"), planned("emp_se"));
    // The plan is the formula applied to the pilot's summary (its largest MCSE of 1/M).
    let s = read_table(&out.join("summary.parquet"));
    let param = str_col(&s, "parameter");
    let worst = f64_col(&s, "emp_se_cv_mcse")
        .into_iter()
        .zip(&param)
        .filter(|(_, p)| *p == "inv_mass")
        .map(|(m, _)| m)
        .fold(0.0, f64::max);
    let expected = (40.0 * (worst / 1e-11f64).powi(2)).ceil() as u64;
    assert_eq!(cv, expected, "{stdout}");
    assert!(cv > 40, "a real plan, beyond the pilot: {stdout}");
    // Both plans share R₀ and the target, so their ratio is the squared ratio of the two
    // MCSEs of 1/M: 1.29e-7 / 2.66e-10 ≈ 490 in this pilot (7.2e-8 / 9.0e-11 ≈ 800 at
    // R₀ = 200; `run` of this study with `--replications-for inv_mass:emp_se=1e-9
    // --replications-for inv_mass:emp_se_cv=1e-9` prints both), so R falls by ~2·10⁵.
    // 100 asks only for an MCSE ratio of 10, a factor ~50 below the measured one: no pilot
    // noise on either MCSE (~11 % relative for emp_se's at R₀ = 40) comes near that.
    assert!(plain >= 100 * cv, "emp_se R = {plain}, emp_se_cv R = {cv}");
}

#[test]
fn report_gives_mass_drag_coefficient_and_rolling_resistance_with_bias_and_spread() {
    // One scale, σ_v = 1 and 2 m/s, OLS and BCLS, R = 200: the report's M, Cd and Cr
    // against the same realisations' mass_hat, cd_hat and θ̂₃ (realisations.parquet).
    let text = set_key(&study_text("bias_compensation.toml"), "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", "[1.0, 2.0]");
    let study = chassis_mc::study::Study::from_toml(&text, "vehicle")
        .unwrap()
        .with_overrides(Some(200), None)
        .unwrap();
    let (dir, _) = run(&study, None);
    let html = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
    let doc = parse_report(&html);
    let headers = texts(&doc, "th");
    for h in [
        "M bias [%]",
        "M spread [%]",
        "Cd bias [%]",
        "Cd spread [%]",
        "Cr bias [%]",
        "Cr spread [%]",
    ] {
        assert!(headers.iter().any(|t| t == h), "{h} missing in {headers:?}");
    }
    let rows = table_rows(&doc, "vehicle");
    assert_eq!(rows.len(), 2 * 2, "conditions × estimators: {rows:?}");

    let r = read_table(&dir.path().join("realisations.parquet"));
    let (sd, est) = (f64_col(&r, "velocity_sd"), str_col(&r, "estimator"));
    let (mass, cd, cr) = (
        f64_col(&r, "mass_hat"),
        f64_col(&r, "cd_hat"),
        f64_col(&r, "theta_rolling_resistance"),
    );
    let (m_true, cd_true, cr_true) = (1800.0, 0.35, 0.0125); // studies/bias_compensation.toml
    let mean_sd = |v: &[f64]| {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var.sqrt())
    };
    let number = |cell: &str| -> f64 { cell.trim().parse().unwrap() };
    let bias_of = |cell: &str| number(cell.split(" ± ").next().unwrap());
    // Cells print three decimals of a percentage: ±0.0005 of rounding.
    let rounding = 0.0005;
    for row in &rows {
        let (level, estimator) = (number(&row[0]), &row[1]);
        let pick = |v: &[f64]| -> Vec<f64> {
            (0..v.len())
                .filter(|&i| sd[i] == level && &est[i] == estimator)
                .map(|i| v[i])
                .collect()
        };
        let (m_mean, m_sd) = mean_sd(&pick(&mass));
        let (cd_mean, cd_sd) = mean_sd(&pick(&cd));
        let (cr_mean, cr_sd) = mean_sd(&pick(&cr));
        // The report converts the summary of θ to first order (docs/model.md#vehicle-parameters);
        // what it leaves out is of relative order (S/μ)² in the mean and S/μ in the SD,
        // with S/μ the relative spread (0.2–0.5 % here): twice that as slack.
        let r_m = m_sd / m_mean;
        let r_cd = cd_sd / cd_mean;
        let second = 2.0 * 100.0 * (r_m * r_m + r_m * r_cd);
        let m_bias = 100.0 * (m_mean / m_true - 1.0);
        assert!(
            (bias_of(&row[2]) - m_bias).abs() <= second + rounding,
            "{row:?}: M bias {m_bias}"
        );
        let m_spread = 100.0 * m_sd / m_true;
        assert!(
            (number(&row[3]) - m_spread).abs() <= 2.0 * r_m * m_spread + rounding,
            "{row:?}: M spread {m_spread}"
        );
        let cd_bias = 100.0 * (cd_mean / cd_true - 1.0);
        assert!(
            (bias_of(&row[4]) - cd_bias).abs() <= second + rounding,
            "{row:?}: Cd bias {cd_bias}"
        );
        // The spread of Cd: an interval that holds the realisations' own.
        let cd_spread = 100.0 * cd_sd / cd_true;
        let (lo, hi) = row[5].split_once('–').unwrap();
        let slack = 2.0 * (r_m + r_cd) * cd_spread + rounding;
        assert!(
            number(lo) - slack <= cd_spread && cd_spread <= number(hi) + slack,
            "{row:?}: Cd spread {cd_spread}"
        );
        // Cr is θ₃ itself: exact up to rounding.
        assert!(
            (bias_of(&row[6]) - 100.0 * (cr_mean / cr_true - 1.0)).abs() <= rounding + 1e-9,
            "{row:?}"
        );
        assert!(
            (number(&row[7]) - 100.0 * cr_sd / cr_true).abs() <= rounding + 1e-9,
            "{row:?}"
        );
    }
}

#[test]
fn report_stays_small_on_a_grid_of_hundreds_of_conditions() {
    // The thesis cycle cut to 60 s: 11 scales × 3 durations × 10 speed-noise levels = 330
    // conditions, OLS and BCLS, R = 4. Before the tables listed a selection and the figures
    // a bounded number of series, this grid's report.html was 9.6 MB (and 33 MB at 1100
    // conditions, README "report.html"); now the page does not grow with the grid beyond
    // the drive-cycle figure: at most 16 series per figure and the tables' selection.
    let text = set_key(&study_text("thesis.toml"), "duration", "60.0");
    let text = text.replace("[drive]\n", "[drive]\ndurations = [20.0, 40.0, 60.0]\n");
    let text = set_key(
        &text,
        "velocity_sd",
        "[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]",
    );
    let text = set_key(&text, "estimators", "[\"ols\", \"bcls\"]");
    let study = chassis_mc::study::Study::from_toml(&text, "grid")
        .unwrap()
        .with_overrides(Some(4), None)
        .unwrap();
    let (dir, report) = run(&study, None);
    assert_eq!(report.infos.len(), 330);
    let html = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
    let cycles = std::fs::read_to_string(dir.path().join("figures/cycles.svg")).unwrap_or_default();
    let without_cycles = html.len() - cycles.len().min(html.len());
    assert!(
        without_cycles < 2_000_000,
        "report.html without cycles.svg: {without_cycles} bytes"
    );
    let doc = parse_report(&html);
    // The tables list a selection of the conditions, and say so.
    let listed = table_rows(&doc, "vehicle").len() / 2;
    assert!(
        (8..=chassis_mc::report::MAX_LISTED_CONDITIONS).contains(&listed),
        "{listed} conditions listed"
    );
    assert!(html.contains(&format!("{listed} of 330 conditions")));
    // Every figure but the cycles' has at most 16 series (legend entries besides the
    // reference line), and says which groups it shows.
    for entry in std::fs::read_dir(dir.path().join("figures")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name == "cycles.svg" {
            continue;
        }
        let svg = std::fs::read_to_string(&path).unwrap();
        let doc = roxmltree::Document::parse(&svg).unwrap();
        // Legend keys sit in the right-hand margin (from x = 940 px; the plot ends at 920).
        let legend_keys = doc
            .descendants()
            .filter(|n| {
                (n.has_tag_name("circle") && n.attribute("fill").is_some_and(|f| f != "none"))
                    || n.has_tag_name("polyline")
            })
            .filter(|n| {
                let x = n
                    .attribute("cx")
                    .or_else(|| n.attribute("points").and_then(|p| p.split(',').next()))
                    .and_then(|x| x.trim().parse::<f64>().ok())
                    .unwrap_or(0.0);
                x > 930.0
            })
            .count();
        assert!(
            legend_keys <= 16 + 1,
            "{name}: {legend_keys} legend entries"
        );
        if name.starts_with("se_") || name.starts_with("ratio_") {
            assert!(
                svg.contains("groups:"),
                "{name}: no note of the groups shown"
            );
        }
    }
}

/// `run --help` names exactly the measures `--replications-for` accepts, in the planner's
/// order, and the planner parses each of them.
///
/// Regression: the help listed seven of the nine measures (not `mean_cv` and `bias_cv`).
#[test]
fn replications_for_help_names_exactly_the_measures_the_planner_accepts() {
    use chassis_mc::stats::plan::{Target, measure_names};
    let (code, help, _) = cli(&["run".as_ref(), "--help".as_ref()], &root());
    assert_eq!(code, 0);
    let text = help.split_whitespace().collect::<Vec<_>>().join(" ");
    let listed: Vec<&str> = text
        .split("standard error of MEASURE (")
        .nth(1)
        .and_then(|rest| rest.split(')').next())
        .expect("--replications-for's help lists the measures in parentheses")
        .split(", ")
        .collect();
    assert_eq!(listed, measure_names());
    for measure in listed {
        assert!(
            Target::parse(&format!("{measure}=0.1")).is_ok(),
            "{measure}"
        );
    }
}

/// The warnings of the model errors in `report.html` of `dir` (the paragraphs that say no
/// bound covers an estimate), as text.
fn model_error_warnings(dir: &std::path::Path) -> Vec<String> {
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    let doc = parse_report(&html);
    doc.descendants()
        .filter(|n| n.attribute("class") == Some("warning"))
        .map(|n| n.text().unwrap_or("").to_string())
        .filter(|w| w.contains("no bound covers this"))
        .collect()
}

#[test]
fn a_model_error_beyond_the_spread_is_warned_with_its_size_and_each_bound_s_coverage() {
    // The thesis car at scale 1, σ_v = 0.25 m/s, OLS and BCLS, R = 50, in a steady 4 m/s
    // headwind: the wind biases every parameter by far more than its spread (measured:
    // OLS 1/M +1.1 %, Cd/M +15 %, Cr +68 %: 21, 731 and 126 EmpSE). Every row of
    // summary.parquet with |bias_model| > emp_se — decided here from the file — has one
    // warning, whose X = 100·bias_model/truth [%] and
    // Y = |bias_model|/emp_se are those of the file to the rounding of the digits printed
    // (X two decimals, Y two decimals: ±0.005), and whose coverage of each bound reported is
    // the file's coverage_B ± coverage_B_mcse (one decimal of a percentage: ±0.05).
    let text = set_key(&study_text("bias_compensation.toml"), "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", "[0.25]");
    let load = |text: &str| {
        chassis_mc::study::Study::from_toml(text, "vehicle")
            .unwrap()
            .with_overrides(Some(50), None)
            .unwrap()
    };
    let windy = load(&format!("{text}\n[truth]\nwind_speed = [4.0]\n"));
    let (dir, _) = run(&windy, None);
    let warnings = model_error_warnings(dir.path());
    let summary = read_table(&dir.path().join("summary.parquet"));
    let (condition, estimator, parameter) = (
        i32_col(&summary, "condition"),
        str_col(&summary, "estimator"),
        str_col(&summary, "parameter"),
    );
    let (truth, bias_model, emp_se) = (
        f64_col(&summary, "truth"),
        f64_col(&summary, "bias_model"),
        f64_col(&summary, "emp_se"),
    );
    let bounds: Vec<String> = summary
        .schema()
        .fields()
        .iter()
        .filter_map(|f| f.name().strip_prefix("coverage_"))
        .filter(|b| !b.ends_with("_mcse"))
        .map(str::to_string)
        .collect();
    assert!(bounds.contains(&"eiv_sandwich".to_string()), "{bounds:?}");
    // The number after `before` in `w`, up to the next space (a trailing comma dropped).
    let number_after = |w: &str, before: &str| -> f64 {
        let rest = &w[w
            .find(before)
            .unwrap_or_else(|| panic!("{before:?} in {w}"))
            + before.len()..];
        let word = rest.split(' ').next().unwrap().trim_end_matches(',');
        word.parse()
            .unwrap_or_else(|e| panic!("{word:?} after {before:?}: {e}"))
    };
    let mut expected = 0;
    for i in 0..truth.len() {
        if bias_model[i].abs() <= emp_se[i] {
            continue;
        }
        expected += 1;
        let start = format!(
            "Condition {} (wind_speed = 4 m/s), {}, ",
            condition[i], estimator[i]
        );
        let tag = format!("({}): ", parameter[i]);
        let mine: Vec<&String> = warnings
            .iter()
            .filter(|w| w.starts_with(&start) && w.contains(&tag))
            .collect();
        assert_eq!(mine.len(), 1, "{start}{tag}: {warnings:#?}");
        let w = mine[0];
        let x = 100.0 * bias_model[i] / truth[i];
        let y = bias_model[i].abs() / emp_se[i];
        let shown_x = number_after(w, "wrong by ");
        let shown_y = number_after(w, &format!("{shown_x:+.2} %, "));
        assert!((shown_x - x).abs() <= 0.005 + 1e-9, "X {x} in {w}");
        assert!((shown_y - y).abs() <= 0.005 + 1e-9, "Y {y} in {w}");
        for b in &bounds {
            let coverage = f64_col(&summary, &format!("coverage_{b}"))[i];
            let mcse = f64_col(&summary, &format!("coverage_{b}_mcse"))[i];
            if coverage.is_nan() {
                assert!(!w.contains(&format!(" {b} ")), "{b} not reported: {w}");
                continue;
            }
            let shown = number_after(w, &format!(" {b} "));
            let shown_mcse = number_after(w, &format!(" {b} {shown:.1} ± "));
            assert!((shown - 100.0 * coverage).abs() <= 0.05 + 1e-9, "{b}: {w}");
            assert!((shown_mcse - 100.0 * mcse).abs() <= 0.05 + 1e-9, "{b}: {w}");
        }
    }
    // Cd/M of both estimators at least, and nothing else.
    assert!(expected >= 2, "{warnings:#?}");
    assert_eq!(warnings.len(), expected, "{warnings:#?}");

    // The same study without [truth]: no such warning.
    let (calm, _) = run(&load(&text), None);
    assert_eq!(model_error_warnings(calm.path()), Vec::<String>::new());
}
