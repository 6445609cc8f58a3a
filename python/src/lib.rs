//! `chassis_mc._core`: the Rust side of the Python package. Each function is a thin call of
//! the library the command line calls, so a study run from Python writes the bytes the
//! `chassis-mc` command writes for the same study and seed; `python/chassis_mc/__init__.py`
//! turns the arguments into these calls and the tables they hand over (in memory, through
//! the Arrow C stream interface: `tables.rs`) into pyarrow tables.
//!
//! Long calls run on a worker thread while the calling thread waits with the GIL released,
//! taking it back every 100 ms to report progress and notices to Python callbacks and to
//! check for Ctrl-C: a KeyboardInterrupt asks a run to stop after the chunk it is writing
//! (its completed parts stay in the output directory, so running it again resumes;
//! `supervise.rs`).

use std::path::PathBuf;

use chassis_mc::check::StudyCheck;
use chassis_mc::design::{DesignError, DesignKey, DesignRequest, DesignTarget, answer_sentence};
use chassis_mc::fit::FitError;
use chassis_mc::run::{RunError, RunOptions, Shard, TableInMemory, run_study};
use chassis_mc::study::{Study, StudyError};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

mod source;
mod supervise;
mod tables;
use supervise::{Watch, supervise};
use tables::ArrowTable;

/// The origin a study or fit file given as a dict is reported under.
const DICT_ORIGIN: &str = "<dict>";

/// How a pickled object is rebuilt: the function and its arguments (values, origin, dir).
type Reduced<'py> = (Bound<'py, PyAny>, (Bound<'py, PyAny>, String, PathBuf));

/// A validated study (`chassis_mc.load` returns one; every call takes one).
#[pyclass(module = "chassis_mc._core", name = "Study", frozen)]
struct PyStudy(Study);

#[pymethods]
impl PyStudy {
    /// The study's name.
    #[getter]
    fn name(&self) -> &str {
        self.0.name()
    }

    /// The master seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.0.seed()
    }

    /// Realisations per condition.
    #[getter]
    fn realisations(&self) -> u64 {
        self.0.realisations()
    }

    /// Where it was read from: a path, `<string>` or `<dict>`.
    #[getter]
    fn origin(&self) -> &str {
        self.0.origin()
    }

    /// The study as run, as canonical TOML (overrides applied).
    fn to_toml(&self) -> String {
        self.0.to_toml()
    }

    /// The directory its relative data paths resolve against.
    #[getter]
    fn dir(&self) -> PathBuf {
        self.0.dir().to_path_buf()
    }

    /// What makes two runs' realisations interchangeable (the study as run without its
    /// realisation count, and the engine version): the start of the `chassis_mc.identity`
    /// in the footer of every file a run of it writes.
    fn identity(&self) -> String {
        self.0.identity()
    }

    /// Pickled as its values as run (a dict of its tables and keys), origin and directory;
    /// unpickling validates it again (and reads its data files, e.g. a speed trace, from the
    /// same paths).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Reduced<'py>> {
        let rebuild = py
            .import("chassis_mc._core")?
            .getattr("_study_from_values")?;
        let values = source::py_value(py, &toml::Value::Table(self.0.to_table()))?;
        Ok((
            rebuild,
            (
                values,
                self.0.origin().to_string(),
                self.0.dir().to_path_buf(),
            ),
        ))
    }

    /// The same study with its realisations and seed overridden (its data paths kept).
    #[pyo3(signature = (realisations=None, seed=None))]
    fn with_overrides(
        &self,
        py: Python<'_>,
        realisations: Option<u64>,
        seed: Option<u64>,
    ) -> PyResult<PyStudy> {
        self.0
            .clone()
            .with_overrides(realisations, seed)
            .map(PyStudy)
            .map_err(|e| study_error(py, &e))
    }

    fn __repr__(&self) -> String {
        format!(
            "Study(name={:?}, seed={}, realisations={}, origin={:?})",
            self.0.name(),
            self.0.seed(),
            self.0.realisations(),
            self.0.origin()
        )
    }
}

/// `chassis_mc.StudyError(message, file, key, line, reason)`, from the library's error. A
/// dict has no lines, so its errors carry none.
fn study_error(py: Python<'_>, e: &StudyError) -> PyErr {
    let line = if e.file == DICT_ORIGIN { None } else { e.line };
    let e = StudyError { line, ..e.clone() };
    raise(
        py,
        "StudyError",
        (
            e.to_string(),
            e.file.clone(),
            e.key.clone(),
            line,
            e.reason.clone(),
        ),
    )
}

