//! `tirebase tir eval | lint | convert | score`: the `.tir` file commands.
//!
//! In: paths from the command line. Out: files (`eval`: a CSV of forces and moments, `convert`:
//! a normalised or converted `.tir`), findings on stdout (`lint`), reader warnings and conversion
//! notes on stderr, and the exit
//! code (`lint`: 0 clean or warnings only, 1 lint errors; any command: 2 via `main` when a file
//! cannot be read). The model, reader, writer and lint are `tirebase_core::tire_model`; this
//! module only moves bytes and prints. Deliberately not here: any physics.

use std::fs;
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, bail};
use tirebase_core::tire_model::tir::{ReadWarning, TirFile, convert, format_f64, lint};
use tirebase_core::tire_model::{Coef, Evaluation, Mode, Pressures, SlipInput};

use crate::cli::{EvalMode, TirCommand, TirConvertArgs, TirEvalArgs, TirLintArgs, TirScoreArgs};

/// Run one `tir` subcommand.
pub fn run(cmd: TirCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        TirCommand::Eval(args) => eval(&args),
        TirCommand::Lint(args) => lint_files(&args),
        TirCommand::Convert(args) => convert(&args),
        TirCommand::Score(args) => score(&args),
    }
}

/// Read and parse a `.tir` file; the error is one line naming the file and the line.
fn read_tir(path: &Path) -> anyhow::Result<(TirFile, Vec<ReadWarning>)> {
    let bytes = fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    TirFile::parse_bytes(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// Refuse a file whose lint errors leave the model undefined (unless `force`, which prints
/// them as warnings); each finding is one stderr line naming the file.
fn refuse_undefined(path: &Path, file: &TirFile, force: bool) -> anyhow::Result<()> {
    let report = lint::lint(file);
    let fatal: Vec<_> = report
        .findings
        .iter()
        .filter(|f| f.leaves_model_undefined())
        .collect();
    if fatal.is_empty() {
        return Ok(());
    }
    for f in &fatal {
        eprintln!("{}: {f}", path.display());
    }
    if force {
        eprintln!(
            "{}: warning: --force: using a model that is undefined ({} lint errors above)",
            path.display(),
            fatal.len()
        );
        return Ok(());
    }
    bail!(
        "{}: refused: {} lint errors leave the model undefined (listed above; `tirebase tir lint` for all findings, --force to use it anyway)",
        path.display(),
        fatal.len()
    )
}

fn print_read_warnings(path: &Path, warnings: &[ReadWarning]) {
    for w in warnings {
        eprintln!("{}: warning: {w}", path.display());
    }
}

/// The input columns `tir eval` needs, in [`SlipInput`] order.
const INPUT_COLUMNS: [&str; 5] = ["Fz_N", "kappa", "alpha_rad", "gamma_rad", "Vx_mps"];
/// The optional inflation-pressure column of `tir eval`, Pa.
const PRESSURE_COLUMN: &str = "P_Pa";
/// The columns `tir eval` adds.
const OUTPUT_COLUMNS: [&str; 5] = ["Fx_N", "Fy_N", "Mx_Nm", "My_Nm", "Mz_Nm"];

fn eval(args: &TirEvalArgs) -> anyhow::Result<ExitCode> {
    let (file, warnings) = read_tir(&args.tir)?;
    print_read_warnings(&args.tir, &warnings);
    refuse_undefined(&args.tir, &file, args.force)?;
    let fnomin = file.coefs[Coef::FNOMIN];
    if fnomin.is_nan() || fnomin <= 0.0 {
        bail!(
            "{}: FNOMIN = {fnomin} N; the model needs a positive nominal load (see `tirebase tir lint`)",
            args.tir.display()
        );
    }
    let table = read_points(&args.input)?;
    let mode = eval_mode(args.mode);
    let mut results = vec![Evaluation::default(); table.points.len()];
    let model = file.model();
    let pressures = match &table.pressures {
        Some(p) if model.version.is_mf6() => Pressures::PerPoint(p),
        Some(_) => {
            eprintln!(
                "note: {} is a PAC2002 / MF 5.2 file without pressure terms; column {PRESSURE_COLUMN} is ignored",
                args.tir.display()
            );
            Pressures::Uniform(model.default_pressure_pa())
        }
        None => Pressures::Uniform(model.default_pressure_pa()),
    };
    model.eval_batch_at(&table.points, pressures, mode, &mut results);
    write_results(&args.output, &table, &results)?;
    Ok(ExitCode::SUCCESS)
}

/// The operating points of an input CSV and its raw records (echoed to the output).
struct PointTable {
    header: csv::StringRecord,
    records: Vec<csv::StringRecord>,
    points: Vec<SlipInput>,
    /// Inflation pressures, Pa, when the CSV has a `P_Pa` column.
    pressures: Option<Vec<f64>>,
}

fn read_points(path: &Path) -> anyhow::Result<PointTable> {
    let shown = path.display();
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_path(path)
        .with_context(|| format!("{shown}: cannot read"))?;
    let header = reader
        .headers()
        .with_context(|| format!("{shown}: line 1: cannot read the header"))?
        .clone();
    let mut index = [0usize; 5];
    for (slot, name) in index.iter_mut().zip(INPUT_COLUMNS) {
        *slot = header
            .iter()
            .position(|h| h.trim_start_matches('\u{feff}').trim() == name)
            .with_context(|| {
                format!(
                    "{shown}: line 1: no column {name} in the header (needs {})",
                    INPUT_COLUMNS.join(", ")
                )
            })?;
    }
    let pressure_index = header
        .iter()
        .position(|h| h.trim_start_matches('\u{feff}').trim() == PRESSURE_COLUMN);
    let mut records = Vec::new();
    let mut points = Vec::new();
    let mut pressures = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| anyhow::anyhow!("{shown}: {e}"))?;
        let line = record.position().map_or(0, csv::Position::line);
        let mut v = [0.0; 5];
        for ((x, &i), name) in v.iter_mut().zip(&index).zip(INPUT_COLUMNS) {
            let text = record.get(i).unwrap_or("").trim();
            *x = text.parse().map_err(|_| {
                anyhow::anyhow!("{shown}: line {line}: column {name}: '{text}' is not a number")
            })?;
            if !f64::is_finite(*x) {
                bail!("{shown}: line {line}: column {name}: '{text}' is not a finite number");
            }
        }
        if let Some(i) = pressure_index {
            let text = record.get(i).unwrap_or("").trim();
            let p: f64 = text.parse().map_err(|_| {
                anyhow::anyhow!(
                    "{shown}: line {line}: column {PRESSURE_COLUMN}: '{text}' is not a number"
                )
            })?;
            if !(p.is_finite() && p > 0.0) {
                bail!(
                    "{shown}: line {line}: column {PRESSURE_COLUMN}: {p} Pa is not a positive inflation pressure"
                );
            }
            pressures.push(p);
        }
        points.push(SlipInput {
            fz_n: v[0],
            kappa: v[1],
            alpha_rad: v[2],
            gamma_rad: v[3],
            vx_mps: v[4],
        });
        records.push(record);
    }
    Ok(PointTable {
        header,
        records,
        points,
        pressures: pressure_index.map(|_| pressures),
    })
}

