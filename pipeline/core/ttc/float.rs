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
            "0", "-0", "+0", "0.000", "-0.000", "1.", ".5", "-.5", ".", "-", "+", "", "1..2",
            "1.2.3", "00012.50", "9007199254740992", "9007199254740993", "0.1", "0.3", "-1234.56",
            "123456789012345678901234", "1e5", "1E-3", "inf", "-inf", "NaN", "nan", "infinity",
            " 1", "1 ", "1,5", "0x10", "1_000", "0.00000000000000000000001", "4.9e-324",
            "1.7976931348623157e308", "99999999999999999999", "+-1", "--1", "1-",
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