/// `chassis_mc.RunError(message, bad_input)`.
fn run_error(py: Python<'_>, message: String, bad_input: bool) -> PyErr {
    raise(py, "RunError", (message, bad_input))
}

/// An instance of `chassis_mc._errors.<class>` built from `args`, as a Python exception.
fn raise<'py, A>(py: Python<'py>, class: &str, args: A) -> PyErr
where
    A: pyo3::call::PyCallArgs<'py>,
{
    let made = py
        .import("chassis_mc._errors")
        .and_then(|m| m.getattr(class))
        .and_then(|c| c.call1(args));
    match made {
        Ok(instance) => PyErr::from_value(instance),
        Err(e) => e,
    }
}

fn from_run_error(py: Python<'_>, e: RunError) -> PyErr {
    match e {
        RunError::Study(s) => study_error(py, &s),
        RunError::Interrupted { .. } | RunError::Stopped => {
            PyKeyboardInterrupt::new_err(e.to_string())
        }
        e => {
            let bad = e.is_bad_input();
            run_error(py, e.to_string(), bad)
        }
    }
}

fn from_fit_error(py: Python<'_>, e: FitError) -> PyErr {
    match e {
        FitError::Study(s) => study_error(py, &s),
        e => {
            let bad = e.is_bad_input();
            run_error(py, e.to_string(), bad)
        }
    }
}

fn from_design_error(py: Python<'_>, e: DesignError) -> PyErr {
    match e {
        DesignError::Study(s) | DesignError::Run(RunError::Study(s)) => study_error(py, &s),
        DesignError::Request(reason) => PyValueError::new_err(reason),
        e => {
            let bad = e.is_bad_input();
            run_error(py, e.to_string(), bad)
        }
    }
}

/// Whether `text` parses as TOML (the package's test of a str that names no file).
#[pyfunction]
fn parses_as_toml(text: &str) -> bool {
    text.parse::<toml::Table>().is_ok()
}

/// Load and validate a study given as exactly one of `path`, `text` (TOML) or `dict` (its
/// tables and keys as Python values, which cross as typed values: no TOML text);
/// `realisations` and `seed` override the study's, as `--realisations` and `--seed` do;
/// `base` is the directory the relative data paths of TOML text or a dict resolve against
/// (default: the working directory).
#[pyfunction]
#[pyo3(signature = (*, path=None, text=None, dict=None, realisations=None, seed=None, base=None))]
#[allow(clippy::too_many_arguments)]
fn load_study(
    py: Python<'_>,
    path: Option<PathBuf>,
    text: Option<String>,
    dict: Option<Bound<'_, PyDict>>,
    realisations: Option<u64>,
    seed: Option<u64>,
    base: Option<PathBuf>,
) -> PyResult<PyStudy> {
    let source = source::Source::given(py, path, text, dict, base, "study")?;
    let study = source
        .study()
        .and_then(|s| s.with_overrides(realisations, seed))
        .map_err(|e| study_error(py, &e))?;
    Ok(PyStudy(study))
}

/// A study from its values as run (a dict), its origin and directory: how a pickled Study
/// comes back, validated again.
#[pyfunction]
fn _study_from_values(
    py: Python<'_>,
    values: Bound<'_, PyDict>,
    origin: &str,
    dir: PathBuf,
) -> PyResult<PyStudy> {
    let table = source::table_of(py, &values)?;
    Study::from_table_in(table, origin, &dir)
        .map(PyStudy)
        .map_err(|e| study_error(py, &e))
}

/// A study from the TOML text of an output file's footer, its origin and directory.
#[pyfunction]
fn _study_from_toml(py: Python<'_>, text: &str, origin: &str, dir: PathBuf) -> PyResult<PyStudy> {
    Study::from_toml_in(text, origin, &dir)
        .map(PyStudy)
        .map_err(|e| study_error(py, &e))
}

/// The tables a run of `study` computes besides its realisations and summary (the
/// vehicle's cycles.parquet), computed again from the study in memory: (file name, table)
/// pairs, none for a model without such tables.
#[pyfunction]
#[pyo3(signature = (study, threads=None))]
fn cycles(
    py: Python<'_>,
    study: &PyStudy,
    threads: Option<usize>,
) -> PyResult<Vec<(&'static str, ArrowTable)>> {
    let watch = Watch::default();
    let tables = supervise(py, &watch, None, None, || {
        chassis_mc::run::extra_tables_in_memory(&study.0, threads)
    })?
    .map_err(|e| from_run_error(py, e))?;
    Ok(tables.into_iter().map(|t| (t.file, table(t))).collect())
}

