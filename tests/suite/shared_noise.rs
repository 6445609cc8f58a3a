//! `noise.share_across_scales` (docs/model.md#shared-noise): conditions that differ only in
//! terrain scale and duration read the same draws in each realisation.

use chassis_mc::model::Model;
use chassis_mc::model::vehicle::VehicleModel;
use chassis_mc::study::Study;

use super::common::*;

/// The thesis study on two scales and two durations, sharing its draws or not.
fn shared_thesis(share: bool, extra_noise: &str) -> String {
    let text = set_key(&study_text("thesis.toml"), "scales", "[1.0, 2.0]");
    let text = text.replace(
        "[drive]",
        "[drive]\ndurations = [300.0, 600.0]          # s",
    );
    text.replace(
        "[noise]",
        &format!("[noise]\nshare_across_scales = {share}\n{extra_noise}"),
    )
}

/// `realise_group` of realisations `first .. first + n` of the draw group `members` against
/// `realise` of each member alone, bit for bit, slot by slot.
fn assert_group_is_each_alone(
    model: &VehicleModel,
    members: &[usize],
    first: u64,
    n: usize,
    what: &str,
) {
    let stride = model.layout().realisation_stride();
    let mut together = vec![0.0; members.len() * n * stride];
    model.realise_group(2018, members, first, n, &mut together);
    for i in 0..n {
        for (k, &c) in members.iter().enumerate() {
            let mut alone = vec![0.0; stride];
            model.realise(2018, c, first + i as u64, &mut alone);
            let at = (i * members.len() + k) * stride;
            assert_eq!(
                together[at..at + stride]
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                alone.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "{what}: condition {c}, realisation {}",
                first + i as u64
            );
        }
    }
}

#[test]
fn one_draw_for_a_group_gives_each_condition_bit_for_bit_its_own_realisation() {
    // The group path (one draw, every condition accumulated from it, realisations side by
    // side) against each condition realised alone from its shared sequence: white speed
    // and output noise (the group path). With AR(1) speed noise both sides realise the
    // members one by one, so that case guards the dispatch and the shared keys only.
    for extra in [
        "output_sd = [0.0, 0.05]",
        "output_sd = [0.0]\nvelocity_correlation_time = [0.5]",
    ] {
        let text = shared_thesis(true, extra).replacen("output_sd = [0.0] ", "# ", 1);
        let study = Study::from_toml(&text, "shared").unwrap();
        let model = VehicleModel::new(&study).unwrap();
        let count = model.condition_count();
        let groups: Vec<usize> = (0..count).map(|c| model.draw_group(c)).collect();
        let inner = count / 4; // 2 scales × 2 durations
        assert_eq!(groups, (0..count).map(|c| c % inner).collect::<Vec<_>>());
        for g in 0..inner {
            let members: Vec<usize> = (0..count).filter(|&c| groups[c] == g).collect();
            assert_eq!(members.len(), 4, "{extra}");
            assert_group_is_each_alone(&model, &members, 7, 3, extra);
        }
    }
}

#[test]
fn gusty_conditions_realised_side_by_side_are_each_realisation_alone_bit_for_bit() {
    // Gusts move the vehicle in every realisation: a group's cycles are integrated four at
    // a time, condition by condition, into the group's slots. Each slot must be what
    // `realise` gives alone, for a group of four conditions and a count that is not a
    // multiple of four (6: a chunk of four, then two), from a first realisation that is not
    // a multiple of four either.
    let text = shared_thesis(true, "");
    let text = format!("{text}\n[truth]\nwind_gust_sd = [1.5]\n");
    let study = Study::from_toml(&text, "gusty").unwrap();
    let model = VehicleModel::new(&study).unwrap();
    let members: Vec<usize> = (0..model.condition_count())
        .filter(|&c| model.draw_group(c) == model.draw_group(0))
        .collect();
    assert_eq!(members.len(), 4, "2 scales × 2 durations share their draws");
    assert_group_is_each_alone(&model, &members, 5, 6, "gusts");
}

