//! Road elevation profiles: each one entry of [`PROFILES`] (its name in study files, how it
//! reads its own keys of `[terrain]`, and its elevation y(x)). The grade table, scaling and
//! the terrain metric are the same for every profile (see docs/model.md#terrain).

use std::fmt;
use std::sync::Arc;

/// A road's elevation along its distance.
pub trait Profile: fmt::Debug + Send + Sync {
    /// Elevation y(x) \[m\] of the unscaled profile at distance `x_m` \[m\].
    fn elevation_m(&self, x_m: f64) -> f64;
}

/// A key of `[terrain]` that a profile cannot accept, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyError {
    /// The dotted key, e.g. `terrain.components[1].period`.
    pub key: String,
    /// What is wrong.
    pub reason: String,
}

/// A profile as study files name it.
#[derive(Debug, Clone, Copy)]
pub struct ProfileEntry {
    /// The value of `terrain.profile`.
    pub name: &'static str,
    /// Read the profile's own keys of `[terrain]` (all of them: an unknown key is an error).
    pub parse: fn(&Params<'_>) -> Result<Arc<dyn Profile>, KeyError>,
}

/// Every profile a study can name.
pub static PROFILES: [ProfileEntry; 2] = [
    ProfileEntry {
        name: "cos2",
        parse: Cos2::parse,
    },
    ProfileEntry {
        name: "sines",
        parse: Sines::parse,
    },
];

/// The profile-specific keys of a `[terrain]` table (or of one of its inline tables),
/// read with their dotted names so that errors point at the key.
#[derive(Debug, Clone, Copy)]
pub struct Params<'a> {
    table: &'a toml::Table,
    prefix: &'a str,
}

impl<'a> Params<'a> {
    /// The keys of `table`, named `prefix.key`.
    pub fn new(table: &'a toml::Table, prefix: &'a str) -> Self {
        Params { table, prefix }
    }

    fn error(&self, key: &str, reason: impl Into<String>) -> KeyError {
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
            return Err(self.error(key, format!("must be a finite number, got {v}")));
        }
        Ok(v)
    }

    /// A number > 0.
    pub fn positive(&self, key: &str) -> Result<f64, KeyError> {
        let v = self.number(key)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.error(key, format!("must be > 0, got {v}")))
        }
    }

    /// A number ≥ 0.
    pub fn non_negative(&self, key: &str) -> Result<f64, KeyError> {
        let v = self.number(key)?;
        if v >= 0.0 {
            Ok(v)
        } else {
            Err(self.error(key, format!("must be >= 0, got {v}")))
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
                    toml::Value::Table(t) => each(&Params::new(t, &prefix)),
                    _ => Err(KeyError {
                        key: prefix.clone(),
                        reason: "must be a table such as { height = 25.0, period = 300.0 }".into(),
                    }),
                }
            })
            .collect()
    }
}

/// `"cos2"`: y(x) = h cos²(x / P), the thesis's hill.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cos2 {
    /// Peak-to-trough height h \[m\].
    pub height_m: f64,
    /// Period parameter P \[m\] (the elevation repeats every π P).
    pub period_m: f64,
}

impl Cos2 {
    fn parse(p: &Params<'_>) -> Result<Arc<dyn Profile>, KeyError> {
        p.only(&["height", "period"])?;
        Ok(Arc::new(Cos2 {
            height_m: p.non_negative("height")?,
            period_m: p.positive("period")?,
        }))
    }
}

impl Profile for Cos2 {
    fn elevation_m(&self, x_m: f64) -> f64 {
        let c = (x_m / self.period_m).cos();
        self.height_m * c * c
    }
}

/// `"sines"`: y(x) = Σ h_k cos²(x / P_k + φ_k), a road of several superposed hills.
#[derive(Debug, Clone, PartialEq)]
pub struct Sines {
    /// The components (h_k \[m\], P_k \[m\], φ_k \[rad\]).
    pub components: Vec<Cos2Component>,
}

/// One component of a [`Sines`] profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cos2Component {
    /// Height h_k \[m\].
    pub height_m: f64,
    /// Period parameter P_k \[m\].
    pub period_m: f64,
    /// Phase φ_k \[rad\].
    pub phase_rad: f64,
}

impl Sines {
    fn parse(p: &Params<'_>) -> Result<Arc<dyn Profile>, KeyError> {
        p.only(&["components"])?;
        let components = p.tables("components", |c| {
            c.only(&["height", "period", "phase"])?;
            Ok(Cos2Component {
                height_m: c.non_negative("height")?,
                period_m: c.positive("period")?,
                phase_rad: c.number("phase")?,
            })
        })?;
        Ok(Arc::new(Sines { components }))
    }
}

impl Profile for Sines {
    fn elevation_m(&self, x_m: f64) -> f64 {
        self.components
            .iter()
            .map(|k| {
                let c = (x_m / k.period_m + k.phase_rad).cos();
                k.height_m * c * c
            })
            .sum()
    }
}
