//! Realisations of a condition computed side by side where each waits on a recursion of its
//! own: the AR(1) filter of a differentiated acceleration's span noise, and the cycle a
//! realisation's own truth drives. The recursions are independent, so the processor
//! overlaps them; each is the one realisation's alone, operation for operation (the same
//! bits).

use std::cell::RefCell;

use super::VehicleModel;
use super::draws::{Draws, filter_side_by_side};
use super::kernel::SPEED;
use super::layout::ROWS;
use super::world::MovedCycle;

/// How many realisations' cycles are integrated side by side where each realisation's truth
/// moves the vehicle (their cycles held at once).
const SIDE_BY_SIDE: usize = 4;

thread_local! {
    /// The filtered span noise of this thread's current group of realisations (memory
    /// reused).
    static SPANS: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

impl VehicleModel {
    /// Whether the realisations of condition `c` take their speed noise AR(1)-filtered over
    /// a differentiated acceleration's span, on the condition's own regression: then
    /// [`Self::filter_spans`] filters a group of them side by side.
    pub(super) fn spans_filtered_together(&self, c: usize) -> bool {
        let cond = &self.conditions[c];
        cond.world.is_none()
            && cond.ar1.is_some()
            && cond.regression.differentiation.is_some()
            && cond.noise.speed_noise_differentiated()
    }

    /// The speed noise of the span of realisations `first .. first + count` of condition
    /// `c` ([`Self::spans_filtered_together`]) into `out`, realisation i's at
    /// `i * len .. (i + 1) * len` (`len` returned): drawn as [`Self::measure`] draws it,
    /// and AR(1)-filtered with the realisations side by side. The recursions are
    /// independent, so the processor overlaps them; one alone waits on each step's
    /// multiply and add. The same operations in the same order, so the same bits.
    pub(super) fn filter_spans(
        &self,
        seed: u64,
        c: usize,
        first: u64,
        count: usize,
        out: &mut Vec<f64>,
    ) -> usize {
        let cond = &self.conditions[c];
        let (Some(d), Some(ar1)) = (&cond.regression.differentiation, &cond.ar1) else {
            unreachable!("filter_spans on a condition without a filtered span");
        };
        let len = d.span_t.len();
        out.resize(count * len, 0.0);
        let key = self.stream_key(c);
        for (i, e) in out.chunks_exact_mut(len).enumerate() {
            Draws::new(self.shared, seed, key, SPEED, first + i as u64).fill(e);
        }
        let mut spans: Vec<&mut [f64]> = out.chunks_exact_mut(len).collect();
        filter_side_by_side(&mut spans, |s| &mut **s, &mut vec![0.0; count], &ar1[..len]);
        len
    }

    /// [`Model::realise_group`](crate::model::Model::realise_group) of realisations `first .. first + count` of condition `c`
    /// ([`Self::spans_filtered_together`]): each realisation on its own, from spans
    /// filtered side by side.
    pub(super) fn realise_filtered_spans(
        &self,
        seed: u64,
        c: usize,
        first: u64,
        count: usize,
        slots: &mut [f64],
    ) {
        SPANS.with_borrow_mut(|spans| {
            let len = self.filter_spans(seed, c, first, count, spans);
            let stride = self.layout.realisation_stride();
            ROWS.with_borrow_mut(|(rows, scans)| {
                for (i, (slots, span)) in slots
                    .chunks_exact_mut(stride)
                    .zip(spans.chunks_exact(len))
                    .enumerate()
                {
                    let r = first + i as u64;
                    self.realise_with(seed, c, r, rows, scans, slots, Some(span), None);
                }
            })
        });
    }

    /// The truths and cycles of realisations `first .. first + count` of condition `c`, made
    /// side by side, where each realisation's truth moves the vehicle
    /// ([`World::moved_cycles`]; `None` elsewhere).
    ///
    /// [`World::moved_cycles`]: super::world::World::moved_cycles
    pub(super) fn moved_cycles(
        &self,
        seed: u64,
        c: usize,
        first: u64,
        count: usize,
    ) -> Option<Vec<Result<MovedCycle, String>>> {
        let world = self.conditions[c].world.as_ref()?;
        world.moved_cycles(&self.study, (seed, self.stream_key(c)), first, count)
    }

    /// Whether each realisation of condition `c` drives a cycle of its own truth
    /// ([`World::moves_side_by_side`](super::world::World::moves_side_by_side)).
    pub(super) fn moves_per_realisation(&self, c: usize) -> bool {
        self.conditions[c]
            .world
            .as_ref()
            .is_some_and(|w| w.moves_side_by_side())
    }

    /// [`Model::realise_group`](crate::model::Model::realise_group) where a condition's realisations each drive a cycle of their
    /// own truth: a condition at a time, its realisations' cycles made [`SIDE_BY_SIDE`] at
    /// once ([`VehicleModel::moved_cycles`]), each realisation then as
    /// [`Model::realise`](crate::model::Model::realise) computes it, into its place among the slots.
    pub(super) fn realise_moved(
        &self,
        seed: u64,
        conditions: &[usize],
        first: u64,
        count: usize,
        slots: &mut [f64],
    ) {
        let stride = self.layout.realisation_stride();
        ROWS.with_borrow_mut(|(rows, scans)| {
            for (k, &c) in conditions.iter().enumerate() {
                for from in (0..count).step_by(SIDE_BY_SIDE) {
                    let chunk = SIDE_BY_SIDE.min(count - from);
                    let at = first + from as u64;
                    let mut moved = self.moved_cycles(seed, c, at, chunk).map(Vec::into_iter);
                    for i in from..from + chunk {
                        let place = (i * conditions.len() + k) * stride;
                        let slots = &mut slots[place..place + stride];
                        let given = moved.as_mut().map(|m| m.next().expect("a cycle each"));
                        let r = first + i as u64;
                        self.realise_with(seed, c, r, rows, scans, slots, None, given);
                    }
                }
            }
        });
    }
}
