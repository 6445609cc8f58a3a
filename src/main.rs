//! The `chassis-mc` command line: parse flags, call the library, map errors to exit codes
//! (0 success, 1 failure while running, 2 bad study file or arguments).

mod cli;
mod progress;

use std::process::ExitCode;

fn main() -> ExitCode {
    let command = cli::parse();
    match cli::run(command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            // Every error of the library says its cause in its own message, so the chain is not
            // printed again (it would repeat the operating system's message).
            eprintln!("error: {}", failure.error);
            ExitCode::from(failure.code)
        }
    }
}
