//! Exact, allocation-free parsing of the fixed-decimal numbers in `.dat` cells.
//!
//! In: the bytes of one cell. Out: the `f64` that `str::parse::<f64>` would give (bit for bit),
//! or `None` where it would fail. TIRF cells are short fixed-decimal numbers (`-1234.56`), which
//! take a fast path: the digits form an integer mantissa `m <= 2^53` and a power of ten `10^k`
//! with `k <= 22`; both are exact in `f64`, so the single IEEE division `m / 10^k` is the
//! correctly rounded value, the same one the standard library computes (Clinger's fast path).
//! Everything else (exponents, long mantissas, `inf`, `NaN`) falls back to the standard parser.
//! Deliberately not here: rejecting NaN/infinity (the caller decides) and trimming.

/// Powers of ten exactly representable in `f64`.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Largest mantissa for which every integer up to it is exact in `f64`.
const MAX_EXACT_MANTISSA: u64 = 1 << 53;

/// Parse a cell exactly as `std::str::from_utf8(cell)?.parse::<f64>()` would.
#[inline]
pub fn parse_f64(cell: &[u8]) -> Option<f64> {
    match parse_fixed_decimal(cell) {
        Some(value) => Some(value),
        None => std::str::from_utf8(cell).ok()?.parse::<f64>().ok(),
    }
}

/// The fast path: `[+-]?digits[.digits]` (at least one digit) with a mantissa `<= 2^53` and at
/// most 22 decimals; `None` for anything else, which then needs the full parser.
#[inline]
pub fn parse_fixed_decimal(cell: &[u8]) -> Option<f64> {
    let (negative, body) = match cell.first()? {
        b'-' => (true, &cell[1..]),
        b'+' => (false, &cell[1..]),
        _ => (false, cell),
    };
    let mut mantissa: u64 = 0;
    let mut digits = 0usize;
    let mut decimals = 0usize;
    let mut seen_point = false;
    for &byte in body {
        match byte {
            b'0'..=b'9' => {
                if digits == 19 {
                    return None;
                }
                mantissa = mantissa * 10 + u64::from(byte - b'0');
                digits += 1;
                decimals += usize::from(seen_point);
            }
            b'.' if !seen_point => seen_point = true,
            _ => return None,
        }
    }
    if digits == 0 || mantissa > MAX_EXACT_MANTISSA || decimals >= POW10.len() {
        return None;
    }
    let magnitude = mantissa as f64 / POW10[decimals];
    Some(if negative { -magnitude } else { magnitude })
}

/// Scan one cell of a tab-separated line starting at `start`, parsing on the way.
///
/// Returns the index where the scan stopped and, when the cell is a plain fixed-decimal number
/// (`-?digits[.digits]`) ending at a tab, CR, LF or the end of `bytes`, its value (identical to
/// `str::parse::<f64>` of the cell; the index is then the delimiter's). `None` means "use the
/// slow path on this cell": the caller finds the real end of the cell (the next tab or line
/// end) and calls [`parse_f64`] on it.
///
/// With at least 24 bytes left, the digit runs before and after the point are
/// found and converted eight bytes at a time (SIMD within a register); near the end of the
/// input, or for runs of eight or more digits, a byte loop does the same.
#[inline(always)]
pub fn scan_fixed_decimal(bytes: &[u8], start: usize) -> (usize, Option<f64>) {
    if bytes.len() - start >= SWAR_LOOKAHEAD
        && let Some(scanned) = scan_swar(bytes, start)
    {
        return scanned;
    }
    scan_bytewise(bytes, start)
}

/// Bytes the SWAR path may read past `start` (sign, 8-byte integer load, point, 8-byte
/// fraction load, delimiter).
const SWAR_LOOKAHEAD: usize = 24;

/// `10^k` as integers, for joining the integer and fraction digit runs.
const POW10_U64: [u64; 8] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000];

