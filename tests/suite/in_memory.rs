//! A run held in memory gives the tables a run into a directory writes, bit for bit, and a
//! study's shards assembled by `summarize_assembled` give its realisation file byte for
//! byte (the Python package's `run` without `out`, and its `shards` + `summarize`).

use arrow::array::RecordBatch;
use chassis_mc::montecarlo::Silent;
use chassis_mc::run::{extra_tables_in_memory, run_in_memory, summarize_assembled};

use super::common::*;

fn whole(batches: &[RecordBatch]) -> RecordBatch {
    arrow::compute::concat_batches(&batches[0].schema(), batches).unwrap()
}

/// The columns of two tables equal value for value (floats by their bits: NaN = NaN, −0 ≠ 0;
/// a null equals a null), names and types too.
fn assert_same(a: &RecordBatch, b: &RecordBatch, what: &str) {
    assert_eq!(a.num_rows(), b.num_rows(), "{what}: rows");
    assert_eq!(a.schema().fields(), b.schema().fields(), "{what}: columns");
    for (k, (x, y)) in a.columns().iter().zip(b.columns()).enumerate() {
        assert_eq!(x.to_data(), y.to_data(), "{what}: column {k} differs");
    }
}

#[test]
fn a_run_in_memory_holds_the_tables_a_run_writes() {
    // The thesis's 11 scales and an R that is not a multiple of the chunk, computed on
    // another thread count: the same rows in the same order as the files.
    let study = study("thesis.toml", 37);
    let (dir, _) = run(&study, Some(2));
    let held = run_in_memory(&study, Some(1), &Silent).unwrap();
    assert_eq!(held.computed, 11 * 37);
    assert_same(
        &whole(&held.realisations.batches),
        &read_table(&dir.path().join("realisations.parquet")),
        "realisations",
    );
    assert_same(
        &whole(&held.summary.batches),
        &read_table(&dir.path().join("summary.parquet")),
        "summary",
    );
    let cycles = extra_tables_in_memory(&study, None).unwrap();
    assert_eq!(cycles.len(), 1);
    assert_same(
        &whole(&cycles[0].batches),
        &read_table(&dir.path().join(cycles[0].file)),
        "cycles",
    );
    // the footer's identity travels with the tables
    let identity = held.summary.schema.metadata().get("chassis_mc.identity");
    assert!(identity.is_some_and(|i| i.starts_with(&study.identity())));
}

#[test]
fn shards_assembled_by_summarize_are_the_files_of_one_run() {
    let study = study("thesis.toml", 29); // 29 does not divide by 3
    let (dir, _) = run(&study, None);
    let shards = tempfile::tempdir().unwrap();
    run_shards(&study, shards.path(), &[1, 2, 0]);
    let out = tempfile::tempdir().unwrap();
    let inputs: Vec<_> = [2, 0, 1]
        .map(|k| shards.path().join(format!("shard={k}")))
        .to_vec();
    summarize_assembled(&inputs, out.path(), false).unwrap();
    for name in ["realisations.parquet", "summary.parquet", "cycles.parquet"] {
        let read = |d: &std::path::Path| std::fs::read(d.join(name)).unwrap();
        assert!(read(dir.path()) == read(out.path()), "{name} differs");
    }
}
