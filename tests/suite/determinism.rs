//! The realisations do not depend on the thread count, and a study
//! extended from R = 200 to R = 400 with the same seed keeps its first 200 rows per
//! condition bit for bit (docs/model.md#streams: one ChaCha8 stream per (seed, condition, realisation)).

use super::common::*;

mod columns;
use columns::{control_column, identification_column, spread_column};

#[test]
fn one_and_two_threads_write_identical_realisations() {
    let study = study("thesis.toml", 200);
    let (d1, _) = run(&study, Some(1));
    let (d2, _) = run(&study, Some(2));
    let a = read_table(&d1.path().join("realisations.parquet"));
    let b = read_table(&d2.path().join("realisations.parquet"));
    assert_eq!(a.num_rows(), 11 * 200);
    assert_eq!(a, b);
    // The summary, built from those rows with exact sums, is identical too.
    assert_eq!(
        read_table(&d1.path().join("summary.parquet")),
        read_table(&d2.path().join("summary.parquet"))
    );
}

#[test]
fn extending_r_keeps_the_first_rows_of_every_condition() {
    let (d200, _) = run(&study("thesis.toml", 200), None);
    let (d400, _) = run(&study("thesis.toml", 400), None);
    let a = read_table(&d200.path().join("realisations.parquet"));
    let b = read_table(&d400.path().join("realisations.parquet"));
    let ra = i64_col(&a, "realisation");
    let cb = i32_col(&b, "condition");
    let rb = i64_col(&b, "realisation");
    // Rows of b with realisation < 200, in order, must equal all rows of a.
    let keep: Vec<u32> = (0..b.num_rows() as u32)
        .filter(|&i| rb[i as usize] < 200)
        .collect();
    let keep = arrow::array::UInt32Array::from(keep);
    let prefix = arrow::compute::take_record_batch(&b, &keep).unwrap();
    assert_eq!(prefix.num_rows(), a.num_rows());
    assert_eq!(ra.len(), 11 * 200);
    // Columns, not schemas: the footer metadata records R, which differs.
    assert_eq!(prefix.columns(), a.columns());
    assert_eq!(cb.iter().filter(|&&c| c == 3).count(), 400);
    // ...and the extension really drew new numbers.
    let theta = f64_col(&b, "theta_inv_mass");
    assert_ne!(theta[200], theta[0]);
}

/// Columns added after the hashes below were pinned, each with a value the older engine
/// implied: `duration` (the whole cycle, the only duration it knew), `grade_bias` (none),
/// `velocity_correlation_time` (white noise), `used` (every sample), `rls_settle_time`
/// (null: no estimator reports one), `acceleration` (the model's), the truth's axes (the
/// truth is the equation: each at its neutral value), `bias_model` (the noise-free
/// estimate of the equation's own data: the truth, to rounding), `runs` (1: a cycle of one
/// run) and cycles.parquet's `run` (0). They are checked separately; the hash covers every
/// other column.
const ADDED_COLUMNS: [&str; 18] = [
    "duration",
    "runs",
    "run",
    "grade_bias",
    "velocity_correlation_time",
    "used",
    "rls_settle_time",
    "acceleration",
    "wind_speed",
    "rotating_mass_factor",
    "force_scale",
    "rolling_speed_coefficient",
    "air_density_ratio",
    "bias_model",
    "grade_map_sd",
    "air_speed_sd",
    "wind_gust_sd",
    "force_scale_sd",
];

/// XXH64 of every value of a table, column by column in row order (doubles by their bits,
/// nulls marked), but the [`ADDED_COLUMNS`], the control-variate columns and the
/// identification metrics: a fingerprint of the content that ignores the file's encoding
/// and footer.
fn content_hash(batch: &arrow::array::RecordBatch) -> u64 {
    hash_columns(batch, &|name| {
        !ADDED_COLUMNS.contains(&name)
            && !control_column(name)
            && !spread_column(name)
            && !identification_column(name)
    })
}

/// The same fingerprint of the control-variate columns alone.
fn control_hash(batch: &arrow::array::RecordBatch) -> u64 {
    hash_columns(batch, &control_column)
}

/// The same fingerprint of the spread's control-variate columns alone.
fn spread_hash(batch: &arrow::array::RecordBatch) -> u64 {
    hash_columns(batch, &spread_column)
}

