//! Flags → validated configuration → library calls. `anyhow` lives only here.
//!
//! [`args`] defines the flags, one file per group of subcommands calls the library
//! ([`outputs`]: `run`, `summarize`, `figures`; [`check`]; [`design`]; [`fit`]:
//! `fit`, `simulate-log`), [`replications`] plans `run --replications-for`, and
//! [`failure`] maps every error to its exit status in one place.

mod args;
mod check;
mod design;
mod failure;
mod fit;
mod outputs;
mod replications;

use clap::Parser;

pub use args::Cli;
use args::Command;
pub use failure::Failure;

/// Parse the command line (exits with status 2 on bad arguments, 0 for --help).
pub fn parse() -> Cli {
    Cli::parse()
}

/// Execute a parsed command.
pub fn run(cli: Cli) -> Result<(), Failure> {
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
