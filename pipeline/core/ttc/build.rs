//! Source columns (any reader) -> [`RunTable`]: unit conversion, frame change, kappa, metadata,
//! then the unit cross-checks (`check.rs`) and, without SL, the derived kappa (`slip.rs`).
//!
//! In: the columns a reader decoded, each with its [`ColumnInfo`] (unit already parsed and
//! checked against the channel), plus the partly filled [`RunMeta`]. Out: the typed run. This is
//! where both readers meet, so the conversion rules exist once. Deliberately not here: parsing,
//! and any smoothing or QC judgement.

use super::{
    ColumnInfo, ExtraChannel, KappaSource, RunMeta, RunTable, TtcChannel, TtcError, TtcFileName,
};
use crate::frame::{IsoW, Sae, TireChannels};
use crate::numerics::stats::median_high;

/// One decoded column of the source, in its original unit.
pub(crate) struct SourceColumn {
    pub info: ColumnInfo,
    pub values: Vec<f64>,
}

/// Loads (ISO-W Fz) below this are treated as "wheel unloaded" by the FZ-sign sanity check, N.
const FZ_SIGN_CHECK_MIN_N: f64 = 50.0;

/// Assemble a run. `missing_location` names where a missing channel was looked for (`line 2`,
/// `variables`). All columns must have the same, non-zero length (the readers guarantee it).
pub(crate) fn build(
    mut meta: RunMeta,
    columns: Vec<SourceColumn>,
    missing_location: &str,
) -> Result<RunTable, TtcError> {
    let rows = columns.first().map_or(0, |c| c.values.len());
    debug_assert!(columns.iter().all(|c| c.values.len() == rows));

    let mut by_channel: [Option<Vec<f64>>; TtcChannel::ALL.len()] = Default::default();
    let mut extras = Vec::new();
    for SourceColumn { info, mut values } in columns {
        match (info.channel, info.unit) {
            (Some(channel), Some(unit)) => {
                unit.convert_in_place(&mut values);
                by_channel[channel as usize] = Some(values);
            }
            _ => extras.push(ExtraChannel {
                name: info.name.clone(),
                unit: info.unit_raw.clone(),
                values,
            }),
        }
        meta.columns.push(info);
    }
    if let Some(missing) = TtcChannel::REQUIRED
        .into_iter()
        .find(|c| by_channel[*c as usize].is_none())
    {
        return Err(TtcError::MissingChannel {
            source_name: meta.source_name.clone(),
            location: missing_location.to_string(),
            channel: missing.name().to_string(),
        });
    }
    let mut take = |channel: TtcChannel| by_channel[channel as usize].take();
    let mut required = |channel: TtcChannel| take(channel).unwrap_or_default();

    let et_s = required(TtcChannel::Et);
    let speed_kph = required(TtcChannel::V);
    let pressure_kpa = required(TtcChannel::P);
    let (fx, fy, fz) = (
        required(TtcChannel::Fx),
        required(TtcChannel::Fy),
        required(TtcChannel::Fz),
    );
    let (mx, mz) = (required(TtcChannel::Mx), required(TtcChannel::Mz));
    let (sa_rad, ia_rad) = (required(TtcChannel::Sa), required(TtcChannel::Ia));
    let sl = take(TtcChannel::Sl);
    let (kappa, kappa_source) = kappa_from_sl(sl.as_deref(), rows);

    let tire = if meta.iso_flag == Some(true) {
        TireChannels::<IsoW>::new(fx, fy, fz, mx, Vec::new(), mz, sa_rad, ia_rad, kappa)
    } else {
        TireChannels::<Sae>::new(fx, fy, fz, mx, Vec::new(), mz, sa_rad, ia_rad, kappa).into_iso_w()
    };

    meta.rows = rows;
    meta.kappa_source = kappa_source;
    meta.sample_rate_hz = estimate_sample_rate_hz(&et_s);
    meta.file_name = TtcFileName::parse(&meta.source_name);
    if let Some(name) = &meta.file_name {
        meta.project.get_or_insert(name.project);
        meta.run.get_or_insert(name.run);
    }
    if let Some(warning) = fz_sign_warning(&tire.fz_n, meta.iso_flag) {
        meta.warnings.push(warning);
    }

    let mut table = RunTable {
        meta,
        et_s,
        speed_kph,
        wheel_speed_rpm: take(TtcChannel::N),
        loaded_radius_m: take(TtcChannel::Rl),
        effective_radius_m: take(TtcChannel::Re),
        pressure_kpa,
        tire,
        nfx: take(TtcChannel::Nfx),
        nfy: take(TtcChannel::Nfy),
        road_temp_c: take(TtcChannel::Rst),
        tread_inner_temp_c: take(TtcChannel::Tsti),
        tread_centre_temp_c: take(TtcChannel::Tstc),
        tread_outer_temp_c: take(TtcChannel::Tsto),
        ambient_temp_c: take(TtcChannel::Ambtmp),
        sr: take(TtcChannel::Sr),
        sl,
        extras,
    };
    table.meta.unit_notes = super::check::cross_check(&mut table);
    if !table.meta.kappa_source.is_measured()
        && let Some((kappa, note)) = super::slip::derive_kappa(&table)
    {
        table.tire.kappa = kappa;
        table.meta.kappa_source = KappaSource::Derived;
        table.meta.warnings.push(note);
    }
    Ok(table)
}

