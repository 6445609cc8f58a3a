//! Each thread's spare drive cycles: a realisation whose truth moves the vehicle makes a
//! cycle of its own and drops it once its regression is built. Freed, a column of that size
//! goes back to the system (the binary serves allocations of 128 KiB and more by mmap) and
//! the next realisation's first touch of every page faults again; kept here, the next cycle
//! writes into memory already mapped.

use std::cell::RefCell;

use super::DriveCycle;

/// At most this many bytes of spare cycles are kept per thread (a few of the thesis
/// cycle's 3.4 MB; a cycle larger than this is never kept).
const SPARE_BYTES: usize = 32 << 20;

thread_local! {
    static SPARE: RefCell<Vec<DriveCycle>> = const { RefCell::new(Vec::new()) };
}

impl DriveCycle {
    /// An empty cycle of one run driven forwards, with room for `n` samples: one of the
    /// thread's spare cycles ([`DriveCycle::recycle`]) when it has one.
    pub fn one_run(n: usize) -> Self {
        match SPARE.with_borrow_mut(Vec::pop) {
            Some(mut cycle) => {
                for column in cycle.columns_mut() {
                    column.clear();
                    column.reserve(n);
                }
                cycle.run.clear();
                cycle.run.resize(n, 0);
                cycle.run_heading.clear();
                cycle.run_heading.push(1.0);
                cycle
            }
            None => DriveCycle {
                t_s: Vec::with_capacity(n),
                x_m: Vec::with_capacity(n),
                v_m_s: Vec::with_capacity(n),
                grade_rad: Vec::with_capacity(n),
                f_prop_n: Vec::with_capacity(n),
                accel_m_s2: Vec::with_capacity(n),
                run: vec![0; n],
                run_heading: vec![1.0],
            },
        }
    }

    /// Give a cycle that is no longer needed to the thread's spares, whose memory the
    /// thread's next [`DriveCycle::one_run`] reuses (dropped instead when the spares would
    /// pass [`SPARE_BYTES`]).
    pub fn recycle(self) {
        let bytes = |c: &DriveCycle| {
            let columns: usize = c.columns().map(Vec::capacity).sum();
            8 * columns + 4 * c.run.capacity()
        };
        SPARE.with_borrow_mut(|spare| {
            if spare.iter().map(bytes).sum::<usize>() + bytes(&self) <= SPARE_BYTES {
                spare.push(self);
            }
        });
    }

    /// The six sampled columns.
    fn columns(&self) -> impl Iterator<Item = &Vec<f64>> {
        [
            &self.t_s,
            &self.x_m,
            &self.v_m_s,
            &self.grade_rad,
            &self.f_prop_n,
            &self.accel_m_s2,
        ]
        .into_iter()
    }

    /// The six sampled columns, to be written.
    fn columns_mut(&mut self) -> impl Iterator<Item = &mut Vec<f64>> {
        [
            &mut self.t_s,
            &mut self.x_m,
            &mut self.v_m_s,
            &mut self.grade_rad,
            &mut self.f_prop_n,
            &mut self.accel_m_s2,
        ]
        .into_iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recycled_cycle_comes_back_empty_with_one_forwards_run() {
        let mut used = DriveCycle::one_run(10);
        for i in 0..10 {
            for column in used.columns_mut() {
                column.push(i as f64);
            }
        }
        used.run.iter_mut().for_each(|r| *r = 3);
        used.run_heading = vec![-1.0, 1.0];
        let fresh = DriveCycle::one_run(12);
        used.recycle();
        let again = DriveCycle::one_run(12);
        assert_eq!(again, fresh);
        assert!(again.columns().all(|c| c.capacity() >= 12));
    }
}