fn table(t: TableInMemory) -> ArrowTable {
    ArrowTable::new(t.schema, t.batches)
}

/// What `run` returns: the tables it computed and, with an output directory, the files.
#[pyclass(module = "chassis_mc._core", name = "RunOutput", frozen, get_all)]
struct RunOutput {
    /// summary.parquet's table, in memory.
    summary: Py<ArrowTable>,
    /// realisations.parquet's table in memory (with `out`, the rows the file holds, earlier
    /// runs' it kept among them), or None for a shard.
    realisations: Option<Py<ArrowTable>>,
    /// The files written (none without `out`).
    files: Vec<PathBuf>,
    /// Realisations kept from an earlier run in `out`.
    reused: u64,
    /// Realisations computed.
    computed: u64,
}

/// Run `study` (the CLI's `run`): into `out` when given, else held in memory with no file
/// created; `shard` (index, count) runs one shard of every condition into
/// `out/shard=index/`, as `--shard index/count`.
#[pyfunction]
#[pyo3(signature = (study, out=None, threads=None, figures=true, progress=None, notice=None, shard=None))]
#[allow(clippy::too_many_arguments)]
fn run(
    py: Python<'_>,
    study: &PyStudy,
    out: Option<PathBuf>,
    threads: Option<usize>,
    figures: bool,
    progress: Option<&Bound<'_, PyAny>>,
    notice: Option<&Bound<'_, PyAny>>,
    shard: Option<(u64, u64)>,
) -> PyResult<RunOutput> {
    let watch = Watch::default();
    let Some(out) = out else {
        if shard.is_some() {
            return Err(PyValueError::new_err(
                "a shard is run into an output directory (out=): its rows are for summarize",
            ));
        }
        let ran = supervise(py, &watch, progress, notice, || {
            chassis_mc::run::run_in_memory(&study.0, threads, &watch)
        })?
        .map_err(|e| from_run_error(py, e))?;
        return Ok(RunOutput {
            summary: Py::new(py, table(ran.summary))?,
            realisations: Some(Py::new(py, table(ran.realisations))?),
            files: Vec::new(),
            reused: 0,
            computed: ran.computed,
        });
    };
    let mut options = RunOptions::new(out);
    options.threads = threads;
    options.figures = figures && shard.is_none();
    // the table comes back with the file, not read from it again (a shard's is not needed)
    options.keep_realisations = shard.is_none();
    options.shard = match shard {
        Some((index, count)) => Some(
            Shard::parse(&format!("{index}/{count}"))
                .map_err(|e| PyValueError::new_err(format!("shard: {e}")))?,
        ),
        None => None,
    };
    let report = supervise(py, &watch, progress, notice, || {
        run_study(&study.0, &options, &watch)
    })?
    .map_err(|e| from_run_error(py, e))?;
    summary_output(py, report)
}

/// The [`RunOutput`] of a run or summary into a directory: its summary rows as a table, and
/// the realisation file's rows when the run kept them.
fn summary_output(py: Python<'_>, report: chassis_mc::run::RunReport) -> PyResult<RunOutput> {
    use chassis_mc::output::{footer_schema, realisation_schema, summary_batch, summary_schema};
    let meta = &report.metadata;
    let schema = footer_schema(summary_schema(&report.layout), meta, "summary");
    let summary = summary_batch(&report.layout, &report.infos, &report.summary)
        .map_err(|e| run_error(py, e.to_string(), false))?;
    let realisations = match report.realisations {
        Some(batches) => {
            let schema = footer_schema(realisation_schema(&report.layout), meta, "realisations");
            Some(Py::new(py, ArrowTable::new(schema, batches))?)
        }
        None => None,
    };
    Ok(RunOutput {
        summary: Py::new(py, ArrowTable::new(schema, vec![summary]))?,
        realisations,
        files: report.files,
        reused: report.reused,
        computed: report.computed,
    })
}

/// `summarize`: the realisations of `inputs` (shard directories or realisation files of one
/// study) summarised into `out`, as the CLI's `summarize`, and assembled into
/// `out/realisations.parquet`: the files of one run of the study, byte for byte.
#[pyfunction]
#[pyo3(signature = (inputs, out, figures=true))]
fn summarize(
    py: Python<'_>,
    inputs: Vec<PathBuf>,
    out: PathBuf,
    figures: bool,
) -> PyResult<RunOutput> {
    let watch = Watch::default();
    let report = supervise(py, &watch, None, None, || {
        chassis_mc::run::summarize_assembled(&inputs, &out, figures)
    })?
    .map_err(|e| from_run_error(py, e))?;
    summary_output(py, report)
}

