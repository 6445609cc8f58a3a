//! A study or fit file as Python gives it: a path (read by the library itself), TOML text, or
//! a dict of its tables and keys, which crosses as typed values (bool, int, float, str, list,
//! dict: TOML's own types) with no TOML text in between.

use std::path::{Path, PathBuf};

use chassis_mc::fit::FitSpec;
use chassis_mc::study::{LogTable, Study, StudyError};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use super::{DICT_ORIGIN, study_error};

/// What was given.
enum Given {
    Path(PathBuf),
    Text(String),
    Table(toml::Table),
}

/// A study or fit file given from Python: what it is, the origin its errors name, the
/// directory its relative data paths resolve against (`base`, else the working directory)
/// and whether that is the working directory by default.
pub(crate) struct Source {
    what: &'static str,
    given: Given,
    origin: String,
    dir: PathBuf,
    dir_is_default: bool,
}

impl Source {
    /// Exactly one of `path`, `text` and `dict`, with the directory `base` for text or a
    /// dict; `what` (`study`, `fit file`) names it in errors.
    pub(crate) fn given(
        py: Python<'_>,
        path: Option<PathBuf>,
        text: Option<String>,
        dict: Option<Bound<'_, PyDict>>,
        base: Option<PathBuf>,
        what: &'static str,
    ) -> PyResult<Source> {
        let (given, origin) = match (path, text, dict) {
            (Some(path), None, None) => {
                let origin = path.display().to_string();
                (Given::Path(path), origin)
            }
            (None, Some(text), None) => (Given::Text(text), "<string>".to_string()),
            (None, None, Some(dict)) => (Given::Table(table_of(py, &dict)?), DICT_ORIGIN.into()),
            _ => {
                return Err(PyTypeError::new_err(format!(
                    "a {what} is given as exactly one of path, text and dict"
                )));
            }
        };
        let dir_is_default = base.is_none();
        let dir = base.unwrap_or_else(|| std::env::current_dir().unwrap_or_else(|_| ".".into()));
        Ok(Source {
            what,
            given,
            origin,
            dir,
            dir_is_default,
        })
    }

    /// The study, validated.
    pub(crate) fn study(&self) -> Result<Study, StudyError> {
        match &self.given {
            Given::Path(path) => Study::load(path),
            Given::Text(text) => Study::from_toml_in(text, &self.origin, &self.dir),
            Given::Table(table) => Study::from_table_in(table.clone(), &self.origin, &self.dir),
        }
        .map_err(|e| self.hint(e))
    }

    /// The fit file, validated, its log read from the file `log` or the table `table` when
    /// given (instead of its `log.file`).
    pub(crate) fn fit(
        &self,
        log: Option<&Path>,
        table: Option<LogTable<'_>>,
    ) -> Result<FitSpec, StudyError> {
        match (&self.given, table) {
            (Given::Path(path), None) => FitSpec::load_with_log(path, log),
            (Given::Path(path), Some(t)) => FitSpec::load_with_table(path, t),
            (Given::Text(text), Some(t)) => {
                FitSpec::parse_with_table(text, &self.origin, &self.dir, t)
            }
            (Given::Text(text), None) => {
                FitSpec::parse_with_log(text, &self.origin, &self.dir, log)
            }
            (Given::Table(values), t) => {
                FitSpec::from_table_in(values.clone(), &self.origin, &self.dir, log, t)
            }
        }
        .map_err(|e| self.hint(e))
    }

    /// `e` with a hint when its key holds a relative path that does not exist in the
    /// working directory, which the caller may not have meant (no `base` was given).
    fn hint(&self, mut e: StudyError) -> StudyError {
        let root = match &self.given {
            Given::Path(_) => return e,
            Given::Text(text) => text.parse::<toml::Table>().ok(),
            Given::Table(table) => Some(table.clone()),
        };
        if self.dir_is_default
            && let Some(key) = &e.key
            && let Some(toml::Value::String(path)) = root.and_then(|r| value_at(r, key))
            && Path::new(&path).is_relative()
            && !self.dir.join(&path).exists()
        {
            let given = match self.given {
                Given::Table(_) => "a dict",
                _ => "TOML text",
            };
            e.reason = format!(
                "{} (a {} given as {given} resolves its relative paths against the current \
                 directory, {}, unless base= names the directory they are relative to)",
                e.reason,
                self.what,
                self.dir.display()
            );
        }
        e
    }
}

