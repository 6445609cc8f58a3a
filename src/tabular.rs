//! Numeric columns of a user's data file (a speed trace, a road profile): CSV or Parquet,
//! chosen by the extension.
//!
//! CSV: a header row, commas, optional quotes (a header may be `"speed, km/h"`); a UTF-8
//! byte-order mark, blank lines, `#` comment lines and CRLF line ends are accepted. Parquet:
//! float or integer columns. Every cell of a requested column must be a finite number; a
//! bad one is a [`TabularError`] naming the file, the column and the line (CSV, the file's
//! own 1-based line number) or row (Parquet, 1-based).

use std::fmt;
use std::fs::File;
use std::path::{Path, PathBuf};

use arrow::array::{Array, AsArray};
use arrow::datatypes::{DataType, Float64Type};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

mod text;
pub use text::{TextColumns, read_text_columns};

/// Why a data file cannot be used.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TabularError {
    /// The file.
    pub file: PathBuf,
    /// The column at fault, if one is.
    pub column: Option<String>,
    /// Where: `line N` (CSV) or `row N` (Parquet), if a row is at fault.
    pub place: Option<String>,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for TabularError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.file.display())?;
        if let Some(c) = &self.column {
            write!(f, "column \"{c}\", ")?;
        }
        if let Some(p) = &self.place {
            write!(f, "{p}: ")?;
        }
        f.write_str(&self.reason)
    }
}

impl std::error::Error for TabularError {}

/// Columns read from one data file: numbers (`T = f64`, [`read_columns`]) or text
/// ([`TextColumns`], [`read_text_columns`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Columns<T = f64> {
    /// The file read.
    pub file: PathBuf,
    /// Where each row came from: its 1-based line in a CSV file, or its 1-based row number
    /// in a Parquet file.
    pub origins: Vec<usize>,
    /// True when the file is Parquet (`origins` are row numbers, else line numbers).
    pub parquet: bool,
    columns: Vec<(String, Vec<T>)>,
}

impl<T> Columns<T> {
    /// The values of column `name` (one of those requested).
    ///
    /// # Panics
    /// If `name` was not requested.
    pub fn get(&self, name: &str) -> &[T] {
        &self
            .columns
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("column {name} was not requested"))
            .1
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.origins.len()
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.origins.is_empty()
    }

    /// `line N` (CSV) or `row N` (Parquet) of row index `i`.
    pub fn place(&self, i: usize) -> String {
        let kind = if self.parquet { "row" } else { "line" };
        format!("{kind} {}", self.origins[i])
    }
}

impl Columns {
    /// Check that column `name` strictly increases.
    pub fn strictly_increasing(&self, name: &str) -> Result<(), TabularError> {
        let v = self.get(name);
        match (1..v.len()).find(|&i| v[i] <= v[i - 1]) {
            None => Ok(()),
            Some(i) => Err(self.error(
                Some(name),
                Some(i),
                format!(
                    "{} does not increase (the row before has {}); the column must be strictly increasing",
                    v[i],
                    v[i - 1]
                ),
            )),
        }
    }

    fn error(&self, column: Option<&str>, row: Option<usize>, reason: String) -> TabularError {
        TabularError {
            file: self.file.clone(),
            column: column.map(str::to_string),
            place: row.map(|i| self.place(i)),
            reason,
        }
    }
}

/// The largest input file the engine reads \[bytes\]: a 1 Hz log of a year is about 30 MB of
/// CSV, a 100 Hz log of a day about 500 MB.
pub const MAX_INPUT_BYTES: u64 = 4 << 30;

/// The longest piece of a user's cell or value a message quotes \[characters\].
pub const MAX_QUOTE_CHARS: usize = 60;

/// `text` as a message shows it: whole when short, else its first [`MAX_QUOTE_CHARS`]
/// characters and how long it is.
pub fn shorten(text: &str) -> String {
    match text.char_indices().nth(MAX_QUOTE_CHARS) {
        None => text.to_string(),
        Some((end, _)) => format!("{}… ({} bytes)", &text[..end], text.len()),
    }
}