/// What `check` returns.
#[pyclass(module = "chassis_mc._core", name = "CheckOutput", frozen, get_all)]
struct CheckOutput {
    /// The report the command prints.
    text: String,
    /// Per condition, the measured time of one realisation [ms].
    ms_per_realisation: Vec<f64>,
    /// The estimated run time [s].
    estimated_seconds: f64,
    /// The estimated size of every output file [bytes].
    output_bytes: f64,
}

/// `check`: the report the CLI prints, with its figures.
#[pyfunction]
#[pyo3(signature = (study, threads=None))]
fn check(py: Python<'_>, study: &PyStudy, threads: Option<usize>) -> PyResult<CheckOutput> {
    let watch = Watch::default();
    let found: StudyCheck = supervise(py, &watch, None, None, || {
        chassis_mc::check::check(&study.0, threads)
    })?
    .map_err(|e| from_run_error(py, e))?;
    Ok(CheckOutput {
        text: chassis_mc::cli::check::check_report(&study.0, &found),
        ms_per_realisation: found
            .per_realisation
            .iter()
            .map(|d| d.as_secs_f64() * 1e3)
            .collect(),
        estimated_seconds: found.estimated_run_time().as_secs_f64(),
        output_bytes: found.total_bytes(),
    })
}

/// What `design` returns.
#[pyclass(module = "chassis_mc._core", name = "DesignOutput", frozen, get_all)]
struct DesignOutput {
    /// The answer in words, as the command prints it.
    sentence: String,
    /// The answer's value, or None when no value in the range meets the target.
    answer: Option<f64>,
    /// The answer's standard deviation from the Monte Carlo error, or None.
    answer_sd: Option<f64>,
    /// The estimator the target applies to.
    estimator: String,
    /// Realisations per Monte Carlo evaluation.
    realisations: u64,
    /// The files written.
    files: Vec<PathBuf>,
}

/// `design`: the search the CLI's `design` runs, written to `out`.
#[pyfunction]
#[pyo3(signature = (study, vary, from_, to, target, out, estimator=None, threads=None))]
#[allow(clippy::too_many_arguments)]
fn design(
    py: Python<'_>,
    study: &PyStudy,
    vary: &str,
    from_: f64,
    to: f64,
    target: &str,
    out: PathBuf,
    estimator: Option<String>,
    threads: Option<usize>,
) -> PyResult<DesignOutput> {
    let key = DesignKey::parse(vary).map_err(|e| PyValueError::new_err(format!("vary: {e}")))?;
    let target =
        DesignTarget::parse(target).map_err(|e| PyValueError::new_err(format!("target: {e}")))?;
    let request = DesignRequest {
        key,
        from: from_,
        to,
        target,
        estimator,
        out,
    };
    let pool = chassis_mc::run::thread_pool(threads).map_err(|e| from_run_error(py, e))?;
    let watch = Watch::default();
    let result = supervise(py, &watch, None, None, || {
        pool.install(|| chassis_mc::design::design(&study.0, &request))
    })?
    .map_err(|e| from_design_error(py, e))?;
    Ok(DesignOutput {
        sentence: answer_sentence(&request, result.answer, result.answer_sd, result.neighbour),
        answer: result.answer.map(|a| a.value),
        answer_sd: result.answer_sd,
        estimator: result.estimator,
        realisations: result.realisations,
        files: result.files,
    })
}

/// What `fit` returns.
#[pyclass(module = "chassis_mc._core", name = "FitOutput", frozen, get_all)]
struct FitOutput {
    /// The tables the command prints.
    text: String,
    /// fit.parquet's table.
    table: Py<ArrowTable>,
    /// systematic.parquet's table, or None without `[systematic]`.
    systematic: Option<Py<ArrowTable>>,
    /// The files written (none without `out`).
    files: Vec<PathBuf>,
}

