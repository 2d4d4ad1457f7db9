//! File names that more than one stage must agree on, as pure functions.
//!
//! In: a tire name as people write it (`"Hoosier 20.5x7.0-13 R25B"`), a rim width in inches and
//! a nominal pressure in kPa. Out: the file stem or name both the virtual test machine (its truth)
//! and the fitting stage (its output) use, so a fitted `.tir` and its truth pair up by name.
//! Deliberately not here: directories (each stage owns its output root).
//!
//! Sanitising rule ([`sanitize_tire`]): lowercase; keep `[a-z0-9.-]`; every run of other
//! characters (`_` included) becomes one `_`; leading and trailing `_` are dropped; an empty
//! result is `tire`. So a sanitised name never contains `__`, the separator of the fields.

/// The tire part of a file name: lowercase `[a-z0-9.-]`, runs of anything else -> `_`.
///
/// ```
/// use tirebase_core::naming::sanitize_tire;
/// assert_eq!(sanitize_tire("Hoosier 20.5x7.0-13 R25B"), "hoosier_20.5x7.0-13_r25b");
/// assert_eq!(sanitize_tire("  Avon 7.0/20.0-13 (A45)  "), "avon_7.0_20.0-13_a45");
/// assert_eq!(sanitize_tire("***"), "tire");
/// ```
pub fn sanitize_tire(tire: &str) -> String {
    let mut out = String::with_capacity(tire.len());
    let mut pending_sep = false;
    for ch in tire.chars().flat_map(char::to_lowercase) {
        if ch.is_ascii_lowercase() || ch.is_ascii_digit() || matches!(ch, '.' | '-') {
            if pending_sep && !out.is_empty() {
                out.push('_');
            }
            pending_sep = false;
            out.push(ch);
        } else {
            pending_sep = true;
        }
    }
    let trimmed = out.trim_matches('_');
    if trimmed.is_empty() {
        "tire".to_string()
    } else {
        trimmed.to_string()
    }
}

/// A rim width for file names: whole inches without decimals (`7`), otherwise the shortest
/// decimal form (`6.5`).
///
/// ```
/// use tirebase_core::naming::rim_label;
/// assert_eq!(rim_label(7.0), "7");
/// assert_eq!(rim_label(6.5), "6.5");
/// ```
pub fn rim_label(rim_in: f64) -> String {
    if (rim_in - rim_in.round()).abs() < 1e-9 {
        format!("{}", rim_in.round() as i64)
    } else {
        format!("{rim_in}")
    }
}

/// The rim part of a file name: `<rim>in` ([`rim_label`]), or `rim-unknown` for a rim width
/// that is not known (0, the store's value for a run whose rim the catalog does not give, or not
/// a positive number): never a made-up `0in`.
///
/// ```
/// use tirebase_core::naming::rim_part;
/// assert_eq!(rim_part(7.0), "7in");
/// assert_eq!(rim_part(0.0), "rim-unknown");
/// ```
pub fn rim_part(rim_in: f64) -> String {
    if rim_in.is_finite() && rim_in > 0.0 {
        format!("{}in", rim_label(rim_in))
    } else {
        UNKNOWN_RIM.to_string()
    }
}

/// The rim part of the file names of a rim that is not known.
pub const UNKNOWN_RIM: &str = "rim-unknown";

/// Stem shared by every per-tire-and-rim file: `<tire>__<rim>in` (`<tire>__rim-unknown` for an
/// unknown rim, [`rim_part`]).
///
/// ```
/// use tirebase_core::naming::tire_rim_stem;
/// assert_eq!(tire_rim_stem("Hoosier 16.0x7.5-10 R25B", 7.0), "hoosier_16.0x7.5-10_r25b__7in");
/// assert_eq!(tire_rim_stem("Hoosier R25B", 0.0), "hoosier_r25b__rim-unknown");
/// ```
pub fn tire_rim_stem(tire: &str, rim_in: f64) -> String {
    format!("{}__{}", sanitize_tire(tire), rim_part(rim_in))
}