/// [`shorten`]ed `text` in double quotes.
pub fn quote(text: &str) -> String {
    format!("\"{}\"", shorten(text))
}

/// The bytes of the regular file at `path` (a symbolic link to one is followed): a device
/// (`/dev/zero`), a FIFO or a directory is refused before anything is read, so a wrong path
/// neither hangs nor fills the memory, and so is a file over `max_bytes`. The error is the
/// reason, for the caller to put beside the path.
pub fn read_regular(path: &Path, max_bytes: u64) -> Result<Vec<u8>, String> {
    use std::io::Read;
    // Opened without blocking, so that a FIFO with no writer cannot hang the open; the
    // type is checked on the open handle, so the file checked is the file read.
    let file = {
        use std::os::unix::fs::OpenOptionsExt;
        std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(O_NONBLOCK)
            .open(path)
            .map_err(|e| format!("cannot read: {e}"))?
    };
    let meta = file.metadata().map_err(|e| format!("cannot read: {e}"))?;
    if !meta.is_file() {
        return Err(format!(
            "is a {}, not a regular file",
            file_kind(&meta.file_type())
        ));
    }
    if meta.len() > max_bytes {
        return Err(format!(
            "is {} bytes; at most {max_bytes} bytes are read",
            meta.len()
        ));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read: {e}"))?;
    if bytes.len() as u64 > max_bytes {
        return Err(format!("grew past {max_bytes} bytes while being read"));
    }
    Ok(bytes)
}

/// What a file type is, in words ("FIFO", "symbolic link", …).
pub fn file_kind(t: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_symlink() {
        "symbolic link"
    } else if t.is_dir() {
        "directory"
    } else if t.is_fifo() {
        "FIFO"
    } else if t.is_socket() {
        "socket"
    } else if t.is_block_device() || t.is_char_device() {
        "device"
    } else {
        "regular file"
    }
}

/// `O_NONBLOCK` of Linux and the BSDs (opening a FIFO without a writer returns at once).
#[cfg(target_os = "linux")]
const O_NONBLOCK: i32 = 0o4000;
#[cfg(not(target_os = "linux"))]
const O_NONBLOCK: i32 = 0x0004;

/// Read the columns `wanted` (each must exist) from `path`, with at least `min_rows` rows.
pub fn read_columns(
    path: &Path,
    wanted: &[&str],
    min_rows: usize,
) -> Result<Columns, TabularError> {
    let fail = |reason: String| TabularError {
        file: path.to_path_buf(),
        column: None,
        place: None,
        reason,
    };
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let columns = match extension.as_deref() {
        Some("csv") => read_csv(path, wanted)?,
        Some("parquet") => read_parquet(path, wanted)?,
        _ => {
            return Err(fail(
                "unsupported file type: the name must end in .csv or .parquet".into(),
            ));
        }
    };
    at_least(columns, min_rows)
}

/// `columns` when they have at least `min_rows` rows, else the error saying so.
fn at_least(columns: Columns, min_rows: usize) -> Result<Columns, TabularError> {
    if columns.len() < min_rows {
        return Err(TabularError {
            file: columns.file.clone(),
            column: None,
            place: None,
            reason: format!(
                "has {} data rows; at least {min_rows} are needed",
                columns.len()
            ),
        });
    }
    Ok(columns)
}

/// The position of each wanted column among `names`, or an error listing what the file has.
fn positions(path: &Path, names: &[String], wanted: &[&str]) -> Result<Vec<usize>, TabularError> {
    wanted
        .iter()
        .map(|w| {
            let fail = |reason: String| TabularError {
                file: path.to_path_buf(),
                column: Some(w.to_string()),
                place: None,
                reason,
            };
            let mut at = names
                .iter()
                .enumerate()
                .filter(|(_, n)| n == w)
                .map(|(i, _)| i);
            match (at.next(), at.next()) {
                (Some(i), None) => Ok(i),
                (Some(i), Some(j)) => Err(fail(format!(
                    "two columns have this name (columns {} and {}); rename one so that the \
                     column read is not a guess",
                    i + 1,
                    j + 1
                ))),
                (None, _) => {
                    let shown: Vec<String> = names.iter().take(40).map(|n| quote(n)).collect();
                    let more = match names.len() > shown.len() {
                        true => format!(" and {} more", names.len() - shown.len()),
                        false => String::new(),
                    };
                    Err(fail(format!(
                        "no such column; the file has [{}]{more}",
                        shown.join(", ")
                    )))
                }
            }
        })
        .collect()
}

/// The text of a CSV file prepared for the `csv` reader: without its BOM, its blank and
/// comment lines (a `#` after optional whitespace), the CR of CRLF, and whitespace before a
/// field (so that `a, "b, c"` is two fields); with the physical line number of each line
/// kept, since the reader counts lines of this text.
fn prepare_csv(bytes: &[u8]) -> (Vec<u8>, Vec<usize>) {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut text = Vec::with_capacity(bytes.len());
    let mut lines = Vec::new();
    let mut quoted = false; // inside a quoted field
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        let body = line.trim_ascii_start();
        if !quoted && (body.is_empty() || body[0] == b'#') {
            continue;
        }
        lines.push(i + 1);
        let (mut start, mut closed) = (!quoted, false); // at a field's start; after a closing quote
        for &b in line {
            if quoted {
                (quoted, closed) = (b != b'"', b == b'"');
            } else if start && (b == b' ' || b == b'\t') {
                continue;
            } else {
                quoted = b == b'"' && (start || closed);
                (start, closed) = (b == b',', false);
            }
            text.push(b);
        }
        text.push(b'\n');
    }
    (text, lines)
}