/// The value at a dotted `key` (`drive.trace`, `terrain.profiles[1].file`) of `root`.
fn value_at(root: toml::Table, key: &str) -> Option<toml::Value> {
    let mut value = toml::Value::Table(root);
    for part in key.split('.') {
        let (name, indices) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        value = value.as_table()?.get(name)?.clone();
        for index in indices.split(['[', ']']).filter(|s| !s.is_empty()) {
            value = value.as_array()?.get(index.parse::<usize>().ok()?)?.clone();
        }
    }
    Some(value)
}

/// A dict's values as a TOML table; an error names the key whose value TOML cannot hold.
pub(crate) fn table_of(py: Python<'_>, dict: &Bound<'_, PyDict>) -> PyResult<toml::Table> {
    toml_table(dict, "").map_err(|(key, reason)| {
        let key = (!key.is_empty()).then_some(key);
        study_error(
            py,
            &StudyError {
                file: DICT_ORIGIN.into(),
                key,
                line: None,
                reason,
            },
        )
    })
}

/// A TOML value as a Python value (a table as a dict, an array as a list, a date-time as
/// its text).
pub(crate) fn py_value<'py>(py: Python<'py>, value: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        toml::Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(x) => PyFloat::new(py, *x).into_any(),
        toml::Value::String(s) => PyString::new(py, s).into_any(),
        toml::Value::Datetime(d) => PyString::new(py, &d.to_string()).into_any(),
        toml::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(py_value(py, item)?)?;
            }
            list.into_any()
        }
        toml::Value::Table(table) => {
            let dict = PyDict::new(py);
            for (k, v) in table {
                dict.set_item(k, py_value(py, v)?)?;
            }
            dict.into_any()
        }
    })
}

/// A Python value as TOML, `key` naming where it is for an error.
/// Why a value cannot be a study's: the dotted key where it is (empty: the top level) and
/// the reason.
type ValueError = (String, String);

fn toml_value(value: &Bound<'_, PyAny>, key: &str) -> Result<toml::Value, ValueError> {
    // bool before int: Python's bool is an int
    if let Ok(b) = value.cast::<PyBool>() {
        return Ok(toml::Value::Boolean(b.is_true()));
    }
    if value.is_instance_of::<PyInt>() {
        return value
            .extract::<i64>()
            .map(toml::Value::Integer)
            .map_err(|_| {
                (
                    key.to_string(),
                    "integer out of the range of a 64-bit TOML integer".to_string(),
                )
            });
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(value.extract::<f64>().expect("a float")));
    }
    if let Ok(s) = value.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_string()));
    }
    if let Ok(d) = value.cast::<PyDict>() {
        return toml_table(d, key).map(toml::Value::Table);
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        let failed = |e: PyErr| (key.to_string(), e.to_string());
        for (i, item) in value.try_iter().map_err(failed)?.enumerate() {
            let item = item.map_err(failed)?;
            items.push(toml_value(&item, &format!("{key}[{i}]"))?);
        }
        return Ok(toml::Value::Array(items));
    }
    // numpy scalars and the like: integers by __index__, reals by __float__
    if value.hasattr("__index__").unwrap_or(false)
        && let Ok(i) = value.extract::<i64>()
    {
        return Ok(toml::Value::Integer(i));
    }
    if value.hasattr("__float__").unwrap_or(false)
        && let Ok(x) = value.extract::<f64>()
    {
        return Ok(toml::Value::Float(x));
    }
    let type_name = value
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into());
    Err((
        key.to_string(),
        format!("a {type_name} is not a study value (give a bool, int, float, str, list or dict)"),
    ))
}

fn toml_table(dict: &Bound<'_, PyDict>, prefix: &str) -> Result<toml::Table, ValueError> {
    let mut table = toml::Table::new();
    for (k, v) in dict.iter() {
        let Ok(k) = k.extract::<String>() else {
            let reason = match prefix {
                "" => "every key must be a str".to_string(),
                p => format!("every key of {p} must be a str"),
            };
            return Err((prefix.to_string(), reason));
        };
        let key = match prefix {
            "" => k.clone(),
            p => format!("{p}.{k}"),
        };
        if v.is_none() {
            // TOML has no null: a key given as None is left out (its default applies)
            continue;
        }
        table.insert(k, toml_value(&v, &key)?);
    }
    Ok(table)
}
