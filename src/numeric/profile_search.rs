//! The search of a designed drive (docs/model.md#designed-drive): the segment levels of a
//! piecewise profile between `lo` and `hi` that minimise a criterion, by argmin.
//!
//! Three stages, each an argmin solver run by its `Executor`:
//! 1. every square wave between the limits whose half period is a whole number of segments
//!    (1 to all of them, starting low and starting high): the best is the start;
//! 2. a segment search ([`SegmentFlip`], a solver of this file): each iteration evaluates,
//!    in parallel, the profile with one segment moved to the other limit, for every
//!    segment, and takes the best if it improves, until none does (a local optimum among
//!    profiles that differ in one segment);
//! 3. a Nelder–Mead polish (argmin's `NelderMead`) of the levels as continuous values,
//!    level = lo + (hi − lo) sin² z, from a simplex about the segment search's answer whose
//!    steps are drawn from the study's seed.
//!
//! The answer is the best profile seen; every stage is deterministic for the seed (the
//! parallel evaluations return in order).

use std::sync::atomic::{AtomicU64, Ordering};

use argmin::core::{
    CostFunction, Error, Executor, IterState, KV, Problem, Solver, State, TerminationReason,
    TerminationStatus,
};
use argmin::solver::neldermead::NelderMead;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The criterion of a profile's segment levels \[N·m\] (lower is better; +∞ for a profile
/// that cannot be driven).
pub type Objective<'a> = dyn Fn(&[f64]) -> f64 + Sync + 'a;

/// A square wave between the limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SquareWave {
    /// Its half period in segments.
    pub half_segments: usize,
    /// Whether it starts at the lower limit.
    pub low_first: bool,
}

impl SquareWave {
    /// Its segment levels.
    pub fn levels(self, segments: usize, lo: f64, hi: f64) -> Vec<f64> {
        (0..segments)
            .map(
                |j| match (j / self.half_segments).is_multiple_of(2) == self.low_first {
                    true => lo,
                    false => hi,
                },
            )
            .collect()
    }
}

/// What the search found.
#[derive(Debug, Clone)]
pub struct Found {
    /// The best segment levels \[N·m\].
    pub levels: Vec<f64>,
    /// Their criterion.
    pub criterion: f64,
    /// The best square wave and its criterion.
    pub square: (SquareWave, f64),
    /// The criterion after the segment search (before the polish).
    pub after_flips: f64,
    /// Number of criterion evaluations.
    pub evaluations: u64,
}

/// Search the levels of `segments` segments within [`lo`, `hi`] minimising `objective`.
pub fn search(
    objective: &Objective<'_>,
    segments: usize,
    lo: f64,
    hi: f64,
    polish_iterations: u64,
    seed: u64,
) -> Result<Found, Error> {
    let counted = Counted {
        objective,
        count: AtomicU64::new(0),
    };
    // Stage 1 and 2: the square waves, then the segment search from the best.
    let flip = SegmentFlip {
        segments,
        lo,
        hi,
        square: None,
        converged: false,
    };
    let flipped = Executor::new(&counted, flip)
        .configure(|s| s.max_iters(4 * segments as u64))
        .timer(false)
        .run()?;
    let square = flipped
        .solver
        .square
        .expect("the segment search starts from a square wave");
    let after_flips = flipped.state.get_best_cost();
    let mut levels = flipped
        .state
        .get_best_param()
        .cloned()
        .expect("the segment search has a best profile");
    let mut criterion = after_flips;
    // Stage 3: the Nelder–Mead polish in z, level = lo + (hi − lo) sin² z.
    if polish_iterations > 0 && criterion.is_finite() {
        let span = hi - lo;
        let z0: Vec<f64> = levels
            .iter()
            .map(|&l| ((l - lo) / span).clamp(0.0, 1.0).sqrt().asin())
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut simplex = vec![z0.clone()];
        for j in 0..segments {
            let mut z = z0.clone();
            // A step of 0.1–0.3 rad into the box's interior (z at 0 or π/2 is a limit).
            let step: f64 = rng.random_range(0.1..0.3);
            z[j] += if z[j] > std::f64::consts::FRAC_PI_4 {
                -step
            } else {
                step
            };
            simplex.push(z);
        }
        let in_z = InZ {
            inner: &counted,
            lo,
            span,
        };
        let polished = Executor::new(in_z, NelderMead::new(simplex))
            .configure(|s| s.max_iters(polish_iterations))
            .timer(false)
            .run()?;
        if polished.state.get_best_cost() < criterion {
            criterion = polished.state.get_best_cost();
            let z = polished
                .state
                .get_best_param()
                .expect("the polish has a best point");
            levels = z.iter().map(|&z| lo + span * z.sin().powi(2)).collect();
        }
    }
    Ok(Found {
        levels,
        criterion,
        square,
        after_flips,
        evaluations: counted.count.load(Ordering::Relaxed),
    })
}