fn read_csv(path: &Path, wanted: &[&str]) -> Result<Columns, TabularError> {
    let fail = |place: Option<String>, column: Option<&str>, reason: String| TabularError {
        file: path.to_path_buf(),
        column: column.map(str::to_string),
        place,
        reason,
    };
    let bytes = read_regular(path, MAX_INPUT_BYTES).map_err(|reason| fail(None, None, reason))?;
    // The reader's line k + 1 is the file's line physical[k]: messages name the file's lines.
    let (text, physical) = prepare_csv(&bytes);
    let line_at = |k: u64| physical.get(k as usize - 1).copied().unwrap_or(k as usize);
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(text.as_slice());
    let line_of = |e: &csv::Error| e.position().map(|p| format!("line {}", line_at(p.line())));
    let names: Vec<String> = reader
        .headers()
        .map_err(|e| fail(line_of(&e), None, format!("cannot read the header: {e}")))?
        .iter()
        .map(str::to_string)
        .collect();
    let index = positions(path, &names, wanted)?;
    let mut values = vec![Vec::new(); wanted.len()];
    let mut origins = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let reason = match e.kind() {
                csv::ErrorKind::UnequalLengths {
                    expected_len, len, ..
                } => format!("has {len} fields; the header has {expected_len}"),
                _ => format!("cannot read: {e}"),
            };
            fail(line_of(&e), None, reason)
        })?;
        let line = record.position().map_or(0, |p| line_at(p.line()));
        for ((column, &k), out) in wanted.iter().zip(&index).zip(&mut values) {
            let cell = &record[k];
            let place = Some(format!("line {line}"));
            if cell.is_empty() {
                return Err(fail(place, Some(column), "the cell is empty".into()));
            }
            let v: f64 = cell.parse().map_err(|_| {
                fail(
                    place.clone(),
                    Some(column),
                    format!("{} is not a number", quote(cell)),
                )
            })?;
            if !v.is_finite() {
                return Err(fail(
                    place,
                    Some(column),
                    format!("{} is not a finite number", shorten(cell)),
                ));
            }
            out.push(v);
        }
        origins.push(line);
    }
    Ok(Columns {
        file: path.to_path_buf(),
        origins,
        parquet: false,
        columns: wanted.iter().map(|w| w.to_string()).zip(values).collect(),
    })
}