/// The SWAR path; `None` when a digit run is 8 bytes or longer (the byte loop handles it).
#[inline(always)]
fn scan_swar(bytes: &[u8], start: usize) -> Option<(usize, Option<f64>)> {
    let mut i = start;
    let negative = bytes[i] == b'-';
    i += usize::from(negative);
    let (int_digits, int_value) = digit_run8(bytes, i)?;
    i += int_digits;
    let (frac_digits, frac_value) = if bytes[i] == b'.' {
        let run = digit_run8(bytes, i + 1)?;
        i += 1 + run.0;
        run
    } else {
        (0, 0)
    };
    let at_delimiter = matches!(bytes[i], b'\t' | b'\n' | b'\r');
    if !at_delimiter || int_digits + frac_digits == 0 {
        return Some((i, None));
    }
    // At most 7 + 7 digits: below 2^53, so exact.
    let mantissa = int_value * POW10_U64[frac_digits] + frac_value;
    let magnitude = mantissa as f64 / POW10[frac_digits];
    Some((i, Some(if negative { -magnitude } else { magnitude })))
}

/// Length (0-7) and value of the run of ASCII digits at `bytes[at..]`, from one 8-byte load;
/// `None` if all 8 bytes are digits. Needs `at + 8 <= bytes.len()`.
#[inline(always)]
fn digit_run8(bytes: &[u8], at: usize) -> Option<(usize, u64)> {
    let word = u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
    // Digits become 0..=9; the top bit of each byte flags "not a digit" (a carry out of a
    // flagged byte can only disturb later bytes, and only the first flag is used).
    let values = word ^ 0x3030_3030_3030_3030;
    let not_digit = (values.wrapping_add(0x7676_7676_7676_7676) | values) & 0x8080_8080_8080_8080;
    if not_digit == 0 {
        return None;
    }
    let len = (not_digit.trailing_zeros() / 8) as usize;
    if len == 0 {
        return Some((0, 0));
    }
    // Move the run to the top bytes (the first character is the lowest byte), zeros below act
    // as leading zero digits, then combine eight digits with three multiplications.
    let aligned = values << (8 * (8 - len));
    Some((len, combine_8_digits(aligned)))
}

/// Eight digit values (first digit in the lowest byte) -> their decimal value.
#[inline(always)]
fn combine_8_digits(digits: u64) -> u64 {
    const MASK: u64 = 0x0000_00FF_0000_00FF;
    const MUL1: u64 = 0x000F_4240_0000_0064; // 100 + (1_000_000 << 32)
    const MUL2: u64 = 0x0000_2710_0000_0001; // 1 + (10_000 << 32)
    let pairs = digits.wrapping_mul(10).wrapping_add(digits >> 8);
    let high = (pairs & MASK).wrapping_mul(MUL1);
    let low = ((pairs >> 16) & MASK).wrapping_mul(MUL2);
    u64::from((high.wrapping_add(low) >> 32) as u32)
}