/// The content hashes of realisations, summary and cycles of `text` at R = 64, of the
/// control-variate columns of realisations and summary, and of the summary's spread by
/// control variates.
fn pinned_hashes(text: &str) -> ([u64; 3], [u64; 2], u64) {
    let study = chassis_mc::study::Study::from_toml(text, "pinned")
        .unwrap()
        .with_overrides(Some(64), None)
        .unwrap();
    let (dir, _) = run(&study, None);
    let tables = ["realisations", "summary", "cycles"]
        .map(|name| read_table(&dir.path().join(format!("{name}.parquet"))));
    // The added columns hold what the older engine implied: the whole 600 s cycle, and
    // every sample used.
    for table in &tables[..2] {
        assert!(f64_col(table, "duration").iter().all(|&d| d == 600.0));
        assert!(f64_col(table, "grade_bias").iter().all(|&b| b == 0.0));
        assert!(
            f64_col(table, "velocity_correlation_time")
                .iter()
                .all(|&t| t == 0.0)
        );
        assert!(str_col(table, "acceleration").iter().all(|a| a == "model"));
        for key in ["grade_map_sd", "air_speed_sd"] {
            assert!(f64_col(table, key).iter().all(|&v| v == 0.0), "{key}");
        }
        // One run: the drive is not a coast-down.
        assert!(f64_col(table, "runs").iter().all(|&k| k == 1.0));
    }
    assert!(i32_col(&tables[2], "run").iter().all(|&r| r == 0));
    for table in &tables {
        for (key, neutral) in [
            ("wind_speed", 0.0),
            ("rotating_mass_factor", 0.0),
            ("force_scale", 0.0),
            ("rolling_speed_coefficient", 0.0),
            ("air_density_ratio", 1.0),
            ("wind_gust_sd", 0.0),
            ("force_scale_sd", 0.0),
        ] {
            assert!(f64_col(table, key).iter().all(|&v| v == neutral), "{key}");
        }
    }
    // Without model errors the noise-free estimate is the truth to rounding: OLS recovers
    // θ from the model's own acceleration to ≤ 1e-9 relative (docs/model.md#vehicle).
    let truth = f64_col(&tables[1], "truth");
    for (b, t) in f64_col(&tables[1], "bias_model").iter().zip(&truth) {
        assert!(b.abs() <= 1e-9 * t.abs(), "bias_model {b} of truth {t}");
    }
    assert!(
        f64_col(&tables[0], "rls_settle_time")
            .iter()
            .all(|t| t.is_nan())
    );
    let used = tables[2]
        .column_by_name("used")
        .unwrap()
        .as_any()
        .downcast_ref::<arrow::array::BooleanArray>()
        .unwrap();
    assert_eq!(used.true_count(), used.len());
    let found = tables.each_ref().map(content_hash);
    let controls = [control_hash(&tables[0]), control_hash(&tables[1])];
    let spread = spread_hash(&tables[1]);
    println!(
        "content hashes: {found:016x?}, control variates: {controls:016x?}, spread: {spread:016x}"
    );
    (found, controls, spread)
}

#[test]
fn refactors_keep_the_realisations_bit_for_bit() {
    // Pinned on the engine before it was reorganised into typed extension entries: any
    // change meant to keep results (a refactor, a faster kernel) must keep these hashes.
    // A change that is meant to change results updates them, and says why in its commit.
    let text = set_key(
        &study_text("bias_compensation.toml"),
        "scales",
        "[1.0, 2.0]",
    );
    // Measured on the engine of commit 2221a26 (whose files for this study are byte-identical
    // to those of this commit's parent, checked with `cmp`).
    let (hashes, controls, spread) = pinned_hashes(&text);
    assert_eq!(
        hashes,
        [
            // Re-pinned when BCLS's eiv_sandwich began to include the variance its
            // compensation leaves beyond the first order (docs/model.md#compensated-sandwich):
            // BCLS's three eiv_sandwich columns in the realisations and its sandwich
            // measures in the summary moved; every other column kept its bits (compared
            // column by column against the engine before, commit 0ba1550, at R = 64).
            0x80ef_eb05_0ed1_d123,
            0xef72_5389_6a0e_85cc,
            // cycles.parquet holds each distinct cycle once, keyed by scale (and
            // acceleration): re-pinned when it stopped repeating the cycle per condition
            // (its blocks equal the old table's rows of each scale's first condition, and
            // every condition's old `used` column is its block's within its duration —
            // checked with DuckDB over an 1100-condition grid).
            0x4e72_a879_eb9a_ef79
        ]
    );
    // The control variates, pinned on the engine that introduced them.
    assert_eq!(controls, [0x4699_57bc_7d64_813f, 0x0ef2_66e5_6de8_855e]);
    // The spread by control variates, pinned on the engine that introduced it.
    // Re-pinned with the compensated sandwich: its emp_over_eiv_sandwich_cv for BCLS moved.
    assert_eq!(spread, 0xe16e_b2d4_5720_9f9e);
}

