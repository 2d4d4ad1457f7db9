//! Text fields of run files (tire names, headers) as valid UTF-8.
//!
//! In: the bytes of a header line or a text variable. Out: a `String`. Files written on Windows
//! carry tire names in Windows-1252 (or Latin-1): those bytes are decoded as such instead of
//! becoming U+FFFD, which would then be written into `.tir` files and store paths. Deliberately
//! not here: parsing the fields.

use std::borrow::Cow;

/// Windows-1252's characters for the bytes 0x80..=0x9F (Latin-1 has C1 controls there; the
/// five bytes Windows-1252 leaves undefined keep their Latin-1 code point).
const CP1252_HIGH: [char; 32] = [
    '\u{20AC}', '\u{0081}', '\u{201A}', '\u{0192}', '\u{201E}', '\u{2026}', '\u{2020}', '\u{2021}',
    '\u{02C6}', '\u{2030}', '\u{0160}', '\u{2039}', '\u{0152}', '\u{008D}', '\u{017D}', '\u{008F}',
    '\u{0090}', '\u{2018}', '\u{2019}', '\u{201C}', '\u{201D}', '\u{2022}', '\u{2013}', '\u{2014}',
    '\u{02DC}', '\u{2122}', '\u{0161}', '\u{203A}', '\u{0153}', '\u{009D}', '\u{017E}', '\u{0178}',
];

/// `bytes` as text: UTF-8 when they are valid UTF-8, else Windows-1252 (which reads Latin-1
/// text the same way outside 0x80..=0x9F). The flag says whether the fallback was used.
///
/// ```
/// use tirebase_core::ttc::text::decode_text;
/// assert_eq!(decode_text(b"Pirelli \xc3\x98 10").0, "Pirelli Ø 10");
/// assert_eq!(decode_text(b"Pirelli \xd8 10"), ("Pirelli Ø 10".into(), true));
/// assert_eq!(decode_text(b"Hoosier \x96 R25B").0, "Hoosier – R25B");
/// ```
pub fn decode_text(bytes: &[u8]) -> (Cow<'_, str>, bool) {
    match std::str::from_utf8(bytes) {
        Ok(s) => (Cow::Borrowed(s), false),
        Err(_) => (
            Cow::Owned(
                bytes
                    .iter()
                    .map(|&b| match b {
                        0x80..=0x9F => CP1252_HIGH[usize::from(b - 0x80)],
                        _ => char::from(b),
                    })
                    .collect(),
            ),
            true,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ttc::dat::read_dat;
    use crate::ttc::example::{ExampleStyle, example_dat};

    #[test]
    fn issue20_a_windows_1252_tire_name_is_decoded_not_replaced() {
        let utf8 = example_dat(ExampleStyle::R9Si, 5, false);
        let name = b"Example 16.0X7.5-10, R20, C2000";
        let at = utf8.windows(name.len()).position(|w| w == name).unwrap();
        // The same file with the tire named "Pirelli Ø 10" in Windows-1252 (Ø = 0xD8).
        let mut legacy = utf8[..at].to_vec();
        legacy.extend_from_slice(b"Pirelli \xd8 10");
        legacy.extend_from_slice(&utf8[at + name.len()..]);
        let run = read_dat(&legacy, "x.dat").unwrap();
        assert_eq!(run.meta.tire_name.as_deref(), Some("Pirelli Ø 10"));
        assert!(
            run.meta.warnings.iter().any(|w| w.contains("Windows-1252")),
            "{:?}",
            run.meta.warnings
        );
    }

    #[test]
    fn every_byte_decodes_to_a_character_and_utf8_passes_through() {
        let all: Vec<u8> = (0u8..=255).collect();
        let (text, fallback) = decode_text(&all);
        assert!(fallback);
        assert_eq!(text.chars().count(), 256);
        assert!(!text.contains('\u{FFFD}'));
        assert_eq!(decode_text("Ä ø €".as_bytes()), ("Ä ø €".into(), false));
    }
}