fn write_results(
    path: &Path,
    table: &PointTable,
    results: &[Evaluation<f64>],
) -> anyhow::Result<()> {
    let shown = path.display();
    let mut writer =
        csv::Writer::from_path(path).with_context(|| format!("{shown}: cannot create"))?;
    let mut header: Vec<String> = table.header.iter().map(str::to_string).collect();
    for h in &mut header {
        if OUTPUT_COLUMNS.contains(&h.trim()) {
            eprintln!("note: input column {h} is kept as {h}_input; {h} holds the model's value");
            h.push_str("_input");
        }
    }
    header.extend(OUTPUT_COLUMNS.iter().map(|s| s.to_string()));
    writer.write_record(&header)?;
    for (record, e) in table.records.iter().zip(results) {
        let outputs = [e.fx_n, e.fy_n, e.mx_nm, e.my_nm, e.mz_nm].map(format_f64);
        writer.write_record(record.iter().chain(outputs.iter().map(String::as_str)))?;
    }
    writer
        .flush()
        .with_context(|| format!("{shown}: cannot write"))?;
    Ok(())
}

/// The range keys the lint envelope took from defaults because the file states no value for
/// them, as a note for the summary line (empty when it states them all): a finding at such an
/// end may lie far outside the data the model was fitted to.
fn defaulted_ranges(file: &TirFile) -> String {
    use Coef::*;
    let mut keys = vec![FZMIN, FZMAX, KPUMIN, KPUMAX, ALPMIN, ALPMAX, CAMMIN, CAMMAX];
    if file.version.is_mf6() {
        keys.extend([PRESMIN, PRESMAX]);
    }
    let missing: Vec<&str> = keys
        .into_iter()
        .filter(|&k| !file.present[k])
        .map(|k| k.name())
        .collect();
    match missing.is_empty() {
        true => String::new(),
        false => format!(
            "; no value in the file for {}: sampled at the defaults, which may reach beyond the \
             tested data",
            missing.join(" ")
        ),
    }
}

/// Lint every file named; an unreadable file is reported and skipped. The exit code is the
/// worst of the files': 2 unreadable, 1 lint errors, 0 clean.
fn lint_files(args: &TirLintArgs) -> anyhow::Result<ExitCode> {
    if let [only] = args.files.as_slice() {
        return Ok(exit_code(lint_file(only)?));
    }
    let mut worst = Linted::Clean;
    for path in &args.files {
        let linted = lint_file(path).unwrap_or_else(|err| {
            eprintln!("error: {}", super::error_line(&err));
            Linted::Unreadable
        });
        worst = worst.max(linted);
    }
    Ok(exit_code(worst))
}

/// The outcome of linting one file, ordered from best to worst.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Linted {
    Clean,
    Errors,
    Unreadable,
}

