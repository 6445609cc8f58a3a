//! Integration tests, compiled into one binary (see `tests/suite/`).
//!
//! Realisation counts are kept small so that `cargo test` stays within a few minutes on two
//! cores; every tolerance is derived from a Monte Carlo standard error or a numerical
//! argument written beside it.

mod suite;
