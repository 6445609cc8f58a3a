//! What estimators derive from a regression's noise-free rows and share between its
//! realisations, kept with the regression: one value per type, made on first use.

use std::any::{Any, TypeId};
use std::fmt;
use std::sync::{Arc, Mutex};

/// Values derived from a regression, one per type (see
/// [`Regression::derived`](super::Regression::derived)).
#[derive(Default)]
pub(super) struct Derived(Mutex<Vec<(TypeId, Arc<dyn Any + Send + Sync>)>>);

impl Derived {
    /// The value of type `T`, made by `make` if there is none yet. Two threads that ask
    /// at once may both make one; the first kept is the one every caller gets (the values
    /// are equal: `make` is a function of the rows).
    pub(super) fn get_or_make<T: Any + Send + Sync>(&self, make: impl FnOnce() -> T) -> Arc<T> {
        if let Some(value) = self.find::<T>() {
            return value;
        }
        let made: Arc<dyn Any + Send + Sync> = Arc::new(make());
        let mut values = self
            .0
            .lock()
            .expect("no panic while holding the derived values");
        let kept = match values.iter().find(|(id, _)| *id == TypeId::of::<T>()) {
            Some((_, value)) => Arc::clone(value),
            None => {
                values.push((TypeId::of::<T>(), Arc::clone(&made)));
                made
            }
        };
        kept.downcast().expect("a value is kept under its own type")
    }

    fn find<T: Any + Send + Sync>(&self) -> Option<Arc<T>> {
        let values = self
            .0
            .lock()
            .expect("no panic while holding the derived values");
        let (_, value) = values.iter().find(|(id, _)| *id == TypeId::of::<T>())?;
        Some(
            Arc::clone(value)
                .downcast()
                .expect("a value is kept under its own type"),
        )
    }
}

impl Clone for Derived {
    /// The clone shares the values made so far.
    fn clone(&self) -> Self {
        let values = self
            .0
            .lock()
            .expect("no panic while holding the derived values");
        Derived(Mutex::new(values.clone()))
    }
}

impl fmt::Debug for Derived {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let values = self
            .0
            .lock()
            .expect("no panic while holding the derived values");
        write!(f, "Derived({} values)", values.len())
    }
}
