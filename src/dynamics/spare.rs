//! Each thread's spare drive cycles: a realisation whose truth moves the vehicle integrates
//! a cycle of its own and drops it once its regression is built. Freed, a column of that
//! size goes back to the system (the command line serves allocations of 128 KiB and more by
//! mmap) and the next realisation's first touch of every page faults again; kept here, the
//! next cycle is written into memory already mapped.

use std::cell::RefCell;

use super::DriveCycle;

/// The most bytes of spare cycles a thread keeps: several of the thesis cycle's 3.1 MB (a
/// cycle larger than this is never kept).
const SPARE_BYTES: usize = 32 << 20;

thread_local! {
    static SPARE: RefCell<Vec<DriveCycle>> = const { RefCell::new(Vec::new()) };
}

impl DriveCycle {
    /// An empty cycle of one run driven forwards, with room for `n` samples: one of the
    /// thread's spare cycles ([`DriveCycle::recycle`]) with that room when it has one.
    pub fn one_run(n: usize) -> Self {
        let spare = SPARE
            .try_with(|spare| {
                let mut spare = spare.try_borrow_mut().ok()?;
                let at = spare.iter().rposition(|c| c.t_s.capacity() >= n)?;
                Some(spare.swap_remove(at))
            })
            .ok()
            .flatten();
        let Some(mut cycle) = spare else {
            return DriveCycle {
                t_s: Vec::with_capacity(n),
                x_m: Vec::with_capacity(n),
                v_m_s: Vec::with_capacity(n),
                grade_rad: Vec::with_capacity(n),
                f_prop_n: Vec::with_capacity(n),
                accel_m_s2: Vec::with_capacity(n),
                run: vec![0; n],
                run_heading: vec![1.0],
            };
        };
        // Every field named, so that a field added to the cycle is reset here too.
        let DriveCycle {
            t_s,
            x_m,
            v_m_s,
            grade_rad,
            f_prop_n,
            accel_m_s2,
            run,
            run_heading,
        } = &mut cycle;
        for column in [t_s, x_m, v_m_s, grade_rad, f_prop_n, accel_m_s2] {
            column.clear();
            column.reserve(n);
        }
        run.clear();
        run.resize(n, 0);
        run_heading.clear();
        run_heading.push(1.0);
        cycle
    }

    /// Give a cycle that is no longer needed to the thread's spares, whose memory the
    /// thread's next [`DriveCycle::one_run`] reuses (dropped instead when the spares would
    /// pass 32 MiB).
    pub fn recycle(self) {
        let bytes = |c: &DriveCycle| {
            let columns: usize = c.columns().map(Vec::capacity).sum();
            8 * columns + 4 * c.run.capacity()
        };
        let _ = SPARE.try_with(|spare| {
            if let Ok(mut spare) = spare.try_borrow_mut()
                && spare.iter().map(bytes).sum::<usize>() + bytes(&self) <= SPARE_BYTES
            {
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
}

/// How many spare cycles this thread keeps.
#[cfg(test)]
pub(crate) fn spare_cycles() -> usize {
    SPARE.with(|spare| spare.borrow().len())
}

/// Drop this thread's spare cycles.
#[cfg(test)]
pub(crate) fn clear_spares() {
    SPARE.with(|spare| spare.borrow_mut().clear());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recycled_cycle_comes_back_empty_with_one_forwards_run_where_it_has_the_room() {
        let mut used = DriveCycle::one_run(12);
        for i in 0..10 {
            for column in [
                &mut used.t_s,
                &mut used.x_m,
                &mut used.v_m_s,
                &mut used.grade_rad,
                &mut used.f_prop_n,
                &mut used.accel_m_s2,
            ] {
                column.push(i as f64);
            }
        }
        used.run.iter_mut().for_each(|r| *r = 3);
        used.run_heading = vec![-1.0, 1.0];
        let memory = used.t_s.as_ptr();
        let fresh = DriveCycle::one_run(12);
        used.recycle();
        // Too little room: a new cycle, the spare kept.
        let larger = DriveCycle::one_run(13);
        assert_ne!(larger.t_s.as_ptr(), memory);
        let again = DriveCycle::one_run(12);
        assert_eq!(again.t_s.as_ptr(), memory, "the spare's memory");
        assert_eq!(again, fresh);
        assert!(again.columns().all(|c| c.capacity() >= 12));
    }
}
