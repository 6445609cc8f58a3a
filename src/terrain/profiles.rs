//! Road elevation profiles: each one entry of [`PROFILES`] (its name in study files, how it
//! reads its own keys of `[terrain]`, and its elevation y(x)). The grade table, scaling and
//! the terrain metric are the same for every profile (see docs/model.md#terrain).

use std::fmt;
use std::sync::Arc;

use crate::settings::{KeyError, Params};

/// A road's elevation along its distance.
pub trait Profile: fmt::Debug + Send + Sync {
    /// Elevation y(x) \[m\] of the unscaled profile at distance `x_m` \[m\].
    fn elevation_m(&self, x_m: f64) -> f64;
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
