//! Estimation: the vehicle regression, its per-realisation sums, its estimators and bounds.
//!
//! - [`regression`]: the noise-free columns of one drive cycle and their constant sums;
//! - [`channels`]: the noise channels of the measurements, one enum variant each;
//! - [`sums`]: the sums of the normal equations, one typed list, and [`sums::Moments`];
//! - [`moments`]: one realisation's sums, accumulated block by block from the noise draws
//!   (the kernel), with the block sums of `moments/lane_sums.rs`;
//! - [`controls`]: the control variates, each moment minus its expectation;
//! - [`systems`]: the OLS and BCLS normal equations of the moments;
//! - [`estimator`]: what an estimator is (the trait, what it reads of a realisation, its own
//!   scan of the rows and columns, its first-order bias);
//! - [`estimators`]: OLS, BCLS and the registry; [`wbcls`] (weighted BCLS), [`rls`]
//!   (recursive LS with forgetting) and [`road_load`] (the coast-down's A + B·V + C·V² fit)
//!   from the rows, with the segment sums they share in `moments/segment_sums.rs`;
//! - [`parameters`]: which components of θ are fitted (all, or all but a known 1/M);
//! - [`bounds`]: the bounds and predicted spreads;
//! - [`conversions`]: M̂, Ĉd and the thesis's error conversions;
//!
//! The small normal-equation systems are solved by [`crate::numeric::linalg`].
//!
//! The equations are in docs/model.md.

pub mod bounds;
pub mod campaign;
pub mod channels;
pub mod controls;
pub mod conversions;
pub mod estimator;
pub mod filters;
pub mod moments;
pub mod parameters;
pub mod regression;
pub mod sums;
pub mod systems;

/// The registry of estimators: one line per file of `estimate/` that holds estimators,
/// `module => [Type, …]` (the module is declared here), in the order study files' messages
/// list them. Generates [`ESTIMATORS`].
macro_rules! estimators {
    ($($module:ident => [$($estimator:ident),+],)*) => {
        $(pub mod $module;)*

        /// Every estimator a study can name, in the order they are listed in messages.
        pub static ESTIMATORS: [&dyn estimator::Estimator; [$($(stringify!($estimator)),+),*].len()] =
            [$($(&$module::$estimator),+),*];
    };
}

estimators! {
    estimators => [Ols, Bcls],
    wbcls => [Wbcls],
    rls => [Rls],
    road_load => [RoadLoad],
    filtering => [RlsMf, Ekf],
}
