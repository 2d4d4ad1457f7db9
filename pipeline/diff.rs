//! Differences between two published versions, per tire, rim and nominal pressure.
//!
//! In: two version directories (their manifests, `.tir` files and result tables). Out: one
//! [`DiffRow`] per difference, sorted: models added or removed, fit-quality changes (the
//! out-of-sample RMSE and the deviation between fitted points first, in `fit_quality`'s column
//! order), PAC2002 coefficients that changed (read from the `.tir` files, so every published
//! coefficient counts), the change in the forces a user feels (max and RMS of |dFx|, |dFy|,
//! |dMz| between the two models over the tested envelope) and stage-result changes (spring
//! rate, thermal fit, relaxation, inertia). Two identical versions give no rows. MF 6.1 models
//! (one per tire and rim, keyed at their `NOMPRES`) are compared the same way, their forces at
//! every tested pressure of the tire and rim (either version's) and at the midpoint between each
//! two neighbouring ones (`at_pressure_kpa`).
//!
//! Deliberately not here: printing (the command layer) and any tolerance a user should tune:
//! values are "changed" when they differ by more than 1e-12 relative (the round-trip precision
//! of the files), forces when they differ by more than 1e-9 N or N m.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use polars::prelude::*;
use tirebase_core::naming::{mf61_tir_file_name, tir_file_name};
use tirebase_core::tire_model::tir::TirFile;
use tirebase_core::tire_model::{Coef, Evaluation, Mode, Pac2002, Pressures, SlipInput};

use crate::manifest::{Manifest, ManifestError};
use crate::schema::TableName;
use crate::store::results;
use crate::store::{IoOp, StoreError};

/// Relative difference below which two values are the same.
const SAME_REL: f64 = 1e-12;
/// Force or moment difference (N, N m) below which two models are the same.
const SAME_FORCE: f64 = 1e-9;

/// Result tables compared generically: (table, row kind).
const TABLES: [(TableName, &str); 5] = [
    (TableName::FitQuality, "quality"),
    (TableName::SpringRate, "stage"),
    (TableName::ThermalFit, "stage"),
    (TableName::Relaxation, "stage"),
    (TableName::Inertia, "inertia"),
];

/// Diff errors.
#[derive(Debug, thiserror::Error)]
pub enum DiffError {
    /// A manifest could not be read.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// A table could not be read.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// A `.tir` file could not be read.
    #[error("{path}: {message}")]
    Tir {
        /// The file.
        path: String,
        /// Why.
        message: String,
    },
    /// A table has an unexpected shape.
    #[error("{table}: {source}")]
    Table {
        /// Table name.
        table: String,
        /// polars' error.
        source: PolarsError,
    },
}

/// One difference.
#[derive(Clone, Debug, PartialEq)]
pub struct DiffRow {
    /// Tire ("" for rows not tied to a tire, e.g. inertia).
    pub tire: String,
    /// Rim width, in.
    pub rim_in: Option<i64>,
    /// Nominal pressure, kPa (an MF 6.1 model's: its `NOMPRES`).
    pub pressure_kpa: Option<i64>,
    /// `pac2002` or `mf61` for model, coefficient and force rows.
    pub model: Option<&'static str>,
    /// `model`, `coefficient`, `force`, `quality`, `stage` or `inertia`.
    pub kind: &'static str,
    /// MF 6.1 force rows: the inflation pressure the two models were compared at, kPa.
    pub at_pressure_kpa: Option<f64>,
    /// What differs (coefficient name, `Fy_N`, `table.column (key)`, `added`/`removed`).
    pub item: String,
    /// Value in A.
    pub old: Option<f64>,
    /// Value in B.
    pub new: Option<f64>,
    /// (new - old) / |old|.
    pub rel_change: Option<f64>,
    /// Force rows: max |delta| over the envelope (N or N m).
    pub max_abs: Option<f64>,
    /// Force rows: RMS of the delta over the envelope (N or N m).
    pub rms: Option<f64>,
}

type GroupKey = (String, i64, i64);

