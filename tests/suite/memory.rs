//! Memory that must not grow with the number of conditions, measured as the heap this
//! thread holds at most (a counting allocator: exact and repeatable, unlike the resident
//! size of a process shared with other tests).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use chassis_mc::numeric::sum::ExactSum;
use chassis_mc::run::summarise_files;
use chassis_mc::stats::measures::Z_95;
use chassis_mc::stats::summary::ConditionSummarizer;

use super::common::*;

/// The system allocator, counting the bytes each thread has allocated and not yet freed.
struct Counting;

thread_local! {
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

fn count(delta: isize) {
    let _ = LIVE.try_with(|live| {
        let now = live.get() + delta;
        live.set(now);
        let _ = PEAK.try_with(|peak| peak.set(peak.get().max(now)));
    });
}

// SAFETY: every call is passed on to the system allocator unchanged; the counting touches
// only const-initialised thread-locals, which never allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        count(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            count(new_size as isize - layout.size() as isize);
        }
        p
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

/// The most heap this thread held above what it held before, while running `f` [bytes].
fn peak_heap<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let start = LIVE.with(Cell::get);
    PEAK.with(|p| p.set(start));
    let out = f();
    (out, (PEAK.with(Cell::get) - start) as usize)
}

/// The thesis study at one scale with `n` speed-noise levels (n conditions), OLS and BCLS,
/// R = 4.
fn conditions(n: usize) -> chassis_mc::Study {
    let levels: Vec<String> = (1..=n)
        .map(|k| format!("{:.3}", k as f64 / n as f64))
        .collect();
    let text = set_key(&study_text("thesis.toml"), "scales", "[1.0]");
    let text = set_key(&text, "velocity_sd", &format!("[{}]", levels.join(", ")));
    let text = set_key(&text, "estimators", "[\"ols\", \"bcls\"]");
    chassis_mc::Study::from_toml(&text, "memory")
        .unwrap()
        .with_overrides(Some(4), None)
        .unwrap()
}

#[test]
fn summary_memory_does_not_grow_with_the_number_of_conditions() {
    let mut peaks = Vec::new();
    let mut per_condition_accumulators = 0;
    for n in [10, 100] {
        let study = conditions(n);
        let tmp = tempfile::tempdir().unwrap();
        let mut options = chassis_mc::RunOptions::new(tmp.path());
        options.figures = false;
        let report =
            chassis_mc::run_study(&study, &options, &chassis_mc::montecarlo::Silent).unwrap();
        assert_eq!(report.infos.len(), n);
        let path = tmp.path().join("realisations.parquet");
        let file = chassis_mc::output::OpenedFile::open(&path).unwrap();
        let (rows, peak) = peak_heap(|| {
            summarise_files(
                &report.layout,
                &report.infos,
                4,
                std::slice::from_ref(&file),
            )
            .unwrap()
        });
        // (compared as text: NaN, where a measure is undefined, equals itself there)
        assert_eq!(
            format!("{rows:?}"),
            format!("{:?}", report.summary),
            "the same summary as the run's"
        );
        // What one condition's summary holds: its exact accumulators.
        let one = ConditionSummarizer::new(&report.layout, 0, &report.infos[0], 4, Z_95);
        per_condition_accumulators = one.accumulators() * size_of::<ExactSum>();
        peaks.push((n, peak));
    }
    let [(n0, p0), (n1, p1)] = peaks[..] else {
        unreachable!()
    };
    let growth = (p1 as f64 - p0 as f64) / (n1 - n0) as f64;
    println!(
        "summary's peak heap: {p0} B at {n0} conditions, {p1} B at {n1}; {growth:.0} B per \
         added condition; one condition's accumulators {per_condition_accumulators} B"
    );
    // Holding every condition's accumulators at once grows the peak by at least one
    // condition's accumulators per condition added. Streaming the conditions holds one at a
    // time: what still grows is the summary rows returned (6 per condition, a few hundred
    // bytes each) and the file's footer, so the growth must stay below that bound.
    assert!(
        growth < per_condition_accumulators as f64,
        "the summary's memory grows by {growth:.0} B per condition, as much as holding every \
         condition's accumulators ({per_condition_accumulators} B each)"
    );
}

/// The realisation file's row groups hold [`ROW_GROUP_ROWS`] rows across conditions: with a
/// row group per condition, the writer kept every row group's metadata (a column chunk's
/// statistics and offsets for each of the file's ~150 columns) until it closed the file,
/// and every reader loaded it again: a 10 000-condition grid at R = 20 peaked at 795 MB
/// (`benches/grid_memory.py`). The footer now grows with the rows, not the conditions.
///
/// [`ROW_GROUP_ROWS`]: chassis_mc::output::ROW_GROUP_ROWS
#[test]
fn the_realisation_files_footer_does_not_grow_with_the_number_of_conditions() {
    let mut footers = Vec::new();
    for n in [10, 100] {
        let study = conditions(n);
        let tmp = tempfile::tempdir().unwrap();
        let mut options = chassis_mc::RunOptions::new(tmp.path());
        options.figures = false;
        chassis_mc::run_study(&study, &options, &chassis_mc::montecarlo::Silent).unwrap();
        let path = tmp.path().join("realisations.parquet");
        let file = std::fs::File::open(&path).unwrap();
        let reader = parquet::file::serialized_reader::SerializedFileReader::new(file).unwrap();
        use parquet::file::reader::FileReader;
        let meta = reader.metadata();
        // n conditions × 4 realisations × 2 estimators rows: one row group.
        let rows = (n * 4 * 2) as i64;
        assert_eq!(meta.file_metadata().num_rows(), rows);
        assert_eq!(
            meta.num_row_groups(),
            (rows as usize).div_ceil(chassis_mc::output::ROW_GROUP_ROWS),
            "{n} conditions"
        );
        // The footer's length: the file's last 8 bytes are its length and "PAR1".
        let bytes = std::fs::read(&path).unwrap();
        let tail = &bytes[bytes.len() - 8..bytes.len() - 4];
        footers.push(u32::from_le_bytes(tail.try_into().unwrap()) as f64);
    }
    // Ninety conditions more add nothing but the study text in the footer (its list of
    // 90 more noise levels, about 6 bytes each): far below one column chunk's metadata per
    // column (~150 × ~100 bytes per condition with a row group each).
    let growth = (footers[1] - footers[0]) / 90.0;
    assert!(
        growth < 50.0,
        "the footer grows by {growth:.0} B per condition: {footers:?}"
    );
}
