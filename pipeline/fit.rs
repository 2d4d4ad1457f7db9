//! TEMPORARY SHIM of the fit command's library API (owner: helper `fitcmd`, INTERFACES.md), so the
//! nightly run compiles and can be exercised before the real module lands on main. It is deleted
//! when `main` is merged; nothing here is a real fit.
//!
//! In: the store. Out: a group plan (real grouping and hashing of the segments table) and a
//! crude, data-dependent stand-in for the fit outcome (peak |Fy|/Fz as PDY1 and PDX1).

use std::collections::BTreeMap;
use std::path::Path;

use polars::prelude::*;
use tirebase_core::fit::segment_data::TireKey;
use tirebase_core::naming::tir_file_name;
use tirebase_core::tire_model::tir::TirFile;
use tirebase_core::tire_model::{Coef, Coefs};

use crate::config::Config;
use crate::progress::Progress;
use crate::store::StoreError;
use crate::store::files::{parquet_files_below, parquet_files_in, read_parquet, sha256_bytes};
use crate::store::layout::{SAMPLES_DIR, SEGMENTS_DIR, hive_encode};

/// Fit errors (store-level only).
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// The store could not be read or written.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// A table could not be built.
    #[error("fit: {0}")]
    Polars(#[from] PolarsError),
}

/// Which stages to run.
#[derive(Clone, Debug)]
pub struct StageSet {
    pub pac2002: bool,
    pub spring_rate: bool,
    pub thermal: bool,
    pub relaxation: bool,
}

impl Default for StageSet {
    fn default() -> Self {
        StageSet {
            pac2002: true,
            spring_rate: true,
            thermal: true,
            relaxation: true,
        }
    }
}

/// What to fit.
#[derive(Clone, Debug, Default)]
pub struct FitOptions {
    pub tire: Option<String>,
    pub stages: StageSet,
    pub jobs: usize,
}

/// One group and the hash of its inputs.
#[derive(Clone, Debug)]
pub struct GroupPlan {
    pub key: TireKey,
    pub input_sha256: String,
    pub n_segments: usize,
}

/// A failed group/stage.
#[derive(Clone, Debug)]
pub struct FitFailure {
    pub tire: String,
    pub rim_in: i64,
    pub pressure_kpa: i64,
    pub stage: String,
    pub reason: String,
}

/// Result tables, .tir files, failures, timings.
#[derive(Clone, Debug, Default)]
pub struct FitOutcome {
    pub tables: BTreeMap<String, DataFrame>,
    pub tir_files: Vec<(String, String)>,
    pub failures: Vec<FitFailure>,
    pub stage_seconds: BTreeMap<String, f64>,
}

/// Groups of the store's segments by tire, rim and nominal pressure.
pub fn plan_groups(
    store: &Path,
    config: &Config,
    opts: &FitOptions,
) -> Result<Vec<GroupPlan>, FitError> {
    let mut groups: BTreeMap<TireKey, Vec<String>> = BTreeMap::new();
    for file in parquet_files_in(&store.join(SEGMENTS_DIR))? {
        let df = read_parquet(&file)?;
        let tire = df.column("tire")?.str()?.clone();
        let rim = df.column("rim_in")?.i64()?.clone();
        let p = df.column("pressure_kpa_nom")?.i64()?.clone();
        let id = df.column("segment_id")?.str()?.clone();
        let sha = df.column("source_sha256")?.str()?.clone();
        for i in 0..df.height() {
            let (Some(t), Some(r), Some(p), Some(id), Some(sha)) =
                (tire.get(i), rim.get(i), p.get(i), id.get(i), sha.get(i))
            else {
                continue;
            };
            if opts.tire.as_deref().is_some_and(|want| want != t) {
                continue;
            }
            let key = TireKey {
                tire: t.to_string(),
                rim_in: r,
                pressure_kpa_nom: p,
            };
            groups.entry(key).or_default().push(format!("{id} {sha}"));
        }
    }
    let cfg = toml::to_string(&config.fit).unwrap_or_default();
    Ok(groups
        .into_iter()
        .map(|(key, mut ids)| {
            ids.sort();
            let text = format!("{}\n{cfg}\n{}", ids.join("\n"), env!("CARGO_PKG_VERSION"));
            GroupPlan {
                key,
                input_sha256: sha256_bytes(text.as_bytes()),
                n_segments: ids.len(),
            }
        })
        .collect())
}

