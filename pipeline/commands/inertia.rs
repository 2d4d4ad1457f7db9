//! `tirebase inertia SESSION_DIR... --out OUT`: rig sessions -> `OUT/inertia.parquet`.
//!
//! In: session directories. Out: one Parquet table (schema `schemas/inertia.toml`), rows sorted by
//! (session, run, object, axis, quantity, method) so the bytes do not depend on thread count; a
//! short summary of the headline results on stdout; one line per failed run on stderr. Exit code
//! 0 when every run succeeded, 1 when some failed (their sessions' other results are still
//! written). Deliberately no analysis here: that is `tirebase_core::inertia`.

use std::fs;
use std::path::Path;
use std::process::ExitCode;

use anyhow::Context;
use polars::prelude::*;
use rayon::prelude::*;
use tirebase_core::inertia::analysis::{SessionOutcome, analyze_session};
use tirebase_core::inertia::session::{load_dir_reader, load_session};
use tirebase_core::inertia::{InertiaResult, RunError};

use crate::cli::InertiaArgs;
use crate::schema;
use crate::store::files::write_parquet_atomic;

/// Runs every session, writes the table, prints the summary.
pub fn run(args: &InertiaArgs) -> anyhow::Result<ExitCode> {
    let mut outcomes: Vec<SessionOutcome> = args
        .sessions
        .par_iter()
        .map(|dir| process_dir(dir))
        .collect();
    reject_duplicate_ids(&mut outcomes, &args.sessions);
    let mut results: Vec<InertiaResult> = outcomes
        .iter()
        .flat_map(|o| o.results.iter().cloned())
        .collect();
    results.sort_by(|a, b| {
        (
            &a.session,
            &a.run,
            &a.object,
            &a.axis,
            &a.quantity,
            &a.method,
        )
            .cmp(&(
                &b.session,
                &b.run,
                &b.object,
                &b.axis,
                &b.quantity,
                &b.method,
            ))
    });
    let errors: Vec<&RunError> = outcomes.iter().flat_map(|o| o.errors.iter()).collect();
    fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create output directory", args.out.display()))?;
    let path = args.out.join("inertia.parquet");
    write_table(&results, &path)?;
    print_summary(&outcomes, &results);
    for e in &errors {
        eprintln!("error: {e}");
    }
    eprintln!(
        "inertia: {} session(s), {} run(s), {} result row(s), {} failed run(s) -> {}",
        outcomes.len(),
        outcomes.iter().map(|o| o.runs).sum::<usize>(),
        results.len(),
        errors.len(),
        path.display()
    );
    Ok(if errors.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// A session id given by two directories would mix their rows: keep the first, fail the others.
fn reject_duplicate_ids(outcomes: &mut [SessionOutcome], dirs: &[std::path::PathBuf]) {
    for k in 1..outcomes.len() {
        if let Some(first) = (0..k).find(|&j| {
            outcomes[j].session == outcomes[k].session && !outcomes[j].results.is_empty()
        }) {
            let o = &mut outcomes[k];
            o.results.clear();
            o.errors = vec![RunError {
                session: o.session.clone(),
                run: "session.toml".into(),
                message: format!(
                    "{}: session id already used by {}",
                    dirs[k].display(),
                    dirs[first].display()
                ),
            }];
        }
    }
}

fn process_dir(dir: &Path) -> SessionOutcome {
    let label = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| dir.display().to_string());
    match load_session(dir) {
        Ok(session) => analyze_session(&session, &load_dir_reader(dir)),
        Err(e) => SessionOutcome {
            session: label.clone(),
            results: Vec::new(),
            errors: vec![RunError {
                session: label,
                run: "session.toml".into(),
                message: e.to_string(),
            }],
            runs: 0,
        },
    }
}

/// Builds the frame in schema order and writes it atomically (temp file, then rename).
fn write_table(rows: &[InertiaResult], path: &Path) -> anyhow::Result<()> {
    let text = |f: fn(&InertiaResult) -> &str| {
        rows.iter()
            .map(|r| f(r).to_owned())
            .collect::<Vec<String>>()
    };
    let df = df!(
        "session" => text(|r| &r.session),
        "run" => text(|r| &r.run),
        "object" => text(|r| &r.object),
        "axis" => text(|r| &r.axis),
        "quantity" => text(|r| &r.quantity),
        "method" => text(|r| &r.method),
        "value" => rows.iter().map(|r| r.value).collect::<Vec<f64>>(),
        "uncertainty" => rows.iter().map(|r| r.uncertainty).collect::<Vec<f64>>(),
        "units" => text(|r| &r.units),
        "diagnostics" => text(|r| &r.diagnostics),
    )
    .map_err(|e| anyhow::anyhow!("building the inertia table: {e}"))?;
    let mut df = schema::table("inertia").conform(df)?;
    write_parquet_atomic(path, &mut df)?;
    Ok(())
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