/// The byte-at-a-time scanner (same contract as [`scan_fixed_decimal`]).
#[inline]
pub(crate) fn scan_bytewise(bytes: &[u8], start: usize) -> (usize, Option<f64>) {
    let len = bytes.len();
    let mut i = start;
    let negative = i < len && bytes[i] == b'-';
    i += usize::from(negative);
    let mut mantissa: u64 = 0;
    let mut digits = 0usize;
    let mut point_at = usize::MAX;
    while i < len {
        let byte = bytes[i];
        let digit = byte.wrapping_sub(b'0');
        if digit < 10 {
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(digit));
            digits += 1;
        } else if byte == b'.' && point_at == usize::MAX {
            point_at = i + 1;
        } else {
            break;
        }
        i += 1;
    }
    let at_delimiter = i == len || matches!(bytes[i], b'\t' | b'\n' | b'\r');
    let decimals = if point_at == usize::MAX {
        0
    } else {
        i - point_at
    };
    if !at_delimiter
        || digits == 0
        || digits > 19
        || mantissa > MAX_EXACT_MANTISSA
        || decimals >= POW10.len()
    {
        return (i, None);
    }
    let magnitude = mantissa as f64 / POW10[decimals];
    (i, Some(if negative { -magnitude } else { magnitude }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn std_parse(text: &str) -> Option<f64> {
        text.parse::<f64>().ok()
    }

    fn same(a: Option<f64>, b: Option<f64>) -> bool {
        match (a, b) {
            (Some(x), Some(y)) => x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
            (None, None) => true,
            _ => false,
        }
    }

    #[test]
    fn edge_cells_agree_with_std() {
        let cells = [
            "0",
            "-0",
            "+0",
            "0.000",
            "-0.000",
            "1.",
            ".5",
            "-.5",
            ".",
            "-",
            "+",
            "",
            "1..2",
            "1.2.3",
            "00012.50",
            "9007199254740992",
            "9007199254740993",
            "0.1",
            "0.3",
            "-1234.56",
            "123456789012345678901234",
            "1e5",
            "1E-3",
            "inf",
            "-inf",
            "NaN",
            "nan",
            "infinity",
            " 1",
            "1 ",
            "1,5",
            "0x10",
            "1_000",
            "0.00000000000000000000001",
            "4.9e-324",
            "1.7976931348623157e308",
            "99999999999999999999",
            "+-1",
            "--1",
            "1-",
        ];
        for cell in cells {
            assert!(
                same(parse_f64(cell.as_bytes()), std_parse(cell)),
                "{cell:?}: ours {:?} std {:?}",
                parse_f64(cell.as_bytes()),
                std_parse(cell)
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]

        /// Fixed-decimal cells like TIRF writes, with any number of decimals and digits.
        #[test]
        fn fixed_decimal_cells_match_std(
            negative in any::<bool>(),
            int_part in 0u64..10_000_000_000,
            frac in proptest::collection::vec(0u8..10, 0..12),
            point in any::<bool>(),
        ) {
            let mut cell = String::new();
            if negative { cell.push('-'); }
            cell.push_str(&int_part.to_string());
            if point || !frac.is_empty() { cell.push('.'); }
            for d in &frac { cell.push(char::from(b'0' + d)); }
            prop_assert!(same(parse_f64(cell.as_bytes()), std_parse(&cell)), "{}", cell);
        }

        /// Any short string over the characters that occur in numbers.
        #[test]
        fn arbitrary_number_like_strings_match_std(cell in "[-+0-9.eEinfaINFA]{0,30}") {
            prop_assert!(same(parse_f64(cell.as_bytes()), std_parse(&cell)), "{}", cell);
        }

        /// The fused scanner agrees with the cell parser wherever it claims a value, and stops
        /// exactly at the delimiter.
        #[test]
        fn scanner_matches_cell_parser(cell in "-?[0-9]{0,21}\\.?[0-9]{0,12}|[-+0-9.eE ]{0,24}", delimiter in "[\t\n\r]?") {
            // Short input takes the byte loop, padded input the SWAR path: both must agree with
            // std wherever they give a value, and with each other.
            let short = format!("{cell}{delimiter}rest");
            let padded = format!("{cell}{delimiter}rest of a long line\t1.0\t2.0");
            for text in [&short, &padded] {
                let (end, value) = scan_fixed_decimal(text.as_bytes(), 0);
                if let Some(v) = value {
                    prop_assert_eq!(end, cell.len());
                    prop_assert!(same(Some(v), std_parse(&cell)), "{}", cell);
                }
            }
            let swar = scan_fixed_decimal(padded.as_bytes(), 0);
            let bytewise = scan_bytewise(padded.as_bytes(), 0);
            if swar.1.is_some() || bytewise.1.is_some() {
                prop_assert!(same(swar.1, bytewise.1), "{}: {:?} {:?}", cell, swar, bytewise);
                prop_assert_eq!(swar.0, bytewise.0);
            }
            let at_end = scan_fixed_decimal(cell.as_bytes(), 0).1;
            prop_assert!(at_end.is_none() || same(at_end, std_parse(&cell)), "{}", cell);
        }

        /// Every finite f64 printed by Rust (shortest round-trip and fixed decimals).
        #[test]
        fn printed_doubles_match_std(bits in any::<u64>(), decimals in 0usize..8) {
            let value = f64::from_bits(bits);
            for cell in [format!("{value}"), format!("{value:.decimals$}")] {
                prop_assert!(same(parse_f64(cell.as_bytes()), std_parse(&cell)), "{}", cell);
            }
        }
    }
}