#[test]
fn refactors_keep_the_general_kernel_bit_for_bit() {
    // The same for the general kernel (grade and force noise on as well as speed noise):
    // measured on the engine of commit d09f037, before the noise channels became one enum
    // (its files for this study are byte-identical to those of the channel enum, by `cmp`).
    let text = set_key(
        &study_text("bias_compensation.toml"),
        "scales",
        "[1.0, 2.0]",
    );
    let text = set_key(
        &text,
        "velocity_sd",
        "[0.5]\ngrade_sd = [0.0, 0.01]\nforce_sd = [20.0]",
    );
    //
    // Re-pinned when BCLS began compensating force and grade noise (every condition here
    // has force noise): BCLS's θ̂, M̂, Ĉd and thesis-conversion columns in the realisations,
    // and BCLS's measures in the summary (its bias_cv among them), moved; OLS's columns, the
    // cycles and the realisations' control variates kept their bits (compared column by
    // column against the engine before the change).
    //
    // Re-pinned when the general kernel was vectorised (README "Determinism"): the block is
    // measured column by column, the small angle of grade noise goes through the vectorised
    // sin/cos (within 1 ulp of `f64::sin_cos`), and the sums are taken in four lanes, so
    // the last bits of every sum, and of every column computed from them, moved; the sums
    // agree with the row-by-row ones within rounding
    // (`the_vectorised_general_path_keeps_the_row_by_row_sums_within_rounding`). The cycles
    // kept their bits.
    //
    // Re-pinned when grade noise came to turn (−g cos θ, g sin θ) by the short series of its
    // small angle (`numeric::trig::turn`, README "Determinism"): the conditions with
    // grade_sd = 0.01 moved, within rounding (θ̂ within 4e-12 relative; compared column by
    // column against commit a93bf2b at R = 64), those with grade_sd = 0 and the cycles
    // kept their bits.
    let (hashes, controls, spread) = pinned_hashes(&text);
    assert_eq!(
        hashes,
        [
            0xc83b_1c2b_ca9f_6399,
            0x73c0_e9a7_66a4_41d9,
            // The same two cycles as above (noise does not change them), stored once.
            0x4e72_a879_eb9a_ef79
        ]
    );
    // The control variates (the centred sums, whose last bits moved with the sums).
    assert_eq!(controls, [0xfaba_8caa_11ec_a387, 0xc404_a1a1_f0c3_d870]);
    // The spread by control variates.
    assert_eq!(spread, 0x0b15_1fbe_31f1_668c);
}

#[test]
fn refactors_keep_the_differentiated_kernel_bit_for_bit() {
    // A differentiated acceleration (its noise summed on the fast path like output noise)
    // with WBCLS and RLS reading the rows: pinned on the engine that moved it there
    // (README "Determinism").
    let text = set_key(
        &study_text("bias_compensation.toml"),
        "scales",
        "[1.0, 2.0]",
    );
    let text = set_key(&text, "velocity_sd", "[0.5]");
    let text = set_key(
        &text,
        "estimators",
        "[\"ols\", \"bcls\", \"wbcls\", \"rls\"]\nacceleration = \"differentiated\"",
    );
    let study = chassis_mc::study::Study::from_toml(&text, "pinned")
        .unwrap()
        .with_overrides(Some(64), None)
        .unwrap();
    let (dir, _) = run(&study, None);
    let found = ["realisations", "summary"].map(|name| {
        let table = read_table(&dir.path().join(format!("{name}.parquet")));
        hash_columns(&table, &|name| !identification_column(name))
    });
    println!("differentiated kernel's hashes: {found:016x?}");
    assert_eq!(found, [0xfd2d_a145_5db5_e16e, 0x7f43_c43c_491b_848a]);
}