fn read_parquet(path: &Path, wanted: &[&str]) -> Result<Columns, TabularError> {
    let fail = |place: Option<String>, column: Option<&str>, reason: String| TabularError {
        file: path.to_path_buf(),
        column: column.map(str::to_string),
        place,
        reason,
    };
    let file = File::open(path).map_err(|e| fail(None, None, format!("cannot open: {e}")))?;
    match file.metadata() {
        Ok(m) if !m.is_file() => {
            return Err(fail(
                None,
                None,
                format!("is a {}, not a regular file", file_kind(&m.file_type())),
            ));
        }
        _ => {}
    }
    let builder = ParquetRecordBatchReaderBuilder::try_new(file)
        .map_err(|e| fail(None, None, format!("not a readable Parquet file: {e}")))?;
    let names: Vec<String> = builder
        .schema()
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .collect();
    let index = positions(path, &names, wanted)?;
    let reader = builder
        .build()
        .map_err(|e| fail(None, None, format!("not a readable Parquet file: {e}")))?;
    let batches = reader.map(|b| b.map_err(|e| fail(None, None, format!("cannot read: {e}"))));
    numeric_columns(path, &index, wanted, batches)
}

/// The columns `wanted` (each must exist) of a table held in memory, with at least
/// `min_rows` rows: `name` says what the table is in errors (in place of a file), which
/// name its rows 1-based as a Parquet file's.
pub fn table_columns(
    name: &Path,
    schema: &arrow::datatypes::Schema,
    batches: &[arrow::record_batch::RecordBatch],
    wanted: &[&str],
    min_rows: usize,
) -> Result<Columns, TabularError> {
    let names: Vec<String> = schema.fields().iter().map(|f| f.name().clone()).collect();
    let index = positions(name, &names, wanted)?;
    let columns = numeric_columns(name, &index, wanted, batches.iter().cloned().map(Ok))?;
    at_least(columns, min_rows)
}

/// The columns `wanted`, at positions `index`, of a table's `batches`: numbers, each finite
/// and present; an error names the file (or table), the column and the 1-based row.
fn numeric_columns(
    path: &Path,
    index: &[usize],
    wanted: &[&str],
    batches: impl Iterator<Item = Result<arrow::record_batch::RecordBatch, TabularError>>,
) -> Result<Columns, TabularError> {
    let fail = |place: Option<String>, column: Option<&str>, reason: String| TabularError {
        file: path.to_path_buf(),
        column: column.map(str::to_string),
        place,
        reason,
    };
    let mut values = vec![Vec::new(); wanted.len()];
    let mut rows = 0usize;
    for batch in batches {
        let batch = batch?;
        for ((column, &k), out) in wanted.iter().zip(index).zip(&mut values) {
            let array = batch.column(k);
            let numeric = array.data_type().is_numeric() && *array.data_type() != DataType::Null;
            if !numeric {
                return Err(fail(
                    None,
                    Some(column),
                    format!("is {}, not a number", array.data_type()),
                ));
            }
            let array = arrow::compute::cast(array, &DataType::Float64)
                .map_err(|e| fail(None, Some(column), format!("cannot read as numbers: {e}")))?;
            let array = array.as_primitive::<Float64Type>();
            for i in 0..array.len() {
                let place = Some(format!("row {}", rows + i + 1));
                if array.is_null(i) {
                    return Err(fail(place, Some(column), "the cell is empty (null)".into()));
                }
                let v = array.value(i);
                if !v.is_finite() {
                    return Err(fail(
                        place,
                        Some(column),
                        format!("{v} is not a finite number"),
                    ));
                }
                out.push(v);
            }
        }
        rows += batch.num_rows();
    }
    Ok(Columns {
        file: path.to_path_buf(),
        origins: (1..=rows).collect(),
        parquet: true,
        columns: wanted.iter().map(|w| w.to_string()).zip(values).collect(),
    })
}

#[cfg(test)]
mod tests;
