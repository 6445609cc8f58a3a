//! The exit status of a failure, decided in one place: 2 for bad input (a study file, an
//! argument, an output directory or file that cannot be used as it is), 1 for a failure
//! while running. Each of the library's errors says which it is (`is_bad_input`); this
//! module only turns that into the code.

use crate::design::DesignError;
use crate::figures::FigureError;
use crate::fit::FitError;
use crate::run::RunError;
use anyhow::anyhow;

/// Exit status for a bad study file or bad arguments.
pub const EXIT_BAD_INPUT: u8 = 2;
/// Exit status for a failure while running.
pub const EXIT_FAILURE: u8 = 1;

/// A failure with the exit code it maps to.
pub struct Failure {
    /// What is printed after `error: `.
    pub error: anyhow::Error,
    /// The exit status.
    pub code: u8,
}

impl Failure {
    /// A failure of bad input (`bad_input`) or while running, with the library's message.
    fn new(error: anyhow::Error, bad_input: bool) -> Self {
        let code = match bad_input {
            true => EXIT_BAD_INPUT,
            false => EXIT_FAILURE,
        };
        Failure { error, code }
    }

    /// A bad argument: exit status 2 with `message`.
    pub fn bad_argument(message: String) -> Self {
        Failure::new(anyhow!(message), true)
    }

    /// A failure while running: exit status 1 with `message`.
    pub fn while_running(message: &str) -> Self {
        Failure::new(anyhow!(message.to_string()), false)
    }
}

/// `From` each library error that the commands return, by its own `is_bad_input`.
macro_rules! classified_by_is_bad_input {
    ($($error:ty),* $(,)?) => {$(
        impl From<$error> for Failure {
            fn from(e: $error) -> Self {
                let bad_input = e.is_bad_input();
                Failure::new(anyhow!(e), bad_input)
            }
        }
    )*};
}

classified_by_is_bad_input!(RunError, FigureError, DesignError, FitError);
