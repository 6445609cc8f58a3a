//! Shared helpers: load the shipped studies, run them into temporary directories, read
//! Parquet columns back.

#![allow(dead_code)]

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use arrow::array::{Array, Float64Array, Int32Array, Int64Array, RecordBatch, StringArray};
use chassis_mc::montecarlo::Silent;
use chassis_mc::run::{RunOptions, RunReport, Shard, run_study};
use chassis_mc::study::Study;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A shipped study file.
pub fn study_path(name: &str) -> PathBuf {
    root().join("studies").join(name)
}

/// Text of a shipped study file.
pub fn study_text(name: &str) -> String {
    std::fs::read_to_string(study_path(name)).unwrap()
}

/// Load a shipped study with `realisations` per condition.
pub fn study(name: &str, realisations: u64) -> Study {
    Study::load(&study_path(name))
        .unwrap()
        .with_overrides(Some(realisations), None)
        .unwrap()
}

/// Replace the line starting with `key =` in `text` by `key = value`.
pub fn set_key(text: &str, key: &str, value: &str) -> String {
    let mut found = false;
    let out: Vec<String> = text
        .lines()
        .map(|l| {
            if l.trim_start().starts_with(&format!("{key} =")) && !found {
                found = true;
                format!("{key} = {value}")
            } else {
                l.to_string()
            }
        })
        .collect();
    assert!(found, "no key {key}");
    out.join("\n") + "\n"
}

/// `studies/bias_compensation.toml` (the thesis sweep, OLS and BCLS, speed noise) at the
/// terrain `scales` and `velocity_sd` levels given (TOML arrays), with R = `realisations`
/// and the study's seed unless `seed` is given.
pub fn speed_noise_study(
    scales: &str,
    velocity_sd: &str,
    realisations: u64,
    seed: Option<u64>,
) -> Study {
    let text = set_key(&study_text("bias_compensation.toml"), "scales", scales);
    let text = set_key(&text, "velocity_sd", velocity_sd);
    Study::from_toml(&text, "bias_compensation")
        .unwrap()
        .with_overrides(Some(realisations), seed)
        .unwrap()
}

/// Run `study` into a fresh temporary directory.
pub fn run(study: &Study, threads: Option<usize>) -> (tempfile::TempDir, RunReport) {
    let dir = tempfile::tempdir().unwrap();
    let mut options = RunOptions::new(dir.path());
    options.threads = threads;
    let report = run_study(study, &options, &Silent).unwrap();
    (dir, report)
}

/// Run `study` into `dir` as `order.len()` shards, in the order given (a cluster finishes
/// them in any order); each writes its realisations and no summary of its own.
pub fn run_shards(study: &Study, dir: &Path, order: &[u64]) {
    for &k in order {
        let mut options = RunOptions::new(dir);
        options.shard = Some(Shard {
            index: k,
            count: order.len() as u64,
        });
        let report = run_study(study, &options, &Silent).unwrap();
        assert!(report.summary.is_empty(), "shard {k} wrote a summary");
    }
}

/// Run `study` (figures too, as every run draws them) and read its summary.parquet.
pub fn run_summary(study: &Study) -> RecordBatch {
    let (dir, _) = run(study, None);
    read_table(&dir.path().join("summary.parquet"))
}

/// All record batches of a Parquet file.
pub fn read_batches(path: &Path) -> Vec<RecordBatch> {
    let file = File::open(path).unwrap();
    ParquetRecordBatchReaderBuilder::try_new(file)
        .unwrap()
        .build()
        .unwrap()
        .map(|b| b.unwrap())
        .collect()
}

/// One whole table, concatenated.
pub fn read_table(path: &Path) -> RecordBatch {
    let batches = read_batches(path);
    arrow::compute::concat_batches(&batches[0].schema(), &batches).unwrap()
}

/// A double column (nulls as NaN).
pub fn f64_col(batch: &RecordBatch, name: &str) -> Vec<f64> {
    let a = batch
        .column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<Float64Array>()
        .unwrap();
    (0..a.len())
        .map(|i| if a.is_null(i) { f64::NAN } else { a.value(i) })
        .collect()
}

