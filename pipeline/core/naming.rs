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

/// Stem shared by every per-tire-and-rim file: `<tire>__<rim>in`.
///
/// ```
/// use tirebase_core::naming::tire_rim_stem;
/// assert_eq!(tire_rim_stem("Hoosier 16.0x7.5-10 R25B", 7.0), "hoosier_16.0x7.5-10_r25b__7in");
/// ```
pub fn tire_rim_stem(tire: &str, rim_in: f64) -> String {
    format!("{}__{}in", sanitize_tire(tire), rim_label(rim_in))
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

#[cfg(test)]
mod tests {
    use super::*;

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