/// kappa = SL when SL was recorded (some value not exactly zero), else zeros and a flag.
fn kappa_from_sl(sl: Option<&[f64]>, rows: usize) -> (Vec<f64>, KappaSource) {
    match sl {
        // Exact zero on purpose: an unrecorded SL is written as `0.000`/`0`, every sample.
        Some(sl) if sl.iter().any(|v| *v != 0.0) => (sl.to_vec(), KappaSource::Sl),
        Some(_) => (vec![0.0; rows], KappaSource::SlAllZero),
        None => (vec![0.0; rows], KappaSource::NoSl),
    }
}

/// `1 / median(positive ET steps)`: robust to the ET jumps of run files and to duplicated times.
pub(crate) fn estimate_sample_rate_hz(et_s: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = et_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    median_high(&mut steps).map(|median| 1.0 / median)
}

/// A warning when most loaded samples have ISO-W `Fz < 0`: the file's frame flag is probably
/// wrong (or FZ was recorded with an unusual sign).
fn fz_sign_warning(fz_n: &[f64], iso_flag: Option<bool>) -> Option<String> {
    let loaded = fz_n.iter().filter(|v| v.abs() > FZ_SIGN_CHECK_MIN_N);
    let (negative, total) = loaded.fold((0usize, 0usize), |(n, t), v| {
        (n + usize::from(*v < 0.0), t + 1)
    });
    (total > 0 && negative * 2 > total).then(|| {
        let flag = match iso_flag {
            Some(true) => "ISO True",
            Some(false) => "ISO False",
            None => "no ISO flag (read as SAE)",
        };
        format!(
            "FZ: {negative} of {total} loaded samples are negative in ISO-W (z up) with {flag}; \
             check the file's axis convention"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_rate_ignores_gaps_and_duplicates() {
        let mut et: Vec<f64> = (0..200).map(|i| f64::from(i) * 0.01).collect();
        et.push(10.0); // a dwell cut out of a run file
        et.push(10.0); // duplicated time
        et.extend((1..50).map(|i| 10.0 + f64::from(i) * 0.01));
        let rate = estimate_sample_rate_hz(&et).unwrap();
        assert!((rate - 100.0).abs() < 1e-6, "{rate}");
        assert_eq!(estimate_sample_rate_hz(&[1.0]), None);
    }

    #[test]
    fn kappa_is_sl_only_when_sl_was_recorded() {
        assert_eq!(kappa_from_sl(None, 2), (vec![0.0, 0.0], KappaSource::NoSl));
        assert_eq!(
            kappa_from_sl(Some(&[0.0, 0.0]), 2),
            (vec![0.0, 0.0], KappaSource::SlAllZero)
        );
        assert_eq!(
            kappa_from_sl(Some(&[0.0, -0.1]), 2),
            (vec![0.0, -0.1], KappaSource::Sl)
        );
    }

    #[test]
    fn fz_sign_warning_only_when_most_loaded_samples_point_down() {
        assert!(fz_sign_warning(&[1000.0, 800.0, -5.0], Some(false)).is_none());
        assert!(fz_sign_warning(&[-1000.0, -800.0, 5.0], Some(true)).is_some());
    }
}