/// The `.tir` file name of one tire, rim and nominal pressure (whole kPa, rounded):
/// `<tire>__<rim>in__<P>kPa.tir`. Used by the truth (`truth/tir/`) and the fit output (`tir/`).
///
/// ```
/// use tirebase_core::naming::tir_file_name;
/// assert_eq!(
///     tir_file_name("Hoosier 20.5x7.0-13 R25B", 7.0, 82.7),
///     "hoosier_20.5x7.0-13_r25b__7in__83kPa.tir"
/// );
/// ```
pub fn tir_file_name(tire: &str, rim_in: f64, pressure_kpa: f64) -> String {
    format!(
        "{}__{}kPa.tir",
        tire_rim_stem(tire, rim_in),
        pressure_kpa.round() as i64
    )
}

/// The `.tir` file name of the MF 6.1 model of one tire and rim (one model across every tested
/// pressure): `<tire>__<rim>in__mf61.tir`.
///
/// ```
/// use tirebase_core::naming::mf61_tir_file_name;
/// assert_eq!(
///     mf61_tir_file_name("Hoosier 20.5x7.0-13 R25B", 7.0),
///     "hoosier_20.5x7.0-13_r25b__7in__mf61.tir"
/// );
/// ```
pub fn mf61_tir_file_name(tire: &str, rim_in: f64) -> String {
    format!("{}__mf61.tir", tire_rim_stem(tire, rim_in))
}

/// The MF 6.1 `.tir` file names of a set of (tire, rim in inches), all different, as
/// [`unique_tir_names`] names the per-pressure files: tires whose names sanitise alike at the
/// same rim each get the hash of their exact name after the tire part.
///
/// ```
/// use tirebase_core::naming::unique_mf61_names;
/// let names = unique_mf61_names(&[("Hoosier R25B", 7.0), ("hoosier r25b", 7.0), ("X", 8.0)]);
/// assert_ne!(names[0].0, names[1].0);
/// assert!(names[0].0.ends_with("__7in__mf61.tir") && names[0].1.is_some());
/// assert_eq!(names[2], ("x__8in__mf61.tir".to_string(), None));
/// ```
pub fn unique_mf61_names(groups: &[(&str, f64)]) -> Vec<(String, Option<String>)> {
    let plain: Vec<String> = groups
        .iter()
        .map(|(t, r)| mf61_tir_file_name(t, *r))
        .collect();
    disambiguate(&plain, groups.iter().map(|(t, _)| *t), |tire, i| {
        format!(
            "{}-{}__{}__mf61.tir",
            sanitize_tire(tire),
            name_hash(tire),
            rim_part(groups[i].1)
        )
    })
}

/// Per name: itself, or, where tires share it, `unique(tire, index)` and a note.
fn disambiguate<'a>(
    plain: &[String],
    tires: impl Iterator<Item = &'a str>,
    unique: impl Fn(&str, usize) -> String,
) -> Vec<(String, Option<String>)> {
    let tires: Vec<&str> = tires.collect();
    let mut tires_of: std::collections::BTreeMap<String, Vec<&str>> = Default::default();
    for (name, tire) in plain.iter().zip(&tires) {
        let sharing = tires_of.entry(name.to_lowercase()).or_default();
        if !sharing.contains(tire) {
            sharing.push(tire);
        }
    }
    plain
        .iter()
        .zip(&tires)
        .enumerate()
        .map(|(i, (name, tire))| {
            let sharing = &tires_of[&name.to_lowercase()];
            if sharing.len() < 2 {
                return (name.clone(), None);
            }
            let unique = unique(tire, i);
            let others: Vec<String> = sharing
                .iter()
                .filter(|t| *t != tire)
                .map(|t| format!("{t:?}"))
                .collect();
            let note = format!(
                "tire {tire:?} shares the file name {name} with {}: written as {unique}",
                others.join(", ")
            );
            (unique, Some(note))
        })
        .collect()
}