/// Every difference between version directories `a` and `b`, optionally for one tire.
pub fn diff_versions(a: &Path, b: &Path, tire: Option<&str>) -> Result<Vec<DiffRow>, DiffError> {
    let (ma, mb) = (Manifest::read(a)?, Manifest::read(b)?);
    let mut groups: BTreeSet<GroupKey> = BTreeSet::new();
    for g in ma.groups.iter().chain(&mb.groups) {
        groups.insert((g.tire.clone(), g.rim_in, g.pressure_kpa));
    }
    let mut rows = Vec::new();
    for key in groups
        .iter()
        .filter(|k| tire.is_none_or(|t| t == k.0.as_str()))
    {
        model_rows(a, b, key, &mut rows)?;
    }
    mf61_rows(a, b, (&ma, &mb), tire, &mut rows)?;
    for (table, kind) in TABLES {
        table_rows(a, b, table, kind, tire, &mut rows)?;
    }
    let kind_order = |k: &str| {
        // Fit quality (out-of-sample error first, then the in-sample figures) before the
        // coefficient and force changes it explains.
        [
            "model",
            "quality",
            "coefficient",
            "force",
            "stage",
            "inertia",
        ]
        .iter()
        .position(|x| *x == k)
    };
    rows.sort_by(|x, y| {
        (&x.tire, x.rim_in, x.pressure_kpa, kind_order(x.kind)).cmp(&(
            &y.tire,
            y.rim_in,
            y.pressure_kpa,
            kind_order(y.kind),
        ))
    });
    Ok(rows)
}

fn row(key: &GroupKey, kind: &'static str, item: impl Into<String>) -> DiffRow {
    DiffRow {
        tire: key.0.clone(),
        rim_in: Some(key.1),
        pressure_kpa: Some(key.2),
        model: None,
        kind,
        at_pressure_kpa: None,
        item: item.into(),
        old: None,
        new: None,
        rel_change: None,
        max_abs: None,
        rms: None,
    }
}

