//! Text columns of a user's table (a fleet of vehicles): CSV or Parquet, every cell as text,
//! so that a table's labels, its filters' columns and its numbers are read alike and a cell
//! is judged only where it is used. CSV as [`super::read_columns`] reads it (a BOM, blank and
//! `#` comment lines, CRLF, quotes); a cell that is not UTF-8 is read as Windows-1252 (the
//! EPA test car list's encoding: Latin-1 with printable 0x80–0x9F). Parquet: any column,
//! cast to text (null an empty cell).

use std::fs::File;
use std::path::Path;

use arrow::array::{Array, AsArray};
use arrow::datatypes::DataType;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use super::{
    Columns, MAX_INPUT_BYTES, TabularError, file_kind, positions, prepare_csv, read_regular,
};

/// Text columns read from one table (every cell as text).
pub type TextColumns = Columns<String>;

/// Windows-1252's characters for the bytes 0x80–0x9F (where Latin-1 has control codes; the
/// five bytes it leaves undefined kept as those codes).
const CP1252_80_9F: [char; 32] = [
    '€', '\u{81}', '‚', 'ƒ', '„', '…', '†', '‡', 'ˆ', '‰', 'Š', '‹', 'Œ', '\u{8d}', 'Ž', '\u{8f}',
    '\u{90}', '‘', '’', '“', '”', '•', '–', '—', '˜', '™', 'š', '›', 'œ', '\u{9d}', 'ž', 'Ÿ',
];

/// A cell's bytes as text: UTF-8, or else Windows-1252 (Latin-1 with the printable
/// characters of 0x80–0x9F: what spreadsheets export).
fn text_of(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes
            .iter()
            .map(|&b| match b {
                0x80..=0x9F => CP1252_80_9F[usize::from(b - 0x80)],
                _ => char::from(b),
            })
            .collect(),
    }
}

/// Read the columns `wanted` (each must exist, names once each) of the table at `path` as
/// text.
pub fn read_text_columns(path: &Path, wanted: &[&str]) -> Result<TextColumns, TabularError> {
    let fail = |place: Option<String>, reason: String| TabularError {
        file: path.to_path_buf(),
        column: None,
        place,
        reason,
    };
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("csv") => {}
        Some("parquet") => return read_parquet_text(path, wanted),
        _ => {
            return Err(fail(
                None,
                "unsupported file type: the name must end in .csv or .parquet".into(),
            ));
        }
    }
    let bytes = read_regular(path, MAX_INPUT_BYTES).map_err(|reason| fail(None, reason))?;
    let (text, physical) = prepare_csv(&bytes);
    let line_at = |k: u64| physical.get(k as usize - 1).copied().unwrap_or(k as usize);
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(text.as_slice());
    let line_of = |e: &csv::Error| e.position().map(|p| format!("line {}", line_at(p.line())));
    let names: Vec<String> = reader
        .byte_headers()
        .map_err(|e| fail(line_of(&e), format!("cannot read the header: {e}")))?
        .iter()
        .map(text_of)
        .collect();
    let index = positions(path, &names, wanted)?;
    let mut values = vec![Vec::new(); wanted.len()];
    let mut origins = Vec::new();
    for record in reader.byte_records() {
        let record = record.map_err(|e| {
            let reason = match e.kind() {
                csv::ErrorKind::UnequalLengths {
                    expected_len, len, ..
                } => format!("has {len} fields; the header has {expected_len}"),
                _ => format!("cannot read: {e}"),
            };
            fail(line_of(&e), reason)
        })?;
        for (&k, out) in index.iter().zip(&mut values) {
            out.push(text_of(&record[k]));
        }
        origins.push(record.position().map_or(0, |p| line_at(p.line())));
    }
    Ok(Columns {
        file: path.to_path_buf(),
        origins,
        parquet: false,
        columns: wanted.iter().map(|w| w.to_string()).zip(values).collect(),
    })
}

fn read_parquet_text(path: &Path, wanted: &[&str]) -> Result<TextColumns, TabularError> {
    let fail = |column: Option<&str>, reason: String| TabularError {
        file: path.to_path_buf(),
        column: column.map(str::to_string),
        place: None,
        reason,
    };
    let file = File::open(path).map_err(|e| fail(None, format!("cannot open: {e}")))?;
    if let Ok(m) = file.metadata()
        && !m.is_file()
    {
        return Err(fail(
            None,
            format!("is a {}, not a regular file", file_kind(&m.file_type())),
        ));
    }
    let builder = ParquetRecordBatchReaderBuilder::try_new(file)
        .map_err(|e| fail(None, format!("not a readable Parquet file: {e}")))?;
    let names: Vec<String> = builder
        .schema()
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .collect();
    let index = positions(path, &names, wanted)?;
    let reader = builder
        .build()
        .map_err(|e| fail(None, format!("not a readable Parquet file: {e}")))?;
    let mut values = vec![Vec::new(); wanted.len()];
    let mut rows = 0usize;
    for batch in reader {
        let batch = batch.map_err(|e| fail(None, format!("cannot read: {e}")))?;
        for ((column, &k), out) in wanted.iter().zip(&index).zip(&mut values) {
            let array = arrow::compute::cast(batch.column(k), &DataType::Utf8)
                .map_err(|e| fail(Some(column), format!("cannot read as text: {e}")))?;
            let array = array.as_string::<i32>();
            out.extend((0..array.len()).map(|i| match array.is_null(i) {
                true => String::new(),
                false => array.value(i).to_string(),
            }));
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