/// A short stable hash of an exact tire name (FNV-1a 64, 8 hex digits): what tells apart two
/// tires whose names sanitise alike.
fn name_hash(tire: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in tire.as_bytes() {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{:08x}", (h >> 32) ^ (h & 0xffff_ffff))
}

/// The `.tir` file names of a set of groups (tire, rim in inches, nominal pressure in kPa), one
/// per group and all different: [`tir_file_name`], except that groups whose names coincide
/// (tires differing only in case or punctuation at the same rim and pressure) each get the
/// hash of their exact tire name after the tire part (`hoosier_r25b-1a2b3c4d__7in__83kPa.tir`).
/// Returns, per group in the order given, the name and, when it was disambiguated, a note
/// saying so. A function of the set of groups only (any reader of a version can recompute it
/// from the version's groups).
///
/// ```
/// use tirebase_core::naming::unique_tir_names;
/// let names = unique_tir_names(&[
///     ("Hoosier R25B", 7.0, 83.0),
///     ("Hoosier-R25B", 7.0, 69.0),
///     ("hoosier r25b", 7.0, 83.0),
/// ]);
/// assert_eq!(names[1].0, "hoosier-r25b__7in__69kPa.tir");
/// assert!(names[1].1.is_none());
/// assert_ne!(names[0].0, names[2].0);
/// assert!(names[0].0.starts_with("hoosier_r25b-") && names[0].0.ends_with("__7in__83kPa.tir"));
/// assert!(names[2].1.as_deref().unwrap().contains("Hoosier R25B"));
/// ```
pub fn unique_tir_names(groups: &[(&str, f64, f64)]) -> Vec<(String, Option<String>)> {
    let plain: Vec<String> = groups
        .iter()
        .map(|(t, r, p)| tir_file_name(t, *r, *p))
        .collect();
    disambiguate(&plain, groups.iter().map(|(t, _, _)| *t), |tire, i| {
        let (_, rim, p) = groups[i];
        format!(
            "{}-{}__{}__{}kPa.tir",
            sanitize_tire(tire),
            name_hash(tire),
            rim_part(rim),
            p.round() as i64
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run whose rim is not known (rim 0 in the store) gets no made-up `0in` in its names,
    /// disambiguated or not.
    #[test]
    fn an_unknown_rim_is_named_so() {
        assert_eq!(tir_file_name("A", 0.0, 83.0), "a__rim-unknown__83kPa.tir");
        assert_eq!(mf61_tir_file_name("A", 0.0), "a__rim-unknown__mf61.tir");
        let names = unique_tir_names(&[("A b", 0.0, 83.0), ("a_b", 0.0, 83.0)]);
        let mf61 = unique_mf61_names(&[("A b", 0.0), ("a_b", 0.0)]);
        for (n, _) in names.iter().chain(&mf61) {
            assert!(n.contains("__rim-unknown__") && !n.contains("0in"), "{n}");
        }
    }

    #[test]
    fn colliding_names_become_distinct_and_stable() {
        let groups = [
            ("Hoosier R25B", 7.0, 83.0),
            ("HOOSIER R25B", 7.0, 83.0),
            ("Hoosier_R25B", 7.0, 83.0),
            ("Hoosier R25B", 8.0, 83.0),
        ];
        let names = unique_tir_names(&groups);
        let set: std::collections::BTreeSet<&String> = names.iter().map(|(n, _)| n).collect();
        assert_eq!(set.len(), 4, "{names:?}");
        assert!(names[..3].iter().all(|(_, note)| note.is_some()));
        assert_eq!(names[3].0, "hoosier_r25b__8in__83kPa.tir");
        // The same group keeps its name whatever else collides with it.
        let again = unique_tir_names(&groups[..2]);
        assert_eq!(again[0].0, names[0].0);
        // One tire at one rim and pressure twice (not a collision).
        let same = unique_tir_names(&[("A", 7.0, 83.0), ("A", 7.0, 83.0)]);
        assert!(
            same.iter()
                .all(|(n, note)| n == "a__7in__83kPa.tir" && note.is_none())
        );
    }

    #[test]
    fn sanitised_names_use_only_the_allowed_alphabet() {
        for name in [
            "Hoosier 43100 18.0x6.0-10 R20, 7 inch rim",
            "Ä b/c\\d:e",
            "a__b",
            "x",
        ] {
            let s = sanitize_tire(name);
            assert!(
                s.chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || ".-_".contains(c)),
                "{s}"
            );
            assert!(
                !s.contains("__"),
                "{s}: a double underscore would clash with the separator"
            );
        }
    }
}