#[test]
fn summary_rows_read_back_equal_the_rows_written() {
    use chassis_mc::stats::columns::SummaryColumn;
    // The typed decoder is the writer's inverse: every measure of every row, to the bit
    // (NaN where a measure is undefined or a bound does not apply).
    let (dir, report) = run(&study("bias_compensation.toml", 30), None);
    let table =
        chassis_mc::output::read_summary(&dir.path().join("summary.parquet"), &report.layout)
            .unwrap();
    assert_eq!(table.rows.len(), report.summary.len());
    let columns = SummaryColumn::all(&report.layout);
    for (read, written) in table.rows.iter().zip(&report.summary) {
        assert_eq!(
            (
                read.condition,
                read.estimator,
                read.parameter,
                read.n,
                read.n_failed
            ),
            (
                written.condition,
                written.estimator,
                written.parameter,
                written.n,
                written.n_failed
            )
        );
        assert_eq!(read.truth.to_bits(), written.truth.to_bits());
        for c in &columns {
            let bits = |row| c.measure_value(row).map(f64::to_bits);
            let (a, b) = (bits(read), bits(written));
            // Non-finite values are written as nulls and read back as NaN.
            let finite = c.measure_value(written).is_none_or(f64::is_finite);
            assert!(
                a == b || !finite,
                "{}: {a:?} vs {b:?}",
                c.name(&report.layout)
            );
        }
        assert_eq!(table.info(read).axes, report.infos[read.condition].axes);
    }
}

