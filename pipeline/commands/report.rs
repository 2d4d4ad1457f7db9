//! `tirebase report`: regenerate the HTML report of a result directory from a store.
//!
//! In: `--store`, `--results`, `--out`, `--car`. Out: the pages in OUT (see [`crate::report`]), a
//! one-line summary on stderr and the index path on stdout. Deliberately not here: fitting or
//! publishing (the report of a published version is written by `run`).

use std::io::Write;
use std::process::ExitCode;

use crate::cli::ReportArgs;
use crate::compare::car::Car;
use crate::report;

/// Write the report and print where it is.
pub fn run(args: &ReportArgs) -> anyhow::Result<ExitCode> {
    let car = Car::load(args.car.as_deref())?;
    let summary = report::write_report(&args.store, &args.results, &args.out, &car)?;
    eprintln!(
        "report: {} tire pages, {} charts drawn, {} without data, {:.0} KiB -> {}",
        summary.tires,
        summary.plots,
        summary.plots_without_data,
        summary.bytes as f64 / 1024.0,
        args.out.display()
    );
    for note in &summary.notes {
        eprintln!("report: note: {note}");
    }
    let mut out = std::io::stdout().lock();
    if let Some(index) = summary.pages.first() {
        writeln!(out, "{}", index.display())?;
    }
    Ok(ExitCode::SUCCESS)
}
