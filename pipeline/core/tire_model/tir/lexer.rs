//! Line-level lexing of `.tir` text: what one line is, with comments removed.
//!
//! In: one physical line (line ending already removed). Out: a [`Line`] (blank, comment,
//! section header, table header, `KEY = value`, other text) or a one-line [`LexError`].
//! `$` and `!` start a comment anywhere outside a quoted string. Numbers are parsed by
//! [`parse_number`] (Fortran `D`/`d` exponents accepted, non-finite values refused).
//! Deliberately not here: what a key means or which section accepts it (see `read.rs`).

/// What one line of a `.tir` file is.
#[derive(Clone, Debug, PartialEq)]
pub enum Line<'a> {
    /// Only whitespace.
    Blank,
    /// A whole-line `$` or `!` comment (text after the marker, untrimmed).
    Comment { marker: char, text: &'a str },
    /// `[NAME]`, name as written (trimmed).
    Section(&'a str),
    /// `{a b c}`, the inner text (trimmed).
    TableHeader(&'a str),
    /// `KEY = value`, both trimmed, trailing comment removed.
    KeyValue { key: &'a str, value: RawValue<'a> },
    /// Anything else (a table row, or a wrapped comment), trimmed, comment removed.
    Text(&'a str),
}

/// The value part of `KEY = value`.
#[derive(Clone, Debug, PartialEq)]
pub enum RawValue<'a> {
    /// Nothing after `=`.
    Empty,
    /// A quoted string (quotes removed).
    Quoted(&'a str),
    /// Unquoted text (may be a number, or several words).
    Bare(&'a str),
}

/// Why a line cannot be lexed.
#[derive(Clone, Debug, PartialEq)]
pub enum LexError {
    /// A control character (binary data).
    Binary(u32),
    /// `[` without `]`.
    UnterminatedSection,
    /// `{` without `}`.
    UnterminatedTable,
    /// A quote without its closing quote.
    UnterminatedQuote,
}

/// Characters that end the content of a line: `$` or `!` outside quotes.
fn strip_comment(s: &str) -> Result<&str, LexError> {
    let mut quote: Option<char> = None;
    for (i, ch) in s.char_indices() {
        match quote {
            Some(q) if ch == q => quote = None,
            Some(_) => {}
            None if ch == '\'' || ch == '"' => quote = Some(ch),
            None if ch == '$' || ch == '!' => return Ok(&s[..i]),
            None => {}
        }
    }
    if quote.is_some() {
        return Err(LexError::UnterminatedQuote);
    }
    Ok(s)
}

/// ASCII control characters other than tab, form feed and the DOS end-of-file mark mean the
/// text is not a `.tir` file. (C1 controls are allowed: Windows-1252 punctuation such as 0x92
/// in a comment shows up as U+0092 after Latin-1 decoding.)
fn check_binary(s: &str) -> Result<(), LexError> {
    let binary = |c: char| {
        ((c as u32) < 0x20 && !matches!(c, '\t' | '\x0c' | '\x1a'))
            || c == '\x7f'
            || c == '\u{fffd}'
    };
    match s.chars().find(|&c| binary(c)) {
        Some(c) => Err(LexError::Binary(c as u32)),
        None => Ok(()),
    }
}

/// Lex one line (without its line ending).
pub fn lex(raw: &str) -> Result<Line<'_>, LexError> {
    check_binary(raw)?;
    let s = raw.trim();
    if s.is_empty() {
        return Ok(Line::Blank);
    }
    let first = s.chars().next().unwrap_or(' ');
    if first == '$' || first == '!' {
        return Ok(Line::Comment {
            marker: first,
            text: &s[1..],
        });
    }
    if first == '[' {
        let close = s.find(']').ok_or(LexError::UnterminatedSection)?;
        return Ok(Line::Section(s[1..close].trim()));
    }
    if first == '{' {
        let close = s.find('}').ok_or(LexError::UnterminatedTable)?;
        return Ok(Line::TableHeader(s[1..close].trim()));
    }
    // A quote in a text line without '=' (e.g. a wrapped comment "tyre's width") is not a
    // string: only strip comments quote-aware when the line is a key/value pair.
    let comment = s.find(['$', '!']).unwrap_or(s.len());
    let eq = match s.find('=') {
        Some(eq) if eq < comment => eq,
        _ => {
            let text = s[..comment].trim();
            return Ok(if text.is_empty() {
                Line::Blank
            } else {
                Line::Text(text)
            });
        }
    };
    let key = s[..eq].trim();
    let value = strip_comment(&s[eq + 1..])?.trim();
    Ok(Line::KeyValue {
        key,
        value: raw_value(value)?,
    })
}

/// Split a comment-free value into empty / quoted / bare.
fn raw_value(v: &str) -> Result<RawValue<'_>, LexError> {
    let Some(q) = v.chars().next() else {
        return Ok(RawValue::Empty);
    };
    if q == '\'' || q == '"' {
        let rest = &v[1..];
        let close = rest.find(q).ok_or(LexError::UnterminatedQuote)?;
        return Ok(RawValue::Quoted(&rest[..close]));
    }
    Ok(RawValue::Bare(v))
}

/// Parse a number as `.tir` files write them: `1`, `-.5`, `0.344D+01`, `1e30`.
/// `None` for anything else, including `inf`/`nan` spellings and overflow to infinity.
pub fn parse_number(s: &str) -> Option<f64> {
    let s = s.trim();
    if s.is_empty()
        || !s.bytes().any(|b| b.is_ascii_digit())
        || !s.bytes().all(|b| {
            b.is_ascii_digit() || matches!(b, b'+' | b'-' | b'.' | b'e' | b'E' | b'd' | b'D')
        })
    {
        return None;
    }
    let x: f64 = if s.contains(['d', 'D']) {
        s.replace(['d', 'D'], "e").parse().ok()?
    } else {
        s.parse().ok()?
    };
    x.is_finite().then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_tir_spellings() {
        assert_eq!(parse_number("0.344D+01"), Some(3.44));
        assert_eq!(parse_number("-.100000E+01"), Some(-1.0));
        assert_eq!(parse_number("1.5d-3"), Some(1.5e-3));
        assert_eq!(parse_number("+7"), Some(7.0));
        assert_eq!(parse_number("1e30"), Some(1e30));
        for bad in [
            "", "inf", "NaN", "1e400", "1,5", "e5", "abc", "1.2.3", "--1", "1 2",
        ] {
            assert_eq!(parse_number(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn lines_with_comments_quotes_and_spaces() {
        assert_eq!(
            lex("FNOMIN   = 1100.0   $Nominal wheel load").unwrap(),
            Line::KeyValue {
                key: "FNOMIN",
                value: RawValue::Bare("1100.0")
            }
        );
        assert_eq!(
            lex("TYRESIDE = 'Right $ side' ! where").unwrap(),
            Line::KeyValue {
                key: "TYRESIDE",
                value: RawValue::Quoted("Right $ side")
            }
        );
        assert_eq!(
            lex("COMMENT = two words  $c").unwrap(),
            Line::KeyValue {
                key: "COMMENT",
                value: RawValue::Bare("two words")
            }
        );
        assert_eq!(
            lex("MFSAFE3 =").unwrap(),
            Line::KeyValue {
                key: "MFSAFE3",
                value: RawValue::Empty
            }
        );
        assert_eq!(lex("[ MODEL ]  $x").unwrap(), Line::Section("MODEL"));
        assert_eq!(
            lex("{radial width}").unwrap(),
            Line::TableHeader("radial width")
        );
        assert_eq!(lex(" 1.0  0.4").unwrap(), Line::Text("1.0  0.4"));
        assert_eq!(lex("re's").unwrap(), Line::Text("re's"));
        assert_eq!(lex("[MODEL"), Err(LexError::UnterminatedSection));
        assert_eq!(lex("A = 'open"), Err(LexError::UnterminatedQuote));
        assert_eq!(lex("A = \u{0}"), Err(LexError::Binary(0)));
    }
}
