//! Numerical foundations used by every stage: exact order-independent sums (so results do
//! not depend on thread count or shard split) and the stable solution of small symmetric
//! positive-definite systems (the normal equations).

pub mod linalg;
pub mod sum;