#[test]
fn the_in_memory_executor_gives_every_condition_its_own_realisations_bit_for_bit() {
    // `montecarlo::in_memory` (design's and check's summaries, fit's bootstrap) computes draw
    // groups together through the run's executor; each slot must be what `realise` gives
    // alone, for conditions listed out of order and a range not starting at 0, across more
    // than one chunk of the executor (2500 realisations > DEFAULT_CHUNK = 1024).
    let study = Study::from_toml(&shared_thesis(true, ""), "shared").unwrap();
    let model = VehicleModel::new(&study).unwrap();
    let stride = model.layout().realisation_stride();
    let count = model.condition_count();
    let conditions: Vec<usize> = (0..count).rev().collect();
    let range = 5..2505u64;
    let slots = chassis_mc::montecarlo::in_memory(
        &model,
        2018,
        &conditions,
        range.clone(),
        &chassis_mc::montecarlo::Silent,
    );
    let r = (range.end - range.start) as usize;
    assert_eq!(slots.len(), conditions.len() * r * stride);
    for (k, &c) in conditions.iter().enumerate() {
        for i in [0, 1, 1023, 1024, 2047, r - 1] {
            let mut alone = vec![0.0; stride];
            model.realise(2018, c, range.start + i as u64, &mut alone);
            let at = (k * r + i) * stride;
            assert_eq!(
                slots[at..at + stride]
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                alone.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "condition {c}, realisation {}",
                range.start + i as u64
            );
        }
    }
}

#[test]
fn shared_draws_keep_every_condition_s_mean_and_emp_se() {
    // Sharing changes which draws a condition reads, not their distribution: per condition,
    // estimator and parameter, mean and EmpSE of a shared run agree with an unshared run
    // (independent draws) within 4 combined MCSE, sqrt(mcse_a² + mcse_b²). With
    // 4 conditions × 3 parameters × 2 measures = 24 comparisons, a false alarm at 4 MCSE has
    // probability ≈ 24 × 6e-5 ≈ 0.2 %.
    let summaries: Vec<_> = [false, true]
        .map(|share| {
            let text = shared_thesis(share, "");
            let study = Study::from_toml(&text, "shared")
                .unwrap()
                .with_overrides(Some(400), None)
                .unwrap();
            run_summary(&study)
        })
        .into();
    let (a, b) = (&summaries[0], &summaries[1]);
    assert_eq!(i32_col(a, "condition"), i32_col(b, "condition"));
    let mut compared = 0;
    for measure in ["mean", "emp_se"] {
        let (va, vb) = (f64_col(a, measure), f64_col(b, measure));
        let mcse = format!("{measure}_mcse");
        let (ma, mb) = (f64_col(a, &mcse), f64_col(b, &mcse));
        for i in 0..va.len() {
            let tolerance = 4.0 * (ma[i] * ma[i] + mb[i] * mb[i]).sqrt();
            assert!(
                (va[i] - vb[i]).abs() <= tolerance,
                "row {i} {measure}: unshared {} shared {} (4 MCSE {tolerance})",
                va[i],
                vb[i]
            );
            compared += 1;
        }
    }
    assert_eq!(compared, 24);
}

#[test]
fn a_shared_run_is_the_same_bytes_on_one_thread_and_two() {
    let text = shared_thesis(true, "");
    let study = Study::from_toml(&text, "shared")
        .unwrap()
        .with_overrides(Some(40), None)
        .unwrap();
    let (one, _) = run(&study, Some(1));
    let (two, _) = run(&study, Some(2));
    // The report tells its reader that the scales' flags are not independent.
    let report = std::fs::read_to_string(one.path().join("report.html")).unwrap();
    assert!(
        report.contains("share their noise draws"),
        "no sharing warning"
    );
    for file in ["realisations.parquet", "summary.parquet"] {
        assert_eq!(
            std::fs::read(one.path().join(file)).unwrap(),
            std::fs::read(two.path().join(file)).unwrap(),
            "{file}"
        );
    }
}

