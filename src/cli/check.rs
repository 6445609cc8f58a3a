//! `check`: a study's conditions, the estimated run time and output size, without running.

use crate::check::StudyCheck;
use crate::study::Study;

use super::args::CheckArgs;
use super::failure::Failure;
use super::progress::human_duration;

/// `check`: validate the study, time a few realisations and print what a run would do.
pub fn check(args: CheckArgs) -> Result<(), Failure> {
    let study = args.overrides.load(&args.study)?;
    let found = crate::check::check(&study, args.overrides.threads())?;
    print!("{}", check_report(&study, &found));
    Ok(())
}

/// What `check` prints.
pub fn check_report(study: &Study, c: &StudyCheck) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: study \"{}\", seed {}",
        study.origin(),
        study.name(),
        study.seed()
    );
    let mut header = format!("{:>4}", "cond");
    for axis in &c.layout.axes {
        let _ = write!(header, " {:>12}", axis.name);
    }
    let _ = write!(header, " {:>14}", "ms/realisation");
    let _ = writeln!(out, "{header}");
    for (i, (info, t)) in c.infos.iter().zip(&c.per_realisation).enumerate() {
        let mut line = format!("{i:>4}");
        for v in &info.axes {
            let _ = write!(line, " {:>12}", v.to_string());
        }
        let _ = writeln!(line, " {:>14.3}", t.as_secs_f64() * 1e3);
        out.push_str(&line);
    }
    let total = c.realisations * c.infos.len() as u64;
    let _ = writeln!(
        out,
        "{} conditions × {} realisations = {total} realisations",
        c.infos.len(),
        c.realisations
    );
    let _ = writeln!(
        out,
        "estimated run time on {} threads ({} cores): about {} (preparing the model {:.2} s, summary, \
         figures and report {:.2} s; a lower bound when the cores are shared)",
        c.threads,
        c.cores,
        human_duration(c.estimated_run_time()),
        c.prepare.as_secs_f64(),
        c.outputs.as_secs_f64()
    );
    let _ = writeln!(
        out,
        "estimated output: about {} in all",
        human_bytes(c.total_bytes())
    );
    // The figures on one line, every other file on its own.
    let (figures, files): (Vec<_>, Vec<_>) = c
        .files
        .iter()
        .partition(|f| f.name.starts_with(&format!("{}/", crate::figures::FIGURES)));
    for f in files {
        let _ = writeln!(out, "  {:<28} {:>10}", f.name, human_bytes(f.bytes));
    }
    if !figures.is_empty() {
        let name = format!("{}/ ({} SVG files)", crate::figures::FIGURES, figures.len());
        let bytes = figures.iter().map(|f| f.bytes).sum();
        let _ = writeln!(out, "  {name:<28} {:>10}", human_bytes(bytes));
    }
    out
}

/// Bytes for people: `3.4 MB`, `1.2 GB`.
fn human_bytes(b: f64) -> String {
    match b {
        b if b >= 1e12 => format!("{:.1} TB", b / 1e12),
        b if b >= 1e9 => format!("{:.1} GB", b / 1e9),
        b if b >= 1e6 => format!("{:.1} MB", b / 1e6),
        b if b >= 1e3 => format!("{:.0} kB", b / 1e3),
        b => format!("{b:.0} B"),
    }
}