/// An int32 column.
pub fn i32_col(batch: &RecordBatch, name: &str) -> Vec<i32> {
    let a = batch
        .column_by_name(name)
        .unwrap()
        .as_any()
        .downcast_ref::<Int32Array>()
        .unwrap();
    a.values().to_vec()
}

/// An int64 column.
pub fn i64_col(batch: &RecordBatch, name: &str) -> Vec<i64> {
    let a = batch
        .column_by_name(name)
        .unwrap()
        .as_any()
        .downcast_ref::<Int64Array>()
        .unwrap();
    a.values().to_vec()
}

/// A string column.
pub fn str_col(batch: &RecordBatch, name: &str) -> Vec<String> {
    let a = batch
        .column_by_name(name)
        .unwrap()
        .as_any()
        .downcast_ref::<StringArray>()
        .unwrap();
    (0..a.len()).map(|i| a.value(i).to_string()).collect()
}

/// A Boolean column of a batch, as values.
pub fn bool_col(batch: &RecordBatch, name: &str) -> Vec<bool> {
    use arrow::array::Array;
    let a = batch
        .column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<arrow::array::BooleanArray>()
        .unwrap_or_else(|| panic!("{name} is not Boolean"));
    (0..a.len()).map(|i| a.value(i)).collect()
}

/// Path of the `chassis-mc` binary built for these tests.
pub fn bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_chassis-mc"))
}

/// Parameter names in output order.
pub const PARAMS: [&str; 3] = ["inv_mass", "drag_over_mass", "rolling_resistance"];

/// Run the binary with `args` in a fresh working directory; (exit code, stdout, stderr).
pub fn cli(args: &[&std::ffi::OsStr], cwd: &Path) -> (i32, String, String) {
    let output = Command::new(bin())
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    (
        output.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// The three tables of two runs hold the same columns, value for value (not the same
/// schemas: the footer records the study text, which may differ).
pub fn assert_same_tables(a: &Path, b: &Path) {
    for name in ["realisations.parquet", "summary.parquet", "cycles.parquet"] {
        let (x, y) = (read_table(&a.join(name)), read_table(&b.join(name)));
        assert_eq!(x.columns(), y.columns(), "{name}");
    }
}

/// Feed `h` every value of `batch`'s columns that `keep` names, column by column in row
/// order: the column's name, then per row 0 for a null, else 1 and the value (a double by
/// its bits). A fingerprint of the values that ignores the file's encoding and footer.
pub fn hash_columns_into(
    h: &mut impl std::hash::Hasher,
    batch: &RecordBatch,
    keep: &dyn Fn(&str) -> bool,
) {
    use arrow::array::AsArray;
    use arrow::datatypes::{DataType, Float64Type, Int32Type, Int64Type};
    for (field, column) in batch.schema().fields().iter().zip(batch.columns()) {
        if !keep(field.name()) {
            continue;
        }
        h.write(field.name().as_bytes());
        for i in 0..column.len() {
            if column.is_null(i) {
                h.write_u8(0);
                continue;
            }
            h.write_u8(1);
            match field.data_type() {
                DataType::Float64 => {
                    h.write_u64(column.as_primitive::<Float64Type>().value(i).to_bits())
                }
                DataType::Int32 => h.write_i32(column.as_primitive::<Int32Type>().value(i)),
                DataType::Int64 => h.write_i64(column.as_primitive::<Int64Type>().value(i)),
                DataType::Utf8 => h.write(column.as_string::<i32>().value(i).as_bytes()),
                DataType::Boolean => h.write_u8(column.as_boolean().value(i) as u8),
                other => panic!("{}: no hash for {other}", field.name()),
            }
        }
    }
}

/// XXH64 (seed 0) of [`hash_columns_into`].
pub fn hash_columns(batch: &RecordBatch, keep: &dyn Fn(&str) -> bool) -> u64 {
    use std::hash::Hasher;
    let mut h = twox_hash::XxHash64::with_seed(0);
    hash_columns_into(&mut h, batch, keep);
    h.finish()
}