#[test]
fn share_across_scales_must_be_a_switch() {
    let text = shared_thesis(true, "").replace(
        "share_across_scales = true",
        "share_across_scales = \"yes\"",
    );
    let err = Study::from_toml(&text, "shared").unwrap_err().to_string();
    assert!(
        err.contains("noise.share_across_scales") && err.contains("true or false"),
        "{err}"
    );
}

#[test]
fn shared_draws_correlate_the_scales_and_independent_ones_do_not() {
    // What sharing is for: realisation r of scale 1.0 and of scale 2.0 read the same speed
    // noise, so their estimates move together (benches/shared_differences.py measured
    // correlations 0.99 for 1/M at R = 2000, against 0.02 without sharing). With R = 400
    // the sampling SD of a correlation near 0 is ≈ 0.05: |ρ| < 0.3 is 6 SD; near 0.99 it is
    // ≈ 0.001, so > 0.9 leaves a wide margin.
    let correlation = |share: bool| {
        let text = set_key(&shared_thesis(share, ""), "durations", "[600.0]");
        let study = Study::from_toml(&text, "shared")
            .unwrap()
            .with_overrides(Some(400), None)
            .unwrap();
        let (dir, _) = run(&study, None);
        let table = read_table(&dir.path().join("realisations.parquet"));
        let (scale, theta) = (f64_col(&table, "scale"), f64_col(&table, "theta_inv_mass"));
        let pick = |s: f64| -> Vec<f64> {
            (0..scale.len())
                .filter(|&i| scale[i] == s)
                .map(|i| theta[i])
                .collect()
        };
        let (a, b) = (pick(1.0), pick(2.0));
        assert_eq!((a.len(), b.len()), (400, 400));
        let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
        let (ma, mb) = (mean(&a), mean(&b));
        let cov: f64 = a.iter().zip(&b).map(|(x, y)| (x - ma) * (y - mb)).sum();
        let var = |x: &[f64], m: f64| x.iter().map(|v| (v - m) * (v - m)).sum::<f64>();
        cov / (var(&a, ma) * var(&b, mb)).sqrt()
    };
    let (shared, independent) = (correlation(true), correlation(false));
    assert!(shared > 0.9, "shared: correlation {shared}");
    assert!(
        independent.abs() < 0.3,
        "independent: correlation {independent}"
    );
}

#[test]
fn a_shared_run_killed_or_extended_ends_as_an_uninterrupted_one() {
    // With draw groups the final file is assembled from the committed parts afterwards; a
    // run stopped right after its first part, then resumed, and a run grown from R = 60 to
    // 150, must both end byte for byte as a direct run.
    use std::process::Command;
    let text = shared_thesis(true, "");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("shared.toml");
    std::fs::write(&path, &text).unwrap();
    let direct = dir.path().join("direct");
    let run_cli = |out: &std::path::Path, r: &str, failpoint: Option<&str>| {
        let mut cmd = Command::new(bin());
        cmd.args(["run", "--quiet", "--realisations", r, "--out"])
            .arg(out)
            .arg(&path);
        if let Some(point) = failpoint {
            cmd.env("CHASSIS_MC_FAILPOINT", point);
        }
        cmd.output().unwrap()
    };
    assert!(run_cli(&direct, "150", None).status.success());
    let killed = dir.path().join("killed");
    let stopped = run_cli(&killed, "150", Some("part-committed:1"));
    assert!(!stopped.status.success(), "the run reached the failpoint");
    let resumed = run_cli(&killed, "150", None);
    assert!(
        resumed.status.success(),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    let grown = dir.path().join("grown");
    assert!(run_cli(&grown, "60", None).status.success());
    assert!(run_cli(&grown, "150", None).status.success());
    for name in ["realisations.parquet", "summary.parquet"] {
        let want = std::fs::read(direct.join(name)).unwrap();
        assert!(
            std::fs::read(killed.join(name)).unwrap() == want,
            "resumed {name}"
        );
        assert!(
            std::fs::read(grown.join(name)).unwrap() == want,
            "grown {name}"
        );
    }
}
