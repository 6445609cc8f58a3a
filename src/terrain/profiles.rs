//! Road profiles: each one entry of [`PROFILES`] (its name in study files, how it reads its
//! own keys of `[terrain]`, and its rise over each 1 m step). The grade table, scaling and
//! the terrain metric are the same for every profile (see docs/model.md#terrain).

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

use super::{GRID_STEP_M, GradeUnit};
use crate::settings::{KeyError, Params};
use crate::tabular::read_columns;

/// A road's profile along its distance.
pub trait Profile: fmt::Debug + Send + Sync {
    /// The unscaled rise y(x_{i+1}) − y(x_i) \[m\] over each grid step i = 0 … length − 1
    /// (x_i = i m).
    fn rises_m(&self, length: usize) -> Vec<f64>;

    /// The profile in a few words, for tables and figures (e.g. `cos2 h = 25 m, P = 300 m`).
    fn describe(&self) -> String;

    /// The distance up to which the profile is defined \[m\] (`None`: any length).
    fn extent_m(&self) -> Option<f64> {
        None
    }

    /// The grade's random walk when the profile is drawn anew in every realisation (its
    /// rises are then those of a flat road, the condition's nominal one).
    fn grade_walk(&self) -> Option<GradeWalk> {
        None
    }
}

/// The rises of the elevation function `y` \[m\] on the grid x = 0 … length m (forward Euler,
/// as the thesis).
pub fn rises_of(y: impl Fn(f64) -> f64, length: usize) -> Vec<f64> {
    let elevation: Vec<f64> = (0..=length).map(|i| y(i as f64 * GRID_STEP_M)).collect();
    elevation.windows(2).map(|w| w[1] - w[0]).collect()
}

/// A profile as study files name it.
#[derive(Debug, Clone, Copy)]
pub struct ProfileEntry {
    /// The value of `terrain.profile`.
    pub name: &'static str,
    /// The profile's own keys of `[terrain]` (besides the keys every profile has).
    pub keys: &'static [&'static str],
    /// Read the profile's own keys of `[terrain]` (all of them: an unknown key is an error).
    pub parse: fn(&Params<'_>) -> Result<Arc<dyn Profile>, KeyError>,
}

/// Every profile a study can name.
pub static PROFILES: [ProfileEntry; 4] = [
    ProfileEntry {
        name: "cos2",
        keys: Cos2::KEYS,
        parse: Cos2::parse,
    },
    ProfileEntry {
        name: "sines",
        keys: Sines::KEYS,
        parse: Sines::parse,
    },
    ProfileEntry {
        name: "file",
        keys: FileProfile::KEYS,
        parse: FileProfile::parse,
    },
    ProfileEntry {
        name: "random_walk",
        keys: RandomWalk::KEYS,
        parse: RandomWalk::parse,
    },
];

/// The grade as a random walk in distance: φ₀ ~ N(0, σ₀²), φ_{k+1} = φ_k + w_k,
/// w_k ~ N(0, q·|V_k|·Δt) (`terrain.profile = "random_walk"`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GradeWalk {
    /// q \[rad²/m\].
    pub intensity: f64,
    /// σ₀ \[rad\].
    pub sd0_rad: f64,
}

/// `"random_walk"`: the grade a random walk in distance, drawn anew in every realisation
/// (the filters' model of the grade: docs/model.md#filter-truth); its nominal road is flat.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RandomWalk(pub GradeWalk);

impl RandomWalk {
    const KEYS: &'static [&'static str] = &["grade_walk", "grade_sd0"];

    fn parse(p: &Params<'_>) -> Result<Arc<dyn Profile>, KeyError> {
        p.only(Self::KEYS)?;
        Ok(Arc::new(RandomWalk(GradeWalk {
            intensity: p.positive("grade_walk")?,
            sd0_rad: p.non_negative("grade_sd0")?,
        })))
    }
}

impl Profile for RandomWalk {
    fn rises_m(&self, length: usize) -> Vec<f64> {
        vec![0.0; length]
    }

    fn describe(&self) -> String {
        format!(
            "random walk q = {} rad²/m, σ₀ = {} rad",
            self.0.intensity, self.0.sd0_rad
        )
    }

    fn grade_walk(&self) -> Option<GradeWalk> {
        Some(self.0)
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
    const KEYS: &'static [&'static str] = &["height", "period"];

    fn parse(p: &Params<'_>) -> Result<Arc<dyn Profile>, KeyError> {
        p.only(Self::KEYS)?;
        Ok(Arc::new(Cos2 {
            height_m: p.non_negative("height")?,
            period_m: p.positive("period")?,
        }))
    }
}

impl Cos2 {
    /// Elevation y(x) \[m\] at distance `x_m` \[m\].
    pub fn elevation_m(&self, x_m: f64) -> f64 {
        let c = (x_m / self.period_m).cos();
        self.height_m * c * c
    }
}