fn read_tir(path: &Path) -> Result<Option<TirFile>, DiffError> {
    if !path.is_file() {
        return Ok(None);
    }
    let bytes = std::fs::read(path).map_err(|e| StoreError::io(IoOp::Read, path, e))?;
    let (file, _) = TirFile::parse_bytes(&bytes).map_err(|e| DiffError::Tir {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    Ok(Some(file))
}

/// Model added/removed, coefficient changes and force deltas of one group.
fn model_rows(a: &Path, b: &Path, key: &GroupKey, out: &mut Vec<DiffRow>) -> Result<(), DiffError> {
    // Each version names its files among its own models (`naming::unique_tir_names`).
    let name_in = |dir: &Path| {
        results::tir_names(&results::model_groups(dir))
            .0
            .remove(&(key.0.clone(), key.1, key.2))
            .unwrap_or_else(|| tir_file_name(&key.0, key.1 as f64, key.2 as f64))
    };
    let (name_a, name) = (name_in(a), name_in(b));
    let old = read_tir(&a.join("tir").join(&name_a))?;
    let new = read_tir(&b.join("tir").join(&name))?;
    let (old, new) = match (old, new) {
        (None, None) => return Ok(()),
        (Some(_), None) => {
            out.push(model_row(key, PAC2002, format!("removed {name}")));
            return Ok(());
        }
        (None, Some(_)) => {
            out.push(model_row(key, PAC2002, format!("added {name}")));
            return Ok(());
        }
        (Some(o), Some(n)) => (o, n),
    };
    coefficient_rows(key, PAC2002, &old, &new, out);
    for (item, max_abs, rms) in force_deltas(&old, &new, None) {
        push_force(out, key, PAC2002, None, item, max_abs, rms);
    }
    Ok(())
}

/// `model` values of the rows.
const PAC2002: &str = "pac2002";
const MF61: &str = "mf61";

fn model_row(key: &GroupKey, model: &'static str, item: String) -> DiffRow {
    let mut r = row(key, "model", item);
    r.model = Some(model);
    r
}

/// One row per coefficient that differs.
fn coefficient_rows(
    key: &GroupKey,
    model: &'static str,
    old: &TirFile,
    new: &TirFile,
    out: &mut Vec<DiffRow>,
) {
    for &c in Coef::ALL.iter() {
        let (x, y) = (old.coefs[c], new.coefs[c]);
        if !same(x, y) {
            let mut r = row(key, "coefficient", c.name());
            r.model = Some(model);
            r.old = Some(x);
            r.new = Some(y);
            r.rel_change = rel_change(x, y);
            out.push(r);
        }
    }
}

/// A force row when the models differ by more than [`SAME_FORCE`].
fn push_force(
    out: &mut Vec<DiffRow>,
    key: &GroupKey,
    model: &'static str,
    at_pressure_kpa: Option<f64>,
    item: &str,
    max_abs: f64,
    rms: f64,
) {
    if max_abs > SAME_FORCE {
        let mut r = row(key, "force", item);
        r.model = Some(model);
        r.at_pressure_kpa = at_pressure_kpa;
        r.max_abs = Some(max_abs);
        r.rms = Some(rms);
        out.push(r);
    }
}

/// The pressures two MF 6.1 models of a tire and rim are compared at, kPa: every tested
/// pressure (the groups of either manifest) and the midpoint between each two neighbouring ones;
/// the models' `NOMPRES` when no group is known.
pub fn mf61_pressures_kpa(tested_kpa: &[i64], nominal_kpa: &[i64]) -> Vec<f64> {
    let mut tested: Vec<i64> = if tested_kpa.is_empty() {
        nominal_kpa.to_vec()
    } else {
        tested_kpa.to_vec()
    };
    tested.sort_unstable();
    tested.dedup();
    let mut out = Vec::new();
    for (i, p) in tested.iter().enumerate() {
        if i > 0 {
            out.push(0.5 * (tested[i - 1] + p) as f64);
        }
        out.push(*p as f64);
    }
    out
}

/// Model added/removed, coefficient changes and force deltas (at each tested pressure and
/// between them) of every tire and rim's MF 6.1 model.
fn mf61_rows(
    a: &Path,
    b: &Path,
    (ma, mb): (&Manifest, &Manifest),
    tire: Option<&str>,
    out: &mut Vec<DiffRow>,
) -> Result<(), DiffError> {
    // (tire, rim) -> (key at NOMPRES, file name) in one version.
    let models_in = |dir: &Path| -> BTreeMap<(String, i64), (GroupKey, String)> {
        let (names, _) = results::mf61_names(&results::mf61_groups(dir));
        names
            .into_iter()
            .map(|(k, name)| ((k.0.clone(), k.1), (k, name)))
            .collect()
    };
    let (in_a, in_b) = (models_in(a), models_in(b));
    let combos: BTreeSet<&(String, i64)> = in_a.keys().chain(in_b.keys()).collect();
    for combo in combos
        .into_iter()
        .filter(|c| tire.is_none_or(|t| t == c.0.as_str()))
    {
        let file_of = |dir: &Path, m: Option<&(GroupKey, String)>| -> Result<_, DiffError> {
            let name = m.map_or_else(
                || mf61_tir_file_name(&combo.0, combo.1 as f64),
                |(_, n)| n.clone(),
            );
            Ok((read_tir(&dir.join("tir").join(&name))?, name))
        };
        let (ka, kb) = (in_a.get(combo), in_b.get(combo));
        let ((old, _), (new, name)) = (file_of(a, ka)?, file_of(b, kb)?);
        let key = kb.or(ka).map(|(k, _)| k.clone()).unwrap_or_default();
        let (old, new) = match (old, new) {
            (None, None) => continue,
            (Some(_), None) => {
                let (k, n) = ka.cloned().unwrap_or_default();
                out.push(model_row(&k, MF61, format!("removed {n}")));
                continue;
            }
            (None, Some(_)) => {
                out.push(model_row(&key, MF61, format!("added {name}")));
                continue;
            }
            (Some(o), Some(n)) => (o, n),
        };
        coefficient_rows(&key, MF61, &old, &new, out);
        let tested: Vec<i64> = ma
            .groups
            .iter()
            .chain(&mb.groups)
            .filter(|g| g.tire == combo.0 && g.rim_in == combo.1)
            .map(|g| g.pressure_kpa)
            .collect();
        let nominal: Vec<i64> = ka.iter().chain(kb.iter()).map(|(k, _)| k.2).collect();
        for p_kpa in mf61_pressures_kpa(&tested, &nominal) {
            for (item, max_abs, rms) in force_deltas(&old, &new, Some(p_kpa * 1e3)) {
                push_force(out, &key, MF61, Some(p_kpa), item, max_abs, rms);
            }
        }
    }
    Ok(())
}

/// Same value within [`SAME_REL`] (NaN equals NaN).
fn same(x: f64, y: f64) -> bool {
    if x.is_nan() || y.is_nan() {
        return x.is_nan() && y.is_nan();
    }
    (x - y).abs() <= SAME_REL * x.abs().max(y.abs())
}

fn rel_change(old: f64, new: f64) -> Option<f64> {
    (old.abs() > 0.0 && old.is_finite() && new.is_finite()).then(|| (new - old) / old.abs())
}

/// The tested envelope both files declare: (lo, hi) of load (N), slip angle (rad), slip ratio
/// and inclination (rad). A range a file leaves at the PAC2002 default (unbounded or +-90 deg)
/// is limited to what a tire test covers: load 2.5 FNOMIN, |alpha| 0.35 rad, |kappa| 0.3,
/// |gamma| 0.1 rad.
pub fn envelope(a: &TirFile, b: &TirFile) -> [(f64, f64); 4] {
    let common = |lo: Coef, hi: Coef, cap: f64| {
        let l = a.coefs[lo].max(b.coefs[lo]).max(-cap);
        let h = a.coefs[hi].min(b.coefs[hi]).min(cap);
        // Disjoint ranges: compare over the gap between them.
        if l < h { (l, h) } else { (h, l) }
    };
    let fnomin = b.coefs[Coef::FNOMIN].max(a.coefs[Coef::FNOMIN]).max(1.0);
    let (fz_lo, fz_hi) = common(Coef::FZMIN, Coef::FZMAX, 2.5 * fnomin);
    [
        (fz_lo.max(0.05 * fnomin), fz_hi),
        common(Coef::ALPMIN, Coef::ALPMAX, 0.35),
        common(Coef::KPUMIN, Coef::KPUMAX, 0.3),
        common(Coef::CAMMIN, Coef::CAMMAX, 0.1),
    ]
}

fn grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

/// (item, max |delta|, RMS delta) of Fx, Fy and Mz between two models over their common
/// envelope: 5 loads x 9 slip angles x 9 slip ratios x 3 inclinations, combined slip, at the
/// new file's measurement speed LONGVL, inputs limited as MFeval useMode 111; at the inflation
/// pressure `p_pa` (MF 6.x; `None`: each file's own, and PAC2002 ignores it).
fn force_deltas(old: &TirFile, new: &TirFile, p_pa: Option<f64>) -> [(&'static str, f64, f64); 3] {
    let [fz, alpha, kappa, gamma] = envelope(old, new);
    let vx = if new.coefs[Coef::LONGVL] > 0.0 {
        new.coefs[Coef::LONGVL]
    } else {
        11.1
    };
    let mut points = Vec::new();
    for &fz_n in &grid(fz.0, fz.1, 5) {
        for &alpha_rad in &grid(alpha.0, alpha.1, 9) {
            for &k in &grid(kappa.0, kappa.1, 9) {
                for &gamma_rad in &grid(gamma.0, gamma.1, 3) {
                    points.push(SlipInput {
                        fz_n,
                        kappa: k,
                        alpha_rad,
                        gamma_rad,
                        vx_mps: vx,
                    });
                }
            }
        }
    }
    let eval = |m: Pac2002| {
        let mut out = vec![Evaluation::default(); points.len()];
        match p_pa {
            Some(p) => m.eval_batch_at(&points, Pressures::Uniform(p), Mode::Limits, &mut out),
            None => m.eval_batch(&points, Mode::Limits, &mut out),
        }
        out
    };
    let (eo, en) = (eval(old.model()), eval(new.model()));
    let stats = |f: fn(&Evaluation<f64>) -> f64| {
        let (mut max, mut sum_sq) = (0.0f64, 0.0);
        for (o, n) in eo.iter().zip(&en) {
            let d = f(n) - f(o);
            let d = if d.is_finite() { d } else { f64::INFINITY };
            max = max.max(d.abs());
            sum_sq += d * d;
        }
        (max, (sum_sq / eo.len().max(1) as f64).sqrt())
    };
    let (fx, fy, mz) = (stats(|e| e.fx_n), stats(|e| e.fy_n), stats(|e| e.mz_nm));
    [
        ("Fx_N", fx.0, fx.1),
        ("Fy_N", fy.0, fy.1),
        ("Mz_Nm", mz.0, mz.1),
    ]
}

/// Free-text columns: neither keys nor compared values.
const TEXT_COLUMNS: [&str; 6] = [
    "diagnostics",
    "units",
    "reason",
    "warnings",
    "notes",
    "termination",
];

/// The columns that identify a row of a result table: strings (except free text), `rim_in`,
/// `pressure_kpa` and nominal levels (`*_nom`); every other column except wall times is a value.
fn split_columns(df: &DataFrame) -> (Vec<String>, Vec<String>) {
    let mut keys = Vec::new();
    let mut values = Vec::new();
    for c in df.columns() {
        let name = c.name().to_string();
        if TEXT_COLUMNS.contains(&name.as_str()) {
            continue;
        }
        let is_key = matches!(c.dtype(), DataType::String)
            || name == "rim_in"
            || name == "pressure_kpa"
            || name.ends_with("_nom");
        if is_key {
            keys.push(name);
        } else if !name.ends_with("seconds")
            && matches!(
                c.dtype(),
                DataType::Float64 | DataType::Int64 | DataType::Boolean
            )
        {
            values.push(name);
        }
    }
    (keys, values)
}

/// A table as rows keyed by its key columns (duplicates numbered in order).
struct KeyedTable {
    keys: Vec<String>,
    values: Vec<String>,
    rows: BTreeMap<Vec<String>, Vec<Option<f64>>>,
}

fn cell_text(c: &Column, i: usize) -> String {
    match c.get(i) {
        Ok(AnyValue::String(s)) => s.to_string(),
        Ok(AnyValue::Null) | Err(_) => String::new(),
        Ok(v) => v.to_string(),
    }
}

fn cell_f64(c: &Column, i: usize) -> Option<f64> {
    match c.get(i).ok()? {
        AnyValue::Float64(v) => Some(v),
        AnyValue::Int64(v) => Some(v as f64),
        AnyValue::Boolean(v) => Some(if v { 1.0 } else { 0.0 }),
        _ => None,
    }
}

fn keyed(df: &DataFrame, tire: Option<&str>) -> KeyedTable {
    let (keys, values) = split_columns(df);
    let mut rows = BTreeMap::new();
    let key_cols: Vec<&Column> = keys.iter().filter_map(|k| df.column(k).ok()).collect();
    let value_cols: Vec<&Column> = values.iter().filter_map(|k| df.column(k).ok()).collect();
    let tire_col = df.column("tire").ok();
    for i in 0..df.height() {
        // With a tire filter, rows of tables without a tire (inertia) belong to no tire.
        if let Some(want) = tire
            && tire_col.is_none_or(|t| cell_text(t, i) != want)
        {
            continue;
        }
        let mut key: Vec<String> = key_cols.iter().map(|c| cell_text(c, i)).collect();
        let base = key.clone();
        let mut n = 0;
        while rows.contains_key(&key) {
            n += 1;
            key = base.clone();
            key.push(format!("#{n}"));
        }
        rows.insert(key, value_cols.iter().map(|c| cell_f64(c, i)).collect());
    }
    KeyedTable { keys, values, rows }
}

/// Value changes and added/removed rows of one result table.
fn table_rows(
    a: &Path,
    b: &Path,
    table: TableName,
    kind: &'static str,
    tire: Option<&str>,
    out: &mut Vec<DiffRow>,
) -> Result<(), DiffError> {
    let read = |dir: &Path| -> Result<Option<DataFrame>, DiffError> {
        Ok(results::read_table(dir, table)?)
    };
    // A table only one version has is compared with an empty table of the same columns.
    let (da, db) = match (read(a)?, read(b)?) {
        (None, None) => return Ok(()),
        (Some(da), None) => (da.clone(), da.clear()),
        (None, Some(db)) => (db.clear(), db),
        (Some(da), Some(db)) => (da, db),
    };
    let (ta, tb) = (keyed(&da, tire), keyed(&db, tire));
    if ta.keys != tb.keys || ta.values != tb.values {
        let mut r = row(
            &(String::new(), 0, 0),
            kind,
            format!("{table}: columns differ"),
        );
        r.rim_in = None;
        r.pressure_kpa = None;
        out.push(r);
        return Ok(());
    }
    let position = |name: &str| ta.keys.iter().position(|k| k == name);
    let (ti, ri, pi) = (
        position("tire"),
        position("rim_in"),
        position("pressure_kpa"),
    );
    let describe = |key: &[String]| -> (DiffRow, String) {
        let mut r = row(&(String::new(), 0, 0), kind, "");
        r.tire = ti.map(|i| key[i].clone()).unwrap_or_default();
        r.rim_in = ri.and_then(|i| key[i].parse().ok());
        r.pressure_kpa = pi.and_then(|i| key[i].parse().ok());
        let extra: Vec<String> = key
            .iter()
            .enumerate()
            .filter(|(i, _)| Some(*i) != ti && Some(*i) != ri && Some(*i) != pi)
            .map(|(i, v)| match ta.keys.get(i) {
                Some(k) => format!("{k}={v}"),
                None => v.clone(),
            })
            .collect();
        (r, extra.join(", "))
    };
    let all: BTreeSet<&Vec<String>> = ta.rows.keys().chain(tb.rows.keys()).collect();
    for key in all {
        let (mut r, extra) = describe(key);
        match (ta.rows.get(key), tb.rows.get(key)) {
            (Some(_), None) => {
                r.item = format!("{table} row removed ({extra})");
                out.push(r);
            }
            (None, Some(_)) => {
                r.item = format!("{table} row added ({extra})");
                out.push(r);
            }
            (Some(va), Some(vb)) => {
                for (j, name) in ta.values.iter().enumerate() {
                    let (x, y) = (va[j], vb[j]);
                    let changed = match (x, y) {
                        (Some(x), Some(y)) => !same(x, y),
                        (None, None) => false,
                        _ => true,
                    };
                    if changed {
                        let mut c = r.clone();
                        c.item = if extra.is_empty() {
                            format!("{table}.{name}")
                        } else {
                            format!("{table}.{name} ({extra})")
                        };
                        c.old = x;
                        c.new = y;
                        c.rel_change = x.zip(y).and_then(|(x, y)| rel_change(x, y));
                        out.push(c);
                    }
                }
            }
            (None, None) => {}
        }
    }
    Ok(())
}

/// The rows as a table (columns tire, rim_in, pressure_kpa, model, kind, item, at_pressure_kpa,
/// old, new, rel_change, max_abs, rms).
pub fn to_frame(rows: &[DiffRow]) -> PolarsResult<DataFrame> {
    let f = |g: fn(&DiffRow) -> Option<f64>| rows.iter().map(g).collect::<Vec<_>>();
    df!(
        "tire" => rows.iter().map(|r| r.tire.as_str()).collect::<Vec<_>>(),
        "rim_in" => rows.iter().map(|r| r.rim_in).collect::<Vec<_>>(),
        "pressure_kpa" => rows.iter().map(|r| r.pressure_kpa).collect::<Vec<_>>(),
        "model" => rows.iter().map(|r| r.model).collect::<Vec<_>>(),
        "kind" => rows.iter().map(|r| r.kind).collect::<Vec<_>>(),
        "item" => rows.iter().map(|r| r.item.as_str()).collect::<Vec<_>>(),
        "at_pressure_kpa" => f(|r| r.at_pressure_kpa),
        "old" => f(|r| r.old),
        "new" => f(|r| r.new),
        "rel_change" => f(|r| r.rel_change),
        "max_abs" => f(|r| r.max_abs),
        "rms" => f(|r| r.rms),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use tirebase_core::tire_model::Coefs;

    fn tire(pdy1: f64) -> TirFile {
        let mut c = Coefs::defaults();
        for (k, v) in [
            (Coef::FNOMIN, 1000.0),
            (Coef::UNLOADED_RADIUS, 0.26),
            (Coef::FZMIN, 200.0),
            (Coef::FZMAX, 2000.0),
            (Coef::ALPMIN, -0.2),
            (Coef::ALPMAX, 0.2),
            (Coef::KPUMIN, -0.15),
            (Coef::KPUMAX, 0.15),
            (Coef::CAMMIN, -0.07),
            (Coef::CAMMAX, 0.07),
            (Coef::PCY1, 1.3),
            (Coef::PDY1, pdy1),
            (Coef::PKY1, -20.0),
            (Coef::PKY2, 1.5),
            (Coef::PCX1, 1.6),
            (Coef::PDX1, 2.0),
            (Coef::PKX1, 20.0),
        ] {
            c[k] = v;
        }
        TirFile::from_coefs(c)
    }

    #[test]
    fn same_model_has_no_force_delta_and_peak_friction_change_moves_fy() {
        let [fy_same, ..] = [force_deltas(&tire(2.0), &tire(2.0), None)[1]];
        assert!(fy_same.1 <= SAME_FORCE, "{fy_same:?}");
        let d = force_deltas(&tire(2.0), &tire(2.2), None);
        let (_, fy_max, fy_rms) = d[1];
        // 10 % more peak friction at up to 2000 N: the lateral force changes by up to ~400 N.
        assert!(fy_max > 50.0 && fy_max < 450.0, "{d:?}");
        assert!(fy_rms > 0.0 && fy_rms < fy_max, "{d:?}");
    }

    #[test]
    fn envelope_is_the_common_declared_range() {
        let mut b = tire(2.0);
        b.coefs[Coef::ALPMAX] = 0.15;
        let env = envelope(&tire(2.0), &b);
        assert_eq!(env[0], (200.0, 2000.0));
        assert_eq!(env[1], (-0.2, 0.15));
        let wide = TirFile::from_coefs(Coefs::defaults());
        let env = envelope(&wide, &wide);
        assert_eq!(env[1], (-0.35, 0.35), "default +-90 deg is limited");
    }

    #[test]
    fn a_tire_filter_leaves_out_rows_of_no_tire() {
        let inertia =
            df!("session" => ["s"], "quantity" => ["inertia"], "value" => [96.0]).unwrap();
        assert_eq!(keyed(&inertia, None).rows.len(), 1);
        assert!(keyed(&inertia, Some("T")).rows.is_empty());
        let per_tire = df!("tire" => ["T", "U"], "value" => [1.0, 2.0]).unwrap();
        assert_eq!(keyed(&per_tire, Some("T")).rows.len(), 1);
    }

    #[test]
    fn mf61_models_are_compared_at_tested_pressures_and_between() {
        assert_eq!(
            mf61_pressures_kpa(&[83, 69, 97, 83], &[83]),
            [69.0, 76.0, 83.0, 90.0, 97.0]
        );
        assert_eq!(mf61_pressures_kpa(&[], &[83, 83]), [83.0]);
    }

    #[test]
    fn mf61_force_deltas_depend_on_the_pressure() {
        let mut a = tire(2.0);
        a.coefs[Coef::NOMPRES] = 83e3;
        let mut a = TirFile::from_coefs_as(a.coefs, tirebase_core::tire_model::Version::Mf61);
        a.coefs[Coef::PPY3] = 0.0;
        let mut b = a.clone();
        b.coefs[Coef::PPY3] = -0.5;
        // Same at NOMPRES, different below it.
        let at_nominal = force_deltas(&a, &b, Some(83e3))[1];
        let below = force_deltas(&a, &b, Some(69e3))[1];
        assert!(at_nominal.1 <= SAME_FORCE, "{at_nominal:?}");
        assert!(below.1 > 1.0, "{below:?}");
    }

    #[test]
    fn relative_change_and_sameness() {
        assert!(same(1.0, 1.0 + 1e-15));
        assert!(!same(1.0, 1.0 + 1e-9));
        assert!(same(f64::NAN, f64::NAN));
        assert_eq!(rel_change(2.0, 3.0), Some(0.5));
        assert_eq!(rel_change(0.0, 3.0), None);
    }
}
