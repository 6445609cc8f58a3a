//! The commands on measured logs: `fit` estimates from a log, `simulate-log` writes a
//! synthetic one.

use crate::fit::{FitError, FitSpec};

use super::args::{FitArgs, SimulateLogArgs, output_directory, output_file};
use super::failure::Failure;

/// `fit`: estimate θ from the fit file's log, print the table and the files written.
pub fn fit(args: FitArgs) -> Result<(), Failure> {
    let FitArgs { fit, out } = args;
    output_directory("--out", &out)?;
    let spec = FitSpec::load(&fit).map_err(FitError::from)?;
    let result = crate::fit::fit(&spec, &out)?;
    print!("{}", crate::fit::table(&result.rows));
    print!("{}", crate::fit::budget_table(&result.systematic));
    println!("wrote:");
    for f in &result.files {
        println!("  {}", f.display());
    }
    Ok(())
}

/// `simulate-log`: one realisation of a one-condition study as a CSV log.
pub fn simulate_log(args: SimulateLogArgs) -> Result<(), Failure> {
    let SimulateLogArgs {
        study,
        out,
        realisation,
        force,
        overrides,
    } = args;
    output_file("--out", &out)?;
    let study = overrides.load(&study)?;
    let n = crate::fit::simulate_log(&study, realisation, &out, force)?;
    println!("wrote {} ({n} samples)", out.display());
    Ok(())
}