/// Stand-in fit: peak |Fy|/Fz of the group's cornering samples.
pub fn fit_groups(
    store: &Path,
    _config: &Config,
    groups: &[GroupPlan],
    _opts: &FitOptions,
    progress: &dyn Progress,
) -> Result<FitOutcome, FitError> {
    let bar = progress.stage("fit", "groups", groups.len() as u64);
    let mut out = FitOutcome::default();
    let (mut tires, mut rims, mut ps, mut names, mut values) =
        (vec![], vec![], vec![], vec![], vec![]);
    let (mut qt, mut qr, mut qp, mut qn, mut qs) = (vec![], vec![], vec![], vec![], vec![]);
    for g in groups {
        let k = &g.key;
        let dir = store
            .join(SAMPLES_DIR)
            .join("test=cornering")
            .join(format!("tire={}", hive_encode(&k.tire)))
            .join(format!("rim_in={}", k.rim_in))
            .join(format!("pressure_kpa_nom={}", k.pressure_kpa_nom));
        let (mut mu, mut fz_sum, mut n, mut fz_max) = (0.0f64, 0.0, 0usize, 0.0f64);
        for f in parquet_files_below(&dir)? {
            let df = read_parquet(&f)?;
            let fy = df.column("fy_n")?.f64()?.clone();
            let fz = df.column("fz_n")?.f64()?.clone();
            for (y, z) in fy.into_no_null_iter().zip(fz.into_no_null_iter()) {
                if z > 200.0 {
                    mu = mu.max(y.abs() / z);
                    fz_sum += z;
                    n += 1;
                    fz_max = fz_max.max(z);
                }
            }
        }
        if n == 0 {
            out.failures.push(FitFailure {
                tire: k.tire.clone(),
                rim_in: k.rim_in,
                pressure_kpa: k.pressure_kpa_nom,
                stage: "pac2002".into(),
                reason: "no cornering samples".into(),
            });
            bar.inc(1);
            continue;
        }
        let mut c = Coefs::defaults();
        for (coef, v) in [
            (Coef::FNOMIN, fz_sum / n as f64),
            (Coef::UNLOADED_RADIUS, 0.26),
            (Coef::FZMIN, 200.0),
            (Coef::FZMAX, fz_max),
            (Coef::ALPMIN, -0.2),
            (Coef::ALPMAX, 0.2),
            (Coef::KPUMIN, -0.2),
            (Coef::KPUMAX, 0.2),
            (Coef::CAMMIN, -0.07),
            (Coef::CAMMAX, 0.07),
            (Coef::PCY1, 1.3),
            (Coef::PDY1, mu),
            (Coef::PKY1, -20.0),
            (Coef::PKY2, 1.5),
            (Coef::PCX1, 1.6),
            (Coef::PDX1, mu),
            (Coef::PKX1, 20.0),
            (Coef::QBZ1, 10.0),
            (Coef::QCZ1, 1.2),
            (Coef::QDZ1, 0.1),
        ] {
            c[coef] = v;
            tires.push(k.tire.clone());
            rims.push(k.rim_in);
            ps.push(k.pressure_kpa_nom);
            names.push(coef.name().to_string());
            values.push(v);
        }
        qt.push(k.tire.clone());
        qr.push(k.rim_in);
        qp.push(k.pressure_kpa_nom);
        qn.push(n as i64);
        qs.push(0.001);
        let text = TirFile::from_coefs(c).render().unwrap_or_default();
        out.tir_files.push((
            tir_file_name(&k.tire, k.rim_in as f64, k.pressure_kpa_nom as f64),
            text,
        ));
        bar.inc(1);
    }
    bar.finish("shim");
    out.tables.insert(
        "coefficients".into(),
        df!("tire" => tires, "rim_in" => rims, "pressure_kpa" => ps, "name" => names, "value" => values)?,
    );
    out.tables.insert(
        "fit_quality".into(),
        df!("tire" => qt, "rim_in" => qr, "pressure_kpa" => qp, "n" => qn, "seconds" => qs)?,
    );
    Ok(out)
}

/// Writes OUT/<table>.parquet and OUT/tir/*.tir.
pub fn write_outcome(outcome: &FitOutcome, out: &Path) -> Result<(), FitError> {
    for (name, df) in &outcome.tables {
        crate::store::files::write_parquet_atomic(
            &out.join(format!("{name}.parquet")),
            &mut df.clone(),
        )?;
    }
    for (name, text) in &outcome.tir_files {
        crate::store::files::write_bytes_atomic(&out.join("tir").join(name), text.as_bytes())?;
    }
    Ok(())
}