#[test]
fn realisations_computed_side_by_side_are_each_computed_alone_bit_for_bit() {
    // The executor computes a condition's realisations in small batches (its data read once
    // per batch); each must be what `realise` gives it alone: white speed and output noise,
    // AR(1) speed noise (filtered for the batch's realisations side by side), and AR(1)
    // speed noise over a differentiated acceleration's span (the spans filtered side by
    // side, each realisation then measured alone) with estimators that read the rows.
    use chassis_mc::model::Model;
    use chassis_mc::model::vehicle::VehicleModel;
    let differentiated = "[\"ols\", \"wbcls\", \"rls\"]\nacceleration = \"differentiated\"";
    for (extra, estimators) in [
        ("output_sd = [0.05]", r#"["ols"]"#),
        (
            "output_sd = [0.0]\nvelocity_correlation_time = [0.5]",
            r#"["ols"]"#,
        ),
        (
            "output_sd = [0.0]\nvelocity_correlation_time = [0.5]",
            differentiated,
        ),
    ] {
        let text = set_key(&study_text("thesis.toml"), "scales", "[1.3]")
            .replacen("output_sd = [0.0] ", "# ", 1)
            .replace("[noise]", &format!("[noise]\n{extra}"));
        let text = set_key(&text, "estimators", estimators);
        let study = chassis_mc::study::Study::from_toml(&text, "batched").unwrap();
        let model = VehicleModel::new(&study).unwrap();
        let stride = model.layout().realisation_stride();
        // A short batch, and one of the executor's eight (filtered by its own loop).
        for (first, n) in [(1021u64, 5usize), (2042, 8)] {
            let mut together = vec![0.0; n * stride];
            model.realise_group(2018, &[0], first, n, &mut together);
            for i in 0..n {
                let mut alone = vec![0.0; stride];
                model.realise(2018, 0, first + i as u64, &mut alone);
                let got = &together[i * stride..(i + 1) * stride];
                assert_eq!(
                    got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    alone.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "{extra} {estimators}: realisation {} of a batch of {n}",
                    first + i as u64
                );
            }
        }
    }
}

#[test]
fn refactors_keep_the_drawn_entries_bit_for_bit() {
    // Gusts (each realisation integrated again), a random force calibration and the map's
    // error, with speed noise, on a 60 s thesis drive: pinned on the engine that introduced
    // them (commit 6432158); the gusts' faster time lookup after it gives the same hashes.
    let text = study_text("thesis.toml");
    let text = set_key(&text, "duration", "60.0");
    let text = set_key(&text, "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", "[0.3]\ngrade_map_sd = [0.0, 0.02]");
    let text = set_key(&text, "estimators", "[\"ols\", \"bcls\"]");
    let text = format!("{text}\n[truth]\nwind_gust_sd = [1.5]\nforce_scale_sd = [0.03]\n");
    let study = chassis_mc::study::Study::from_toml(&text, "pinned")
        .unwrap()
        .with_overrides(Some(16), None)
        .unwrap();
    let (dir, _) = run(&study, None);
    // The spread's control-variate columns came later; no control applies where each
    // realisation has its own truth, so they are null here (checked), and left out.
    let summary = read_table(&dir.path().join("summary.parquet"));
    for field in summary.schema().fields() {
        if spread_column(field.name()) {
            let column = summary.column_by_name(field.name()).unwrap();
            assert_eq!(column.null_count(), column.len(), "{}", field.name());
        }
    }
    // The coast-down's columns came later too: `runs` (1) and cycles.parquet's `run` (0),
    // checked and left out.
    let tables = ["realisations", "summary", "cycles"]
        .map(|name| read_table(&dir.path().join(format!("{name}.parquet"))));
    for table in &tables[..2] {
        assert!(f64_col(table, "runs").iter().all(|&k| k == 1.0));
    }
    assert!(i32_col(&tables[2], "run").iter().all(|&r| r == 0));
    let found = tables.each_ref().map(|table| {
        hash_columns(table, &|name| {
            !spread_column(name) && !identification_column(name) && name != "runs" && name != "run"
        })
    });
    println!("drawn entries' hashes: {found:016x?}");
    assert_eq!(
        found,
        [
            // Re-pinned with the compensated sandwich (docs/model.md#compensated-sandwich):
            // BCLS's sandwich columns alone moved (compared column by column against commit
            // 0ba1550, R = 16). Re-pinned again when the map's grade came to enter by its
            // tangent's sine and cosine, not sin(atan t) (docs/model.md#grade-map): the
            // conditions with the map moved, their regression's sums within 1e-12
            // relative (world/map.rs's test), the estimates within 5e-12 (compared column by
            // column against commit 66f7b02, R = 16); cycles.parquet did not.
            0x689e_59ca_c092_186f,
            0x11ce_45cc_a477_9735,
            0x40c9_86a7_226e_182a
        ]
    );
}

#[test]
fn refactors_keep_the_row_scans_bit_for_bit() {
    // WBCLS's segment moments and RLS's running sums over the rows (docs/model.md,
    // "Estimators that read the rows"): the thesis path (only w moved), with forgetting,
    // with output noise (ỹ moved), with grade noise (x̃₃ and ỹ moved) and on each
    // realisation's own regression. Pinned on the engine before RLS took the states of the
    // terms of noise-free columns from its plan (commit 9bee3d7); the case with grade noise
    // re-pinned when grade noise came to turn its gravity terms by the short series of its
    // small angle (the general kernel's test above).
    let cases = [
        ("[0.0]", "", "", ""),
        ("[0.0]", "", "\nforgetting = 0.995", ""),
        ("[0.05]", "", "", ""),
        ("[0.0]", "\ngrade_sd = [0.01]", "", ""),
        // A random force calibration: each realisation's own regression.
        ("[0.0]", "", "", "\n[truth]\nforce_scale_sd = [0.03]\n"),
    ];
    let mut found = Vec::new();
    for (output, grade, estimation, truth) in cases {
        let text = set_key(&study_text("bias_compensation.toml"), "scales", "[1.0]");
        let text = set_key(&text, "velocity_sd", &format!("[0.5]{grade}"));
        let text = set_key(&text, "output_sd", output);
        let text = set_key(
            &text,
            "estimators",
            &format!("[\"ols\", \"wbcls\", \"rls\"]{estimation}"),
        );
        let text = format!("{text}{truth}");
        let study = chassis_mc::study::Study::from_toml(&text, "pinned")
            .unwrap()
            .with_overrides(Some(32), None)
            .unwrap();
        let (dir, _) = run(&study, None);
        for name in ["realisations", "summary"] {
            let table = read_table(&dir.path().join(format!("{name}.parquet")));
            found.push(hash_columns(&table, &|name| !identification_column(name)));
        }
    }
    println!("row scans' hashes: {found:016x?}");
    assert_eq!(
        found,
        [
            0x48ae_7793_8259_998c,
            0x7fd4_a65b_6316_6e3b,
            0x1865_199b_db9a_7971,
            0x8793_7c34_d4b4_da80,
            0x91a6_bd4a_7bb4_b978,
            0x2ebf_e92e_574f_d191,
            0xbcfa_4174_86a5_3bbe,
            0x9bfe_7935_0e71_df73,
            0x808d_ee45_156f_b98d,
            0xbe3c_1f33_3fbe_94e5,
        ]
    );
}
