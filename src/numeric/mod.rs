//! Numerical foundations used by every stage: exact order-independent sums (so results do
//! not depend on thread count or shard split) and the stable solution of small symmetric
//! positive-definite systems (the normal equations); double-double arithmetic for the few
//! computations that cancel more digits than `f64` has; a sine and cosine of small angles
//! that vectorises and gives the same bits on every x86-64 CPU, and the turn of grade
//! noise's gravity terms by its small angle; the one RK4 stepper; FNV-1a fingerprints;
//! which vector instructions the fast paths may use (and the switch that forces the
//! portable code).

pub mod dd;
pub mod hash;
pub mod linalg;
pub mod ode;
pub mod profile_search;
pub mod simd;
pub mod sum;
pub mod trig;
