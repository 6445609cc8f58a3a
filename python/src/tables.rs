//! Tables crossing between Rust and Python in memory, through the Arrow C stream interface
//! (the `__arrow_c_stream__` PyCapsule protocol pyarrow, polars and DuckDB read): no file
//! and no copy of the columns on either side.

use std::ffi::CStr;

use arrow::datatypes::SchemaRef;
use arrow::ffi_stream::{FFI_ArrowArrayStream, RecordBatchStreamReader};
use arrow::record_batch::{RecordBatch, RecordBatchIterator};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyCapsule;

/// The name the protocol gives a stream's capsule.
const STREAM: &CStr = c"arrow_array_stream";

/// A table held by the Rust side (its schema, with the footer's metadata a file of it
/// carries, and its record batches), read by `pyarrow.table(t)`,
/// `pyarrow.RecordBatchReader.from_stream(t)` or any reader of the Arrow PyCapsule
/// interface. The package turns it into a `pyarrow.Table` at once.
#[pyclass(module = "chassis_mc._core", name = "ArrowTable", frozen)]
pub struct ArrowTable {
    schema: SchemaRef,
    batches: Vec<RecordBatch>,
}

impl ArrowTable {
    /// A table of `batches` under `schema` (each batch's own schema is not looked at: the
    /// stream reports `schema`).
    pub fn new(schema: SchemaRef, batches: Vec<RecordBatch>) -> Self {
        ArrowTable { schema, batches }
    }
}

#[pymethods]
impl ArrowTable {
    /// An Arrow C stream of the table's batches in a PyCapsule (the consumer takes it over;
    /// a capsule never consumed releases it). A `requested_schema` is not followed: the
    /// stream has the table's own schema, which the protocol allows (the consumer casts).
    #[pyo3(signature = (requested_schema=None))]
    fn __arrow_c_stream__<'py>(
        &self,
        py: Python<'py>,
        requested_schema: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyCapsule>> {
        let _ = requested_schema;
        let reader = RecordBatchIterator::new(
            self.batches.clone().into_iter().map(Ok),
            self.schema.clone(),
        );
        let stream = FFI_ArrowArrayStream::new(Box::new(reader));
        PyCapsule::new_with_value(py, stream, STREAM)
    }

    /// Rows in the table.
    #[getter]
    fn num_rows(&self) -> usize {
        self.batches.iter().map(RecordBatch::num_rows).sum()
    }
}

/// The schema and record batches of `table`, any object with `__arrow_c_stream__` (a
/// pyarrow Table, a polars DataFrame, …), read from its stream in memory.
pub fn import(table: &Bound<'_, PyAny>) -> PyResult<(SchemaRef, Vec<RecordBatch>)> {
    let capsule = table
        .call_method0("__arrow_c_stream__")?
        .cast_into::<PyCapsule>()
        .map_err(|_| PyTypeError::new_err("__arrow_c_stream__ did not return a PyCapsule"))?;
    let pointer = capsule.pointer_checked(Some(STREAM))?;
    // SAFETY: a capsule named "arrow_array_stream" holds an FFI_ArrowArrayStream (the
    // protocol); `from_raw` moves it out and leaves a released stream in its place, which
    // the capsule's own destructor then leaves alone.
    let stream = unsafe { FFI_ArrowArrayStream::from_raw(pointer.as_ptr().cast()) };
    let reader = RecordBatchStreamReader::try_new(stream)
        .map_err(|e| PyTypeError::new_err(format!("not a readable Arrow stream: {e}")))?;
    let schema = arrow::record_batch::RecordBatchReader::schema(&reader);
    let batches = reader
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| PyTypeError::new_err(format!("not a readable Arrow stream: {e}")))?;
    Ok((schema, batches))
}
