//! `tirebase compare --store DIR [--store DIR ...] [--version N] [--tire PATTERN ...] [--car
//! FILE] [--format table|csv] [--rank lateral|longitudinal|envelope]`: the tire-selection table
//! (`crate::compare`) on stdout; the car, the error source and what was left out on stderr.
//!
//! In: the parsed arguments. Out: the table and an exit code (0 rows printed, 2 nothing to
//! compare). Deliberately not here: any figure or ranking logic.

use std::io::Write;
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, bail};
use tirebase_core::compare::Objective;

use crate::cli::{CompareArgs, OutputFormat, RankBy};
use crate::commands::diff::resolve;
use crate::compare::car::Car;
use crate::compare::table::{format_text, to_frame};
use crate::compare::{TireFilter, compare, round};
use crate::query::write_csv;

/// Compare the tires of one or more rounds.
pub fn run(args: &CompareArgs) -> anyhow::Result<ExitCode> {
    if args.version.is_some() && args.store.len() > 1 {
        bail!("--version applies to one --store; with several stores each one's latest is read");
    }
    let car = Car::load(args.car.as_deref())?;
    let labels = round_labels(&args.store);
    let mut rounds = Vec::with_capacity(args.store.len());
    for (store, label) in args.store.iter().zip(&labels) {
        let dir = resolve(store, args.version.as_deref().unwrap_or("latest"))?;
        rounds.push(round::load(&dir, label));
    }
    let objective = match args.rank {
        RankBy::Lateral => Objective::Lateral,
        RankBy::Longitudinal => Objective::Longitudinal,
        RankBy::Envelope => Objective::Envelope,
    };
    let comparison = compare(&rounds, &car, objective, &TireFilter::new(&args.tire));
    eprintln!("car: {}", car.describe());
    for note in &comparison.notes {
        eprintln!("note: {note}");
    }
    if comparison.rows.is_empty() {
        eprintln!("nothing to compare: no fitted tire, rim and pressure matches");
        return Ok(ExitCode::from(2));
    }
    let sources: std::collections::BTreeSet<&str> = comparison
        .rows
        .iter()
        .map(|r| r.error_source.as_str())
        .collect();
    let sources: Vec<&str> = sources.into_iter().collect();
    eprintln!(
        "ranked by {} (higher is better); ties: differences within the uncertainty from {}",
        crate::compare::objective_column(objective),
        sources.join("; ")
    );
    if sources.iter().any(|s| s.contains("in-sample")) {
        eprintln!(
            "note: fit_quality has no out-of-sample error yet: the in-sample RMSE (which includes \
             measurement noise) stands in for it, so ties are judged conservatively"
        );
    }
    if let Some(s) = comparison.cross_round_spread {
        eprintln!("cross-round pairs add the largest round-to-round spread, {s:.4}");
    }
    let mut df = to_frame(&comparison).context("building the compare table")?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match args.format {
        OutputFormat::Csv => write_csv(&mut df, &mut out).context("writing CSV")?,
        // a closed stdout (e.g. `| head`) is not an error
        OutputFormat::Table => {
            let _ = out.write_all(format_text(&df).as_bytes());
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Each store's directory name, or the path as given when two stores share a name.
fn round_labels(stores: &[std::path::PathBuf]) -> Vec<String> {
    let name = |p: &Path| {
        p.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| p.display().to_string())
    };
    let names: Vec<String> = stores.iter().map(|p| name(p)).collect();
    stores
        .iter()
        .zip(&names)
        .map(|(p, n)| {
            if names.iter().filter(|m| *m == n).count() > 1 {
                p.display().to_string()
            } else {
                n.clone()
            }
        })
        .collect()
}
