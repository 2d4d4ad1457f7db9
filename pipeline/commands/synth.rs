//! `tirebase synth ...`: resolve the configuration, run the virtual machine (`synth round`) or
//! the inertia-session generator (`synth inertia`), write the files.
//!
//! In: the parsed `synth round` arguments (and the `[synth]` table of `--config`). Out: the round
//! directory (raw files, catalog, truth) and a one-screen summary on stderr. All simulation is
//! in `tirebase_core::synth`; this layer only resolves configuration, parallelises over run files
//! (rayon; every run has its own random stream, so the bytes do not depend on the thread count)
//! and writes each file atomically (temporary name, then rename).

use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use rayon::prelude::*;

use crate::cli::{SynthCommand, SynthInertiaArgs, SynthRoundArgs, SynthSize, SynthTruth};
use crate::config::Config;
use tirebase_core::synth::inertia::{SyntheticSession, demo_car_sessions, validation_sessions};
use tirebase_core::synth::tires::TruthForm;

use crate::core::synth::round::{
    OutFile, RunSummary, Size, SynthConfig, plan_round, render_run, render_truth,
};

/// Run one `synth` subcommand.
pub fn run(cmd: &SynthCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        SynthCommand::Round(args) => round(args),
        SynthCommand::Inertia(args) => inertia(args),
    }
}

/// Defaults < `[synth]` of `--config` < flags.
pub fn resolve_config(args: &SynthRoundArgs) -> anyhow::Result<SynthConfig> {
    let mut cfg = Config::load(args.config.as_deref())?.synth;
    if let Some(seed) = args.seed {
        cfg.seed = seed;
    }
    if let Some(size) = args.size {
        cfg.size = match size {
            SynthSize::Demo => Size::Demo,
            SynthSize::Full => Size::Full,
        };
    }
    if args.defects {
        cfg.defects = true;
    }
    if let Some(truth) = args.truth {
        cfg.truth = match truth {
            SynthTruth::Pac2002 => TruthForm::Pac2002,
            SynthTruth::Mf61 => TruthForm::Mf61,
        };
    }
    if args.ideal || args.no_noise {
        cfg.realism.noise_scale = 0.0;
    }
    if args.ideal || args.no_lag {
        cfg.realism.lag = false;
    }
    if args.ideal || args.no_heat {
        cfg.realism.heat = false;
    }
    Ok(cfg)
}

fn round(args: &SynthRoundArgs) -> anyhow::Result<ExitCode> {
    let cfg = resolve_config(args)?;
    let summary = write_round(&cfg, &args.out, args.jobs)?;
    eprintln!("{summary}");
    Ok(ExitCode::SUCCESS)
}

/// Generate a whole virtual round into `out` (raw/, truth/ and catalog.toml are replaced; the
/// demo car's rig sessions are written into inertia/, replacing only their own directories)
/// with `jobs` worker threads (None = one per core); returns the one-line summary.
pub fn write_round(cfg: &SynthConfig, out: &Path, jobs: Option<usize>) -> anyhow::Result<String> {
    let started = Instant::now();
    let plan = plan_round(cfg)?;
    for owned in ["raw", "truth"] {
        let dir = out.join(owned);
        if dir.exists() {
            std::fs::remove_dir_all(&dir)
                .with_context(|| format!("{}: cannot replace", dir.display()))?;
        }
    }
    std::fs::create_dir_all(out.join("raw"))
        .with_context(|| format!("{}: cannot create", out.join("raw").display()))?;
    std::fs::create_dir_all(out.join("truth/tir"))
        .with_context(|| format!("{}: cannot create", out.join("truth/tir").display()))?;

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let results: Vec<anyhow::Result<(RunSummary, usize)>> = pool.install(|| {
        (0..plan.runs.len())
            .into_par_iter()
            .map(|i| {
                let output = render_run(&plan, i)?;
                let bytes = output.file.bytes.len();
                write_atomic(out, &output.file)?;
                Ok((output.summary, bytes))
            })
            .collect()
    });
    let mut summaries = Vec::with_capacity(results.len());
    let mut total_bytes = 0usize;
    for r in results {
        let (s, b) = r?;
        total_bytes += b;
        summaries.push(s);
    }
    summaries.sort_by_key(|s| s.spec.run);
    for file in render_truth(&plan, &summaries)? {
        write_atomic(out, &file)?;
    }
    let sessions = demo_car_sessions(cfg.seed);
    for s in &sessions {
        write_session(&out.join(crate::run::INERTIA_DIR), s)?;
    }
    let rows: usize = summaries.iter().map(|s| s.rows).sum();
    let segments: usize = summaries.iter().map(|s| s.segments.len()).sum();
    let defects: usize = summaries.iter().map(|s| s.defects.len()).sum();
    Ok(format!(
        "synth round: {} run files ({} rows, {:.1} MB), {} tire/rim combinations, {} truth models, {} segments, {} defects, {} rig sessions -> {} in {:.1} s",
        summaries.len(),
        rows,
        total_bytes as f64 / 1e6,
        plan.combos.len(),
        plan.truths.len(),
        segments,
        defects,
        sessions.len(),
        out.display(),
        started.elapsed().as_secs_f64()
    ))
}

/// Write `file` under `root` via a temporary name and a rename.
fn write_atomic(root: &Path, file: &OutFile) -> anyhow::Result<()> {
    let path: PathBuf = root.join(&file.path);
    let tmp = path.with_extension("tmp-synth");
    std::fs::write(&tmp, &file.bytes)
        .with_context(|| format!("{}: cannot write", tmp.display()))?;
    std::fs::rename(&tmp, &path).with_context(|| format!("{}: cannot rename", path.display()))?;
    Ok(())
}

/// Write session `s` into `root/<name>/` (that directory is replaced): session.toml,
/// expected.toml and its run files; returns the directory.
fn write_session(root: &Path, s: &SyntheticSession) -> anyhow::Result<PathBuf> {
    let dir = root.join(&s.name);
    if dir.exists() {
        fs::remove_dir_all(&dir).with_context(|| format!("{}: cannot replace", dir.display()))?;
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
    Ok(dir)
}

/// Writes every synthetic inertia session under `args.out`.
pub fn inertia(args: &SynthInertiaArgs) -> anyhow::Result<ExitCode> {
    for s in validation_sessions(args.seed) {
        let dir = write_session(&args.out, &s)?;
        // a closed stdout (e.g. `| head`) must not stop the writing
        let _ = writeln!(std::io::stdout().lock(), "{}", dir.display());
    }
    Ok(ExitCode::SUCCESS)
}
