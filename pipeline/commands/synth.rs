//! `tirebase synth ...`: resolve the configuration, run the virtual machine (`synth round`) or
//! the inertia-session generator (`synth inertia`), write the files.
//!
//! In: the parsed `synth round` arguments (and the `[synth]` table of `--config`). Out: the round
//! directory (raw files, catalog, truth) and a one-screen summary on stderr. All simulation is
//! in `tirebase_core::synth` and the writing in [`crate::synth_round`]; this layer only resolves
//! configuration and prints.

use std::io::Write as _;
use std::path::Path;
use std::process::ExitCode;

use crate::cli::{SynthCommand, SynthInertiaArgs, SynthRoundArgs, SynthSize, SynthTruth};
use crate::config::Config;
use crate::synth_round::{RoundWritten, write_round, write_session};
use tirebase_core::synth::inertia::validation_sessions;
use tirebase_core::synth::tires::TruthForm;

use crate::core::synth::round::{Size, SynthConfig};

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
    let written = write_round(&cfg, &args.out, args.jobs)?;
    eprintln!("{}", summary_line(&written, &args.out));
    Ok(ExitCode::SUCCESS)
}

/// The one-line summary of a written round (printed by `synth round` and by `run` when it
/// generates the embedded round).
pub fn summary_line(w: &RoundWritten, out: &Path) -> String {
    format!(
        "synth round: {} run files ({} rows, {:.1} MB), {} tire/rim combinations, {} truth models, {} segments, {} defects, {} rig sessions -> {} in {:.1} s",
        w.run_files,
        w.rows,
        w.run_bytes as f64 / 1e6,
        w.combos,
        w.truths,
        w.segments,
        w.defects,
        w.rig_sessions,
        out.display(),
        w.elapsed.as_secs_f64()
    )
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
