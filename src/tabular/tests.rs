use std::sync::Arc;

use arrow::array::{Float64Array, Int32Array, RecordBatch};
use arrow::datatypes::{DataType, Field, Schema};

use super::*;

fn write(dir: &tempfile::TempDir, name: &str, text: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn error(text: &str, wanted: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = write(&dir, "d.csv", text.as_bytes());
    read_columns(&path, wanted, 3).unwrap_err().to_string()
}

#[test]
fn a_real_file_with_bom_comments_blank_lines_quotes_and_crlf_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let text = "\u{feff}# logged 2026-11-28\r\n\r\n\"time, s\",\"speed\", note \r\n0,1.5,a\r\n# pause\r\n1, 2e0 ,\"b, c\"\r\n\r\n2.5,3,d\r\n";
    let path = write(&dir, "t.CSV", text.as_bytes());
    let c = read_columns(&path, &["speed", "time, s"], 3).unwrap();
    assert_eq!(c.get("time, s"), &[0.0, 1.0, 2.5]);
    assert_eq!(c.get("speed"), &[1.5, 2.0, 3.0]);
    // The file's own line numbers, counting the comment and blank lines.
    assert_eq!(c.origins, vec![4, 6, 8]);
    assert_eq!(c.place(2), "line 8");
}

#[test]
fn a_quoted_header_after_a_space_and_a_quoted_cell_over_two_lines_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let text = "t, \"speed, km/h\", note\n0, 1, \"two\n\n# not a comment\"\n1, 2, x\n2, 3, y\n";
    let path = write(&dir, "q.csv", text.as_bytes());
    let c = read_columns(&path, &["speed, km/h"], 3).unwrap();
    assert_eq!(c.get("speed, km/h"), &[1.0, 2.0, 3.0]);
    assert_eq!(c.origins, vec![2, 5, 6]);
}

#[test]
fn a_bad_cell_is_named_by_column_and_physical_line() {
    let text = "\u{feff}# header follows\n\nt,v\n0,1\n# c\n\n1,abc\n2,3\n";
    let e = error(text, &["t", "v"]);
    assert!(
        e.ends_with("d.csv: column \"v\", line 7: \"abc\" is not a number"),
        "{e}"
    );
}

#[test]
fn malformed_files_are_errors_that_say_what_and_where() {
    let cases: [(&str, &[&str], &str); 6] = [
        (
            "t,v\n0,1\n1,2\n2,3\n",
            &["t", "speed"],
            "column \"speed\", no such column; the file has [\"t\", \"v\"]",
        ),
        (
            "t,v\n0,1\n1,nan\n2,3\n",
            &["t", "v"],
            "column \"v\", line 3: nan is not a finite number",
        ),
        (
            "t,v\n0,1\n1,\n2,3\n",
            &["t", "v"],
            "column \"v\", line 3: the cell is empty",
        ),
        (
            "t,v\n0,1\n1,2\n",
            &["t", "v"],
            "has 2 data rows; at least 3 are needed",
        ),
        (
            "t,v\n0,1\n1,2,9\n2,3\n",
            &["t", "v"],
            "line 3: has 3 fields; the header has 2",
        ),
        (
            "t,v\n0,1\n1,inf\n2,3\n",
            &["v"],
            "column \"v\", line 3: inf is not a finite number",
        ),
    ];
    for (text, wanted, expected) in cases {
        let e = error(text, wanted);
        assert!(e.contains(expected), "{e}\n  expected: {expected}");
    }
}

#[test]
fn a_column_that_does_not_increase_is_named_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(&dir, "d.csv", b"t,v\n0,1\n1,2\n1,3\n");
    let c = read_columns(&path, &["t"], 3).unwrap();
    let e = c.strictly_increasing("t").unwrap_err().to_string();
    assert!(
        e.contains("column \"t\", line 4: 1 does not increase"),
        "{e}"
    );
}

#[test]
fn only_csv_and_parquet_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(&dir, "d.txt", b"t,v\n");
    let e = read_columns(&path, &["t"], 3).unwrap_err().to_string();
    assert!(e.contains("d.txt: unsupported file type"), "{e}");
    let e = read_columns(&dir.path().join("none.csv"), &["t"], 3)
        .unwrap_err()
        .to_string();
    assert!(e.contains("none.csv: cannot read"), "{e}");
}

fn parquet(dir: &tempfile::TempDir, v: Vec<f64>) -> PathBuf {
    let schema = Arc::new(Schema::new(vec![
        Field::new("t", DataType::Int32, false),
        Field::new("v", DataType::Float64, false),
    ]));
    let n = v.len() as i32;
    let batch = RecordBatch::try_new(
        schema.clone(),
        vec![
            Arc::new(Int32Array::from((0..n).collect::<Vec<_>>())),
            Arc::new(Float64Array::from(v)),
        ],
    )
    .unwrap();
    let path = dir.path().join("d.parquet");
    let mut w =
        parquet::arrow::ArrowWriter::try_new(File::create(&path).unwrap(), schema, None).unwrap();
    w.write(&batch).unwrap();
    w.close().unwrap();
    path
}

#[test]
fn parquet_integer_and_float_columns_are_read_and_a_nan_is_named_by_row() {
    let dir = tempfile::tempdir().unwrap();
    let path = parquet(&dir, vec![1.0, 2.5, 4.0]);
    let c = read_columns(&path, &["v", "t"], 3).unwrap();
    assert_eq!(c.get("t"), &[0.0, 1.0, 2.0]);
    assert_eq!(c.get("v"), &[1.0, 2.5, 4.0]);
    assert_eq!(c.place(0), "row 1");
    let path = parquet(&dir, vec![1.0, f64::NAN, 4.0]);
    let e = read_columns(&path, &["v"], 3).unwrap_err().to_string();
    assert!(
        e.contains("column \"v\", row 2: NaN is not a finite number"),
        "{e}"
    );
}
