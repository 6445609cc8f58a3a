//! The `chassis-mc` command line: flags → validated configuration → library calls, and
//! every error mapped to its exit status (0 success, 1 failure while running, 2 bad study
//! file or arguments). `anyhow` lives only here.
//!
//! It is part of the library so that the binary (`src/main.rs`) and the Python wheel's
//! `chassis-mc` command run the same code: both call [`main`] with their arguments.
//!
//! [`args`] defines the flags, one file per group of subcommands calls the library
//! ([`outputs`]: `run`, `summarize`, `figures`; [`check`]; [`design`]; [`fit`]:
//! `fit`, `simulate-log`), [`replications`] plans `run --replications-for`, and
//! [`failure`] maps every error to its exit status in one place; [`progress`] draws the bar
//! or prints the lines of a long run.

mod args;
pub mod check;
mod design;
mod failure;
mod fit;
mod outputs;
pub mod progress;
mod replications;

use clap::Parser;

use args::Cli;
use args::Command;
use failure::Failure;

/// Run the command line `args` (the first is the program's name) and return its exit
/// status: 0 for success and for `--help`, 1 for a failure while running, 2 for a bad study
/// file or bad arguments. Messages go to stdout and stderr as the binary prints them.
pub fn main<I, T>(args: I) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            // clap's own output: the help on stdout, a usage error on stderr
            let _ = e.print();
            return u8::try_from(e.exit_code()).unwrap_or(failure::EXIT_BAD_INPUT);
        }
    };
    match run(cli) {
        Ok(()) => 0,
        Err(failure) => {
            // Every error of the library says its cause in its own message, so the chain is
            // not printed again (it would repeat the operating system's message).
            eprintln!("error: {}", failure.error);
            failure.code
        }
    }
}

/// Execute a parsed command.
fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Run(args) => outputs::run(args),
        Command::Summarize(args) => outputs::summarize(args),
        Command::Figures(args) => outputs::figures(args),
        Command::Check(args) => check::check(args),
        Command::Design(args) => design::design(args),
        Command::Fit(args) => fit::fit(args),
        Command::SimulateLog(args) => fit::simulate_log(args),
    }
}
