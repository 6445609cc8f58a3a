//! A regression's column: shared storage read as a slice, and the spare storage a thread
//! keeps of the regressions it dropped, so that a realisation with its own regression (a
//! model error drawn per realisation) fills columns it already holds instead of asking the
//! allocator for pages again (docs/model.md#model-errors).

use std::cell::RefCell;
use std::fmt;
use std::ops::Deref;
use std::sync::Arc;

/// A column of a regression: the first `len` values of storage shared with the regression
/// of a longer duration of the same cycle, whose rows begin with these
/// ([`Regression::prefix`](super::Regression::prefix); docs/model.md#row-selection). Reads as a slice.
#[derive(Clone, PartialEq)]
pub struct Column<T = f64> {
    values: Arc<[T]>,
    len: usize,
}

impl<T> Column<T> {
    /// The first `n` values, sharing the storage.
    pub fn prefix(&self, n: usize) -> Column<T> {
        assert!(n <= self.len, "a prefix of {n} of {} values", self.len);
        Column {
            values: self.values.clone(),
            len: n,
        }
    }
}

impl<T> From<Vec<T>> for Column<T> {
    fn from(values: Vec<T>) -> Self {
        let len = values.len();
        Column {
            values: values.into(),
            len,
        }
    }
}

impl<T: Clone> From<&[T]> for Column<T> {
    /// A copy of `values` (one allocation: a `Vec` made into a column is copied once more).
    fn from(values: &[T]) -> Self {
        Column {
            values: values.into(),
            len: values.len(),
        }
    }
}

impl<T> Deref for Column<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.values[..self.len]
    }
}

impl<T: fmt::Debug> fmt::Debug for Column<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        (**self).fmt(f)
    }
}

/// Spare columns a thread keeps at most: two realisations' regressions.
const SPARE_COLUMNS: usize = 24;

thread_local! {
    /// Storage of the thread's dropped regressions' columns that nothing else held, newest
    /// last.
    static SPARE: RefCell<Vec<Arc<[f64]>>> = const { RefCell::new(Vec::new()) };
}

impl Column<f64> {
    /// A column of `n` values written by `fill`, in spare storage of the thread when it
    /// holds some of that length (no allocation), else in new storage.
    pub fn filled(n: usize, fill: impl FnOnce(&mut [f64])) -> Column {
        let spare = SPARE
            .try_with(|spare| {
                let mut spare = spare.try_borrow_mut().ok()?;
                let at = spare.iter().rposition(|v| v.len() == n)?;
                Some(spare.swap_remove(at))
            })
            .ok()
            .flatten();
        // New storage in one allocation (a `Vec` made into an `Arc` would be copied).
        let mut values = spare.unwrap_or_else(|| std::iter::repeat_n(0.0, n).collect());
        fill(Arc::get_mut(&mut values).expect("spare storage is held by nothing else"));
        Column { values, len: n }
    }

    /// K columns of `n` values each, written together by `fill` ([`Column::filled`]).
    pub fn filled_together<const K: usize>(
        n: usize,
        fill: impl FnOnce([&mut [f64]; K]),
    ) -> [Column; K] {
        let mut columns: [Column; K] = std::array::from_fn(|_| Column::filled(n, |_| {}));
        let slices = columns
            .each_mut()
            .map(|c| Arc::get_mut(&mut c.values).expect("new storage is held by nothing else"));
        fill(slices);
        columns
    }

    /// The values of `values`, in spare storage when the thread has some ([`Column::filled`]).
    pub fn collected(values: impl ExactSizeIterator<Item = f64>) -> Column {
        Column::filled(values.len(), |out| {
            out.iter_mut().zip(values).for_each(|(o, v)| *o = v)
        })
    }

    /// Keep this column's storage as the thread's spare when nothing else holds it.
    pub(super) fn recycle(&self) {
        if Arc::strong_count(&self.values) != 1 || Arc::weak_count(&self.values) != 0 {
            return;
        }
        let _ = SPARE.try_with(|spare| {
            if let Ok(mut spare) = spare.try_borrow_mut() {
                if spare.len() == SPARE_COLUMNS {
                    spare.remove(0);
                }
                spare.push(Arc::clone(&self.values));
            }
        });
    }
}