/// `fit`: a fit file given as exactly one of `path`, `text` or `dict` (its relative log
/// path resolved against `base` as in [`load_study`]), its log read from the file `log` or
/// from the table `log_table` (name, any object with `__arrow_c_stream__`) when given;
/// written to `out` when given, else nothing is written.
#[pyfunction]
#[pyo3(signature = (*, path=None, text=None, dict=None, out=None, log=None, base=None, log_table=None))]
#[allow(clippy::too_many_arguments)]
fn fit(
    py: Python<'_>,
    path: Option<PathBuf>,
    text: Option<String>,
    dict: Option<Bound<'_, PyDict>>,
    out: Option<PathBuf>,
    log: Option<PathBuf>,
    base: Option<PathBuf>,
    log_table: Option<(String, Bound<'_, PyAny>)>,
) -> PyResult<FitOutput> {
    let held = log_table
        .map(|(name, t)| tables::import(&t).map(|(schema, batches)| (name, schema, batches)))
        .transpose()?;
    let given = held
        .as_ref()
        .map(|(name, schema, batches)| chassis_mc::study::LogTable {
            name,
            schema,
            batches,
        });
    let source = source::Source::given(py, path, text, dict, base, "fit file")?;
    let spec = source
        .fit(log.as_deref(), given)
        .map_err(|e| study_error(py, &e))?;
    drop(held);
    let watch = Watch::default();
    let result = supervise(py, &watch, None, None, || match &out {
        Some(out) => chassis_mc::fit::fit(&spec, out),
        None => chassis_mc::fit::fit_in_memory(&spec),
    })?
    .map_err(|e| from_fit_error(py, e))?;
    let printed = format!(
        "{}{}",
        chassis_mc::fit::table(&result.rows),
        chassis_mc::fit::budget_table(&result.systematic)
    );
    let batch = |b: Result<arrow::record_batch::RecordBatch, arrow::error::ArrowError>| {
        b.map(|b| ArrowTable::new(b.schema(), vec![b]))
            .map_err(|e| run_error(py, e.to_string(), false))
    };
    let systematic = match result.systematic.is_empty() {
        true => None,
        false => Some(Py::new(
            py,
            batch(chassis_mc::fit::budget_batch(&result.systematic))?,
        )?),
    };
    Ok(FitOutput {
        text: printed,
        table: Py::new(py, batch(chassis_mc::fit::rows_batch(&result.rows))?)?,
        systematic,
        files: result.files,
    })
}

/// `simulate-log`: realisation `realisation` of a one-condition study as a measured log, in
/// memory (columns of LOG_HEADER, float64), also written as CSV to `path` when given.
#[pyfunction]
#[pyo3(signature = (study, path=None, realisation=0, force=false))]
fn simulate_log(
    py: Python<'_>,
    study: &PyStudy,
    path: Option<PathBuf>,
    realisation: u64,
    force: bool,
) -> PyResult<ArrowTable> {
    let watch = Watch::default();
    let log = supervise(py, &watch, None, None, || {
        if let Some(path) = path.as_deref().filter(|_| !force) {
            // refused before the simulation, not after it
            chassis_mc::fit::ensure_replaceable(path)?;
        }
        let log = chassis_mc::fit::simulated_log(&study.0, realisation)?;
        if let Some(path) = &path {
            chassis_mc::fit::write_log(&log, path, true)?;
        }
        Ok(log)
    })?
    .map_err(|e| from_fit_error(py, e))?;
    let batch = chassis_mc::fit::log_batch(log).map_err(|e| run_error(py, e.to_string(), false))?;
    Ok(ArrowTable::new(batch.schema(), vec![batch]))
}

/// The `chassis-mc` command line with `argv` (the first is the program's name); returns its
/// exit status. The wheel's `chassis-mc` command calls this.
#[pyfunction]
fn main(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(|| chassis_mc::cli::main(argv))
}

/// The Rust side of `chassis_mc`.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyStudy>()?;
    m.add_function(wrap_pyfunction!(load_study, m)?)?;
    m.add_function(wrap_pyfunction!(parses_as_toml, m)?)?;
    m.add_function(wrap_pyfunction!(_study_from_toml, m)?)?;
    m.add_function(wrap_pyfunction!(_study_from_values, m)?)?;
    m.add_class::<ArrowTable>()?;
    m.add_class::<RunOutput>()?;
    m.add_class::<FitOutput>()?;
    m.add_class::<CheckOutput>()?;
    m.add_class::<DesignOutput>()?;
    m.add_function(wrap_pyfunction!(cycles, m)?)?;
    m.add_function(wrap_pyfunction!(summarize, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(check, m)?)?;
    m.add_function(wrap_pyfunction!(design, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_log, m)?)?;
    m.add_function(wrap_pyfunction!(main, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // The ranges of the arguments, as the command line's: --realisations, --seed (a study
    // file's seed is a TOML integer, at most i64::MAX) and --threads (a u16 from 1).
    m.add("MAX_REALISATIONS", chassis_mc::study::MAX_REALISATIONS)?;
    m.add("MAX_SEED", i64::MAX as u64)?;
    m.add("MAX_THREADS", u16::MAX)?;
    Ok(())
}
