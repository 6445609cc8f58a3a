//! Typed reading of the study-file keys that an extension owns: each terrain profile and
//! drive mode reads its own keys through [`Params`], and a key it cannot accept is a
//! [`KeyError`] naming the dotted key, which the study turns into an error with the file and
//! line.

use std::path::{Path, PathBuf};

/// A value or a list of values, as the list: one value stands for the list of that value
/// (`scales = 1.0` is `scales = [1.0]`). Every reader of such a key of a `toml::Value` goes
/// through it; the study's serde structs have the same rule as a deserialiser (which keeps
/// each item's place in the file for errors).
pub fn one_or_many(value: &toml::Value) -> &[toml::Value] {
    match value {
        toml::Value::Array(items) => items,
        one => std::slice::from_ref(one),
    }
}

/// A key that an extension cannot accept, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyError {
    /// The dotted key, e.g. `terrain.components[1].period`.
    pub key: String,
    /// What is wrong.
    pub reason: String,
}

/// The keys of a study-file table that an extension reads itself (a terrain profile's keys of
/// `[terrain]`, a drive mode's of `[drive]`, or an inline table of them), read with their
/// dotted names so that errors point at the key.
#[derive(Debug, Clone, Copy)]
pub struct Params<'a> {
    table: &'a toml::Table,
    prefix: &'a str,
    dir: &'a Path,
}

impl<'a> Params<'a> {
    /// The keys of `table`, named `prefix.key`; file paths relative to the working directory.
    pub fn new(table: &'a toml::Table, prefix: &'a str) -> Self {
        Params {
            table,
            prefix,
            dir: Path::new(""),
        }
    }

    /// The same keys, with file paths relative to `dir` (the study file's directory).
    pub fn relative_to(self, dir: &'a Path) -> Self {
        Params { dir, ..self }
    }

    /// Whether the table has `key`.
    pub fn has(&self, key: &str) -> bool {
        self.table.contains_key(key)
    }

    /// `read(self, key)` when the table has `key`, else `None`.
    pub fn optional<T>(
        &self,
        key: &str,
        read: impl FnOnce(&Self, &str) -> Result<T, KeyError>,
    ) -> Result<Option<T>, KeyError> {
        self.has(key).then(|| read(self, key)).transpose()
    }

