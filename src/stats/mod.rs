//! Statistics of the realisations: performance measures with Monte Carlo standard errors,
//! and the two-pass summary of a study (with the exact sums of [`crate::numeric::sum`]).

pub mod columns;
pub mod control;
pub mod fleet;
pub mod measures;
pub mod plan;
pub mod spread;
pub mod summary;