fn exit_code(linted: Linted) -> ExitCode {
    match linted {
        Linted::Clean => ExitCode::SUCCESS,
        Linted::Errors => ExitCode::from(1),
        Linted::Unreadable => ExitCode::from(2),
    }
}

fn lint_file(tir: &Path) -> anyhow::Result<Linted> {
    let path = tir.display();
    let (file, warnings) = read_tir(tir)?;
    for w in &warnings {
        println!("{path}: warning[read]: {w}");
    }
    let report = lint::lint(&file);
    for f in &report.findings {
        println!("{path}: {f}");
    }
    let envelope = report.envelope.map_or_else(
        || "not sampled".to_string(),
        |e| {
            let pressures: Vec<String> = e
                .pressures_pa
                .iter()
                .flatten()
                .map(|p| format!("{:.1}", p / 1e3))
                .collect();
            let pressures = if pressures.is_empty() {
                String::new()
            } else {
                format!(", pressure {} kPa", pressures.join(" / "))
            };
            format!(
                "Fz {:.0}..{:.0} N, inclination {:.2}..{:.2} deg, kappa {}..{}, alpha {:.2}..{:.2} deg{pressures}, {} points",
                e.fz_n.0,
                e.fz_n.1,
                e.gamma_rad.0.to_degrees(),
                e.gamma_rad.1.to_degrees(),
                format_f64(e.kappa.0),
                format_f64(e.kappa.1),
                e.alpha_rad.0.to_degrees(),
                e.alpha_rad.1.to_degrees(),
                report.points
            )
        },
    );
    println!(
        "{path}: {} errors, {} warnings (envelope: {envelope}){}",
        report.errors(),
        report.warnings() + warnings.len(),
        defaulted_ranges(&file)
    );
    Ok(if report.errors() > 0 {
        Linted::Errors
    } else {
        Linted::Clean
    })
}

fn convert(args: &TirConvertArgs) -> anyhow::Result<ExitCode> {
    let (file, warnings) = read_tir(&args.input)?;
    print_read_warnings(&args.input, &warnings);
    refuse_undefined(&args.input, &file, args.force)?;
    let to = args.to.unwrap_or(file.version);
    let shown = args.input.display();
    let conversion = convert::convert(&file, to, args.pressure)
        .map_err(|e| anyhow::anyhow!("{shown}: cannot convert to {}: {e}", to.label()))?;
    for note in &conversion.notes {
        eprintln!(
            "{shown}: note: {} -> {}: {note}",
            file.version.label(),
            to.label()
        );
    }
    let text = conversion
        .file
        .render()
        .map_err(|e| anyhow::anyhow!("{shown}: cannot write as {}: {e}", to.label()))?;
    fs::write(&args.output, text)
        .with_context(|| format!("{}: cannot write", args.output.display()))?;
    Ok(ExitCode::SUCCESS)
}

fn eval_mode(mode: EvalMode) -> Mode {
    match mode {
        EvalMode::Limits => Mode::Limits,
        EvalMode::Raw => Mode::Raw,
    }
}

fn score(args: &TirScoreArgs) -> anyhow::Result<ExitCode> {
    let (file, warnings) = read_tir(&args.tir)?;
    print_read_warnings(&args.tir, &warnings);
    let selection = crate::score::Selection {
        tire: args.tire.clone(),
        rim_in: args.rim_in,
        pressure_kpa_nom: args.pressure_kpa,
        max_abs_alpha_deg: args.max_alpha_deg,
        min_fz_n: args.min_fz_n,
        min_speed_kph: args.min_speed_kph,
        every: args.every,
    };
    let rows = crate::score::score(&args.store, &file, &selection, eval_mode(args.mode))?;
    if rows.is_empty() {
        bail!(
            "{}: no sample matches the selection (tire, rim, pressure, |alpha|, Fz, V)",
            args.store.display()
        );
    }
    let mut out = csv::Writer::from_writer(std::io::stdout().lock());
    out.write_record([
        "tire",
        "rim_in",
        "source_file",
        "pressure_kpa_nom",
        "n_samples",
        "fx_rmse_n",
        "fy_rmse_n",
        "mz_rmse_nm",
        "fx_rms_n",
        "fy_rms_n",
        "mz_rms_nm",
    ])?;
    for r in rows {
        // empty: a channel the model does not carry, or no finite sample
        let f = |v: f64| match v.is_finite() {
            true => format!("{v:.3}"),
            false => String::new(),
        };
        out.write_record([
            r.tire,
            r.rim_in.to_string(),
            r.source_file,
            r.pressure_kpa_nom
                .map_or_else(String::new, |p| p.to_string()),
            r.n_samples.to_string(),
            f(r.fx_rmse_n),
            f(r.fy_rmse_n),
            f(r.mz_rmse_nm),
            f(r.fx_rms_n),
            f(r.fy_rms_n),
            f(r.mz_rms_nm),
        ])?;
    }
    out.flush()?;
    Ok(ExitCode::SUCCESS)
}
