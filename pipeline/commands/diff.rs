//! `tirebase diff --store DIR A B [--tire T] [--format table|csv]`: the differences between two
//! versions (`crate::diff`) on stdout, as an aligned table or CSV.
//!
//! Exit code 0 whether or not the versions differ; 2 when a version does not exist.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};

use crate::cli::{DiffArgs, OutputFormat};
use crate::diff::{diff_versions, to_frame};
use crate::query::{format_table, write_csv};
use crate::store::layout::parse_version_dir;
use crate::store::versions;

/// Compare two versions.
pub fn run(args: &DiffArgs) -> anyhow::Result<ExitCode> {
    let a = resolve(&args.store, &args.a)?;
    let b = resolve(&args.store, &args.b)?;
    let rows = diff_versions(&a, &b, args.tire.as_deref())?;
    let mut df = to_frame(&rows).context("building the diff table")?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match args.format {
        OutputFormat::Csv => write_csv(&mut df, &mut out).context("writing CSV")?,
        OutputFormat::Table => {
            if rows.is_empty() {
                eprintln!("no differences between {} and {}", args.a, args.b);
            } else {
                // a closed stdout (e.g. `| head`) is not an error
                let _ = out.write_all(format_table(&df).as_bytes());
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// A version argument (`3`, `v000003`, `latest`) -> its directory.
pub(crate) fn resolve(store: &Path, arg: &str) -> anyhow::Result<PathBuf> {
    let all = versions::list(store)?;
    let wanted = if arg == "latest" {
        all.last().map(|(n, _)| *n)
    } else {
        arg.parse::<u32>()
            .ok()
            .or_else(|| parse_version_dir(arg))
            .or_else(|| arg.strip_prefix('v').and_then(|d| d.parse().ok()))
    };
    let Some(n) = wanted else {
        bail!("{arg}: not a version (give a number, vNNNNNN or latest)");
    };
    match all.into_iter().find(|(k, _)| *k == n) {
        Some((_, dir)) => Ok(dir),
        None => bail!("{}: no version {n}", store.display()),
    }
}