impl Profile for Cos2 {
    fn rises_m(&self, length: usize) -> Vec<f64> {
        rises_of(|x| self.elevation_m(x), length)
    }

    fn describe(&self) -> String {
        format!("cos2 h = {} m, P = {} m", self.height_m, self.period_m)
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
    const KEYS: &'static [&'static str] = &["components"];

    fn parse(p: &Params<'_>) -> Result<Arc<dyn Profile>, KeyError> {
        p.only(Self::KEYS)?;
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

impl Sines {
    /// Elevation y(x) \[m\] at distance `x_m` \[m\].
    pub fn elevation_m(&self, x_m: f64) -> f64 {
        self.components
            .iter()
            .map(|k| {
                let c = (x_m / k.period_m + k.phase_rad).cos();
                k.height_m * c * c
            })
            .sum()
    }
}

impl Profile for Sines {
    fn rises_m(&self, length: usize) -> Vec<f64> {
        rises_of(|x| self.elevation_m(x), length)
    }

    fn describe(&self) -> String {
        format!("sines of {} components", self.components.len())
    }
}

/// `"file"`: a road from a data file, elevation \[m\] or grade by distance \[m\], linearly
/// interpolated to the 1 m grid.
#[derive(Debug, Clone, PartialEq)]
pub struct FileProfile {
    /// The data file.
    pub file: PathBuf,
    /// Distances \[m\], strictly increasing, the first at most 0.
    pub distance_m: Vec<f64>,
    /// What the file gives at those distances.
    pub values: FileValues,
}

/// The quantity a terrain file gives.
#[derive(Debug, Clone, PartialEq)]
pub enum FileValues {
    /// Elevation \[m\]: grades by forward Euler on the grid, as every profile.
    Elevation(Vec<f64>),
    /// Grade \[rad\]: interpolated to the grid directly.
    Grade(Vec<f64>),
}

impl FileProfile {
    const KEYS: &'static [&'static str] = &[
        "file",
        "distance_column",
        "elevation_column",
        "grade_column",
        "grade_unit",
    ];

    fn parse(p: &Params<'_>) -> Result<Arc<dyn Profile>, KeyError> {
        p.only(Self::KEYS)?;
        let file = p.file("file")?;
        let distance = p.string("distance_column")?;
        let (column, unit) = match (p.has("elevation_column"), p.has("grade_column")) {
            (true, false) => {
                if p.has("grade_unit") {
                    return Err(p.error("grade_unit", "applies to grade_column only"));
                }
                (p.string("elevation_column")?, None)
            }
            (false, true) => (
                p.string("grade_column")?,
                Some(GradeUnit::parse(p, "grade_unit")?),
            ),
            _ => {
                return Err(p.error(
                    "elevation_column",
                    "give exactly one of elevation_column and grade_column",
                ));
            }
        };
        let cols = read_columns(&file, &[distance, column], 3)
            .map_err(|e| p.error("file", e.to_string()))?;
        cols.strictly_increasing(distance)
            .map_err(|e| p.error("file", e.to_string()))?;
        let distance_m = cols.get(distance).to_vec();
        if distance_m[0] > 0.0 {
            return Err(p.error(
                "file",
                format!(
                    "{}: column \"{distance}\" starts at {} m; the road must start at 0 m",
                    file.display(),
                    distance_m[0]
                ),
            ));
        }
        let v = cols.get(column);
        let values = match unit {
            None => FileValues::Elevation(v.to_vec()),
            Some(unit) => FileValues::Grade(v.iter().map(|&g| unit.to_rad(g)).collect()),
        };
        Ok(Arc::new(FileProfile {
            file,
            distance_m,
            values,
        }))
    }

    /// Linear interpolation of `values` at `x_m` (inside the file's range).
    fn at(&self, values: &[f64], x_m: f64) -> f64 {
        let d = &self.distance_m;
        // The segment [d[i], d[i + 1]] holding x (the last one at the end).
        let i = d.partition_point(|&di| di <= x_m).clamp(1, d.len() - 1) - 1;
        if x_m == d[i] {
            return values[i];
        }
        let f = (x_m - d[i]) / (d[i + 1] - d[i]);
        values[i] + f * (values[i + 1] - values[i])
    }
}

impl Profile for FileProfile {
    fn rises_m(&self, length: usize) -> Vec<f64> {
        match &self.values {
            FileValues::Elevation(y) => rises_of(|x| self.at(y, x), length),
            FileValues::Grade(g) => (0..length)
                .map(|i| self.at(g, i as f64 * GRID_STEP_M).tan() * GRID_STEP_M)
                .collect(),
        }
    }

    fn extent_m(&self) -> Option<f64> {
        self.distance_m.last().copied()
    }

    fn describe(&self) -> String {
        let what = match self.values {
            FileValues::Elevation(_) => "elevation",
            FileValues::Grade(_) => "grade",
        };
        let name = self.file.file_name().unwrap_or_default().to_string_lossy();
        format!("{what} from {name}")
    }
}
