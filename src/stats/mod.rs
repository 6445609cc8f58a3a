//! Statistics of the realisations: exact sums, performance measures with Monte Carlo
//! standard errors, and the two-pass summary of a study.

pub mod measures;
pub mod sum;
pub mod summary;