/// The objective, counting its evaluations.
struct Counted<'a, 'b> {
    objective: &'a Objective<'b>,
    count: AtomicU64,
}

impl CostFunction for &Counted<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, levels: &Vec<f64>) -> Result<f64, Error> {
        self.count.fetch_add(1, Ordering::Relaxed);
        Ok((self.objective)(levels))
    }
}

/// The objective of z, level = lo + span · sin² z.
struct InZ<'a, 'b, 'c> {
    inner: &'a Counted<'b, 'c>,
    lo: f64,
    span: f64,
}

impl CostFunction for InZ<'_, '_, '_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, z: &Vec<f64>) -> Result<f64, Error> {
        let levels: Vec<f64> = z
            .iter()
            .map(|&z| self.lo + self.span * z.sin().powi(2))
            .collect();
        (&self.inner).cost(&levels)
    }
}

type Flips = IterState<Vec<f64>, (), (), (), (), f64>;

/// The segment search: from the best square wave, move the one segment whose move to the
/// other limit improves the criterion most, until none does.
struct SegmentFlip {
    segments: usize,
    lo: f64,
    hi: f64,
    /// The best square wave and its criterion (set by `init`).
    square: Option<(SquareWave, f64)>,
    converged: bool,
}

impl<O> Solver<O, Flips> for SegmentFlip
where
    O: CostFunction<Param = Vec<f64>, Output = f64> + Sync,
{
    fn name(&self) -> &str {
        "segment flip"
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: Flips,
    ) -> Result<(Flips, Option<KV>), Error> {
        let waves: Vec<SquareWave> = (1..=self.segments)
            .flat_map(|half_segments| {
                [true, false].map(|low_first| SquareWave {
                    half_segments,
                    low_first,
                })
            })
            .collect();
        let profiles: Vec<Vec<f64>> = waves
            .iter()
            .map(|w| w.levels(self.segments, self.lo, self.hi))
            .collect();
        let costs = problem.bulk_cost(&profiles)?;
        let best = argmin_index(&costs);
        self.square = Some((waves[best], costs[best]));
        Ok((state.param(profiles[best].clone()).cost(costs[best]), None))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        mut state: Flips,
    ) -> Result<(Flips, Option<KV>), Error> {
        let current = state.take_param().expect("init sets the profile");
        let cost = state.get_cost();
        let (lo, hi) = (self.lo, self.hi);
        let moved: Vec<Vec<f64>> = (0..self.segments)
            .map(|j| {
                let mut p = current.clone();
                p[j] = if p[j] - lo < hi - p[j] { hi } else { lo };
                p
            })
            .collect();
        let costs = problem.bulk_cost(&moved)?;
        let best = argmin_index(&costs);
        if costs[best] < cost {
            Ok((state.param(moved[best].clone()).cost(costs[best]), None))
        } else {
            self.converged = true;
            Ok((state.param(current).cost(cost), None))
        }
    }

    fn terminate(&mut self, _state: &Flips) -> TerminationStatus {
        match self.converged {
            true => TerminationStatus::Terminated(TerminationReason::SolverConverged),
            false => TerminationStatus::NotTerminated,
        }
    }
}

/// The index of the smallest value (the first of equals; NaN never wins).
fn argmin_index(costs: &[f64]) -> usize {
    let mut best = 0;
    for (i, &c) in costs.iter().enumerate() {
        if c < costs[best] || costs[best].is_nan() {
            best = i;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_search_finds_the_best_profile_of_a_separable_objective() {
        // Segment j contributes (level − target_j)², target_j at a limit: the optimum is the
        // targets, which differ from every square wave; the segment search reaches it.
        let targets: Vec<f64> = (0..12)
            .map(|j| if j % 5 == 1 { 0.0 } else { 10.0 })
            .collect();
        let objective =
            |l: &[f64]| -> f64 { l.iter().zip(&targets).map(|(a, b)| (a - b).powi(2)).sum() };
        let found = search(&objective, 12, 0.0, 10.0, 50, 7).unwrap();
        assert_eq!(found.levels, targets);
        assert_eq!(found.criterion, 0.0);
        assert!(found.square.1 > 0.0);
    }

    #[test]
    fn square_waves_alternate_every_half_period() {
        let w = SquareWave {
            half_segments: 2,
            low_first: false,
        };
        assert_eq!(w.levels(6, 0.0, 1.0), vec![1.0, 1.0, 0.0, 0.0, 1.0, 1.0]);
    }
}