    /// The value at `key`, as it is.
    pub fn value(&self, key: &str) -> Result<&'a toml::Value, KeyError> {
        self.table
            .get(key)
            .ok_or_else(|| self.error(key, "required key is missing"))
    }

    /// A string.
    pub fn string(&self, key: &str) -> Result<&'a str, KeyError> {
        match self.table.get(key) {
            None => Err(self.error(key, "required key is missing")),
            Some(toml::Value::String(s)) => Ok(s),
            Some(other) => {
                Err(self.error(key, format!("must be a string, got {}", other.type_str())))
            }
        }
    }

    /// The value named by the string at `key`, one of `named` (name, value) pairs.
    pub fn named<T: Copy>(&self, key: &str, named: &[(&'static str, T)]) -> Result<T, KeyError> {
        let s = self.string(key)?;
        match named.iter().find(|(n, _)| *n == s) {
            Some((_, value)) => Ok(*value),
            None => {
                let names: Vec<&str> = named.iter().map(|(n, _)| *n).collect();
                Err(self.error(key, format!("must be one of {names:?}, got \"{s}\"")))
            }
        }
    }

    /// A boolean.
    pub fn boolean(&self, key: &str) -> Result<bool, KeyError> {
        match self.table.get(key) {
            None => Err(self.error(key, "required key is missing")),
            Some(toml::Value::Boolean(b)) => Ok(*b),
            Some(other) => Err(self.error(
                key,
                format!("must be true or false, got {}", other.type_str()),
            )),
        }
    }

    /// A file path, relative to the study file's directory unless absolute.
    pub fn file(&self, key: &str) -> Result<PathBuf, KeyError> {
        let s = self.string(key)?;
        if s.is_empty() {
            return Err(self.error(key, "must name a file"));
        }
        Ok(self.dir.join(s))
    }

    /// A non-empty list of numbers > 0 (one number stands for the list of that number).
    pub fn positive_list(&self, key: &str) -> Result<Vec<f64>, KeyError> {
        let value = self
            .table
            .get(key)
            .ok_or_else(|| self.error(key, "required key is missing"))?;
        let items = one_or_many(value);
        if items.is_empty() || !(value.is_array() || value.is_float() || value.is_integer()) {
            return Err(self.error(key, "must be a number or a non-empty list of numbers"));
        }
        items
            .iter()
            .enumerate()
            .map(|(i, item)| {
                let v = match item {
                    toml::Value::Float(f) => *f,
                    toml::Value::Integer(n) => *n as f64,
                    other => {
                        return Err(self.error(
                            &format!("{key}[{i}]"),
                            format!("must be a number, got {}", other.type_str()),
                        ));
                    }
                };
                if v > 0.0 && v.is_finite() {
                    Ok(v)
                } else {
                    Err(self.error(
                        &format!("{key}[{i}]"),
                        format!("must be > 0, got {}", shown(v)),
                    ))
                }
            })
            .collect::<Result<Vec<f64>, _>>()
            .and_then(|values| match first_repeat(&values) {
                Some((first, again)) => Err(self.error(
                    &format!("{key}[{again}]"),
                    format!(
                        "{} is listed twice (also at {key}[{first}]); each value of an axis is \
                         one condition",
                        values[again]
                    ),
                )),
                None => Ok(values),
            })
    }

    /// An error about `key` of this table.
    pub fn error(&self, key: &str, reason: impl Into<String>) -> KeyError {
        KeyError {
            key: format!("{}.{key}", self.prefix),
            reason: reason.into(),
        }
    }

    /// Fail on any key not in `known`.
    pub fn only(&self, known: &[&str]) -> Result<(), KeyError> {
        match self.table.keys().find(|k| !known.contains(&k.as_str())) {
            Some(k) => {
                Err(self.error(k, format!("unknown field `{k}`, expected one of {known:?}")))
            }
            None => Ok(()),
        }
    }

    /// A finite number (integer or float).
    pub fn number(&self, key: &str) -> Result<f64, KeyError> {
        let v = match self.table.get(key) {
            None => return Err(self.error(key, "required key is missing")),
            Some(toml::Value::Float(f)) => *f,
            Some(toml::Value::Integer(i)) => *i as f64,
            Some(other) => {
                return Err(self.error(key, format!("must be a number, got {}", other.type_str())));
            }
        };
        if !v.is_finite() {
            return Err(self.error(key, format!("must be a finite number, got {}", shown(v))));
        }
        Ok(v)
    }

    /// A number > 0.
    pub fn positive(&self, key: &str) -> Result<f64, KeyError> {
        let v = self.number(key)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.error(key, format!("must be > 0, got {}", shown(v))))
        }
    }

    /// A number ≥ 0.
    pub fn non_negative(&self, key: &str) -> Result<f64, KeyError> {
        let v = self.number(key)?;
        if v >= 0.0 {
            Ok(v)
        } else {
            Err(self.error(key, format!("must be >= 0, got {}", shown(v))))
        }
    }

    /// A non-empty array of tables, each read by `each` with its own dotted prefix.
    pub fn tables<T>(
        &self,
        key: &str,
        each: impl Fn(&Params<'_>) -> Result<T, KeyError>,
    ) -> Result<Vec<T>, KeyError> {
        let items = match self.table.get(key) {
            None => return Err(self.error(key, "required key is missing")),
            Some(toml::Value::Array(items)) if !items.is_empty() => items,
            Some(_) => return Err(self.error(key, "must be a non-empty list of tables")),
        };
        items
            .iter()
            .enumerate()
            .map(|(i, item)| {
                let prefix = format!("{}.{key}[{i}]", self.prefix);
                match item {
                    toml::Value::Table(t) => each(&Params::new(t, &prefix).relative_to(self.dir)),
                    _ => Err(KeyError {
                        key: prefix.clone(),
                        reason: "must be a table such as { height = 25.0, period = 300.0 }".into(),
                    }),
                }
            })
            .collect()
    }
}

/// The first value of `values` equal to an earlier one, as (index of the earlier, index of
/// the repeat).
pub fn first_repeat(values: &[f64]) -> Option<(usize, usize)> {
    (1..values.len()).find_map(|j| (0..j).find(|&i| values[i] == values[j]).map(|i| (i, j)))
}

/// A number as a message shows it: as written for everyday sizes, in scientific notation
/// beyond them (so that 1e300 is not printed with its 301 digits).
pub fn shown(v: f64) -> String {
    match v.abs() {
        a if a == 0.0 || (1e-4..1e15).contains(&a) || !a.is_finite() => format!("{v}"),
        _ => format!("{v:e}"),
    }
}
