//! `tirebase inertia SESSION_DIR... --out OUT`: rig sessions -> `OUT/inertia.parquet`.
//!
//! In: session directories. Out: one Parquet table (schema `schemas/inertia.toml`), rows sorted by
//! (session, run, object, axis, quantity, method) so the bytes do not depend on thread count; a
//! short summary of the headline results on stdout; one line per failed run on stderr. Exit code
//! 0 when every run succeeded, 1 when some failed (their sessions' other results are still
//! written). Deliberately no analysis here: that is `tirebase_core::inertia`.

use std::fs;
use std::process::ExitCode;

use anyhow::Context;
use tirebase_core::inertia::InertiaResult;
use tirebase_core::inertia::analysis::SessionOutcome;

use crate::cli::InertiaArgs;
use crate::inertia::process_sessions;
use crate::store::files::write_parquet_atomic;

/// Runs every session, writes the table, prints the summary.
pub fn run(args: &InertiaArgs) -> anyhow::Result<ExitCode> {
    let processed = process_sessions(&args.sessions);
    fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create output directory", args.out.display()))?;
    let path = args.out.join("inertia.parquet");
    write_parquet_atomic(&path, &mut processed.table()?)?;
    print_summary(&processed.outcomes, &processed.results);
    let errors: Vec<_> = processed.errors().collect();
    for e in &errors {
        eprintln!("error: {e}");
    }
    eprintln!(
        "inertia: {} session(s), {} run(s), {} result row(s), {} failed run(s) -> {}",
        processed.outcomes.len(),
        processed.runs(),
        processed.results.len(),
        errors.len(),
        path.display()
    );
    Ok(if errors.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// Headline rows (vehicle inertia and CG) per session on stdout.
fn print_summary(outcomes: &[SessionOutcome], rows: &[InertiaResult]) {
    const HEADLINE: [&str; 6] = [
        "inertia",
        "inertia_cg",
        "cg_height",
        "cg_offset_x",
        "friction_torque",
        "aero_drag_coefficient",
    ];
    let mut sessions: Vec<&str> = outcomes.iter().map(|o| o.session.as_str()).collect();
    sessions.sort_unstable();
    for s in sessions {
        println!("{s}");
        for r in rows
            .iter()
            .filter(|r| r.session == s && HEADLINE.contains(&r.quantity.as_str()))
        {
            println!(
                "  {:<22} {:<10} {:<6} {:<22} {:<30} {:>12.5} ± {:<10.3e} {}",
                r.run, r.object, r.axis, r.quantity, r.method, r.value, r.uncertainty, r.units
            );
        }
    }
}
