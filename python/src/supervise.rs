//! Long calls on a worker thread while the calling thread waits with the GIL released,
//! taking it back every [`POLL`] to report progress and notices to Python callbacks and to
//! check for Ctrl-C.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::Duration;

use chassis_mc::montecarlo::Observer;
use pyo3::prelude::*;

/// How often the waiting thread takes the GIL back (progress, notices, Ctrl-C).
const POLL: Duration = Duration::from_millis(100);

/// What a call in progress tells the waiting thread.
#[derive(Default)]
pub(crate) struct Watch {
    total: AtomicU64,
    done: AtomicU64,
    notices: Mutex<Vec<String>>,
    stop: AtomicBool,
}

impl Observer for Watch {
    fn planned(&self, total: u64, done: u64) {
        self.total.store(total, Ordering::Relaxed);
        self.done.store(done, Ordering::Relaxed);
    }

    fn realisations_done(&self, count: u64) {
        self.done.fetch_add(count, Ordering::Relaxed);
    }

    fn notice(&self, message: &str) {
        self.notices
            .lock()
            .expect("notices lock")
            .push(message.to_string());
    }

    fn stop_requested(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

/// Run `work` on a worker thread while this one waits with the GIL released, calling
/// `progress(done, total)` when the count moves and `notice(message)` for each notice. On
/// Ctrl-C the run is asked to stop and, once the worker has returned, the KeyboardInterrupt
/// is raised.
pub(crate) fn supervise<T: Send>(
    py: Python<'_>,
    watch: &Watch,
    progress: Option<&Bound<'_, PyAny>>,
    notice: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    std::thread::scope(|scope| {
        let (sender, receiver) = mpsc::channel::<()>();
        let worker = scope.spawn(move || {
            let value = work();
            let _ = sender.send(());
            value
        });
        let mut receiver = Some(receiver);
        let mut interrupt: Option<PyErr> = None;
        let mut shown = (u64::MAX, u64::MAX);
        let mut failure: Option<PyErr> = None;
        loop {
            let waiting = receiver.take().expect("the receiver is back");
            let (finished, waiting) = py.detach(move || {
                let got = waiting.recv_timeout(POLL);
                (
                    !matches!(got, Err(mpsc::RecvTimeoutError::Timeout)),
                    waiting,
                )
            });
            receiver = Some(waiting);
            let notices: Vec<String> = std::mem::take(&mut *watch.notices.lock().expect("lock"));
            for message in notices {
                if let Some(notice) = notice
                    && let Err(e) = notice.call1((message,))
                {
                    failure.get_or_insert(e);
                }
            }
            let now = (
                watch.done.load(Ordering::Relaxed),
                watch.total.load(Ordering::Relaxed),
            );
            if now != shown && now.1 > 0 {
                shown = now;
                if let Some(progress) = progress
                    && let Err(e) = progress.call1(now)
                {
                    failure.get_or_insert(e);
                }
            }
            if interrupt.is_none()
                && let Err(e) = py.check_signals()
            {
                watch.stop.store(true, Ordering::Relaxed);
                interrupt = Some(e);
            }
            // A callback that raised stops the run too, and its error is raised.
            if failure.is_some() {
                watch.stop.store(true, Ordering::Relaxed);
            }
            if finished {
                break;
            }
        }
        let value = match worker.join() {
            Ok(value) => value,
            Err(panic) => std::panic::resume_unwind(panic),
        };
        match interrupt.or(failure) {
            Some(e) => Err(e),
            None => Ok(value),
        }
    })
}
