//! `tirebase synth ...`: write synthetic data sets with known answers.
//!
//! In: an output directory and a seed. Out: for `synth inertia`, one directory per validation
//! case with `session.toml`, the run CSVs and `expected.toml`; the case names on stdout.
//! Deliberately no analysis: `tirebase inertia` reads what this writes.

use std::fs;
use std::io::Write as _;
use std::process::ExitCode;

use anyhow::Context;
use tirebase_core::synth::inertia::validation_sessions;

use crate::cli::SynthInertiaArgs;

/// Writes every synthetic inertia session under `args.out`.
pub fn inertia(args: &SynthInertiaArgs) -> anyhow::Result<ExitCode> {
    for s in validation_sessions(args.seed) {
        let dir = args.out.join(&s.name);
        if dir.exists() {
            fs::remove_dir_all(&dir)
                .with_context(|| format!("{}: cannot replace", dir.display()))?;
        }
        fs::create_dir_all(&dir).with_context(|| format!("{}: cannot create", dir.display()))?;
        fs::write(dir.join("session.toml"), &s.session_toml)
            .with_context(|| format!("{}: write", dir.display()))?;
        fs::write(dir.join("expected.toml"), s.expected_toml())
            .with_context(|| format!("{}: write", dir.display()))?;
        for (rel, contents) in &s.files {
            let path = dir.join(rel);
            if let Some(parent) = path.parent() {
                fs::create_dir_all(parent)
                    .with_context(|| format!("{}: cannot create", parent.display()))?;
            }
            fs::write(&path, contents).with_context(|| format!("{}: write", path.display()))?;
        }
        // a closed stdout (e.g. `| head`) must not stop the writing
        let _ = writeln!(std::io::stdout().lock(), "{}", dir.display());
    }
    Ok(ExitCode::SUCCESS)
}
