//! Comma-separated ASCII fields shared by the instrument parsers: a field cursor that never
//! indexes out of bounds, and number parsing that refuses what the instruments never send
//! (non-finite values, empty fields, stray characters).

use core::str::FromStr;

/// Why one field of a sentence was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FieldError {
    /// The sentence ended before this field (0-based index after the header).
    Missing(u8),
    /// The field is present but is not the expected number, flag or text.
    Malformed(u8),
    /// The sentence has more fields than the format defines.
    Extra,
}

/// Splits a sentence body on `sep` and hands out its fields in order, counting them.
pub struct Fields<'a> {
    rest: Option<&'a [u8]>,
    sep: u8,
    index: u8,
}

impl<'a> Fields<'a> {
    /// Fields of `body`, separated by `sep`.
    pub fn new(body: &'a [u8], sep: u8) -> Self {
        Self {
            rest: Some(body),
            sep,
            index: 0,
        }
    }

    /// Index of the next field to be read.
    pub fn index(&self) -> u8 {
        self.index
    }

    /// The next raw field, or `Missing` when the sentence has ended.
    pub fn next_raw(&mut self) -> Result<&'a [u8], FieldError> {
        let idx = self.index;
        let rest = self.rest.ok_or(FieldError::Missing(idx))?;
        self.index = self.index.saturating_add(1);
        match rest.iter().position(|&b| b == self.sep) {
            Some(pos) => {
                let (head, tail) = rest.split_at(pos);
                self.rest = tail.get(1..);
                Ok(head)
            }
            None => {
                self.rest = None;
                Ok(rest)
            }
        }
    }

    /// The next field as text with surrounding blanks removed (PD6 pads with spaces).
    pub fn next_str(&mut self) -> Result<&'a str, FieldError> {
        let idx = self.index;
        let raw = self.next_raw()?;
        let s = core::str::from_utf8(raw).map_err(|_| FieldError::Malformed(idx))?;
        Ok(s.trim_matches(' '))
    }

    /// The next field padded to exactly `width` bytes, as fixed-width formats print it:
    /// spaces, then the value without blanks. The value's text, or `Malformed`.
    pub fn next_padded(&mut self, width: usize) -> Result<&'a str, FieldError> {
        let idx = self.index;
        let raw = self.next_raw()?;
        let value = raw
            .iter()
            .position(|&b| b != b' ')
            .and_then(|start| raw.get(start..))
            .filter(|v| raw.len() == width && !v.contains(&b' '))
            .ok_or(FieldError::Malformed(idx))?;
        core::str::from_utf8(value).map_err(|_| FieldError::Malformed(idx))
    }

    /// The next field as a finite `f32`.
    pub fn next_f32(&mut self) -> Result<f32, FieldError> {
        let idx = self.index;
        parse_f32(self.next_str()?).ok_or(FieldError::Malformed(idx))
    }

    /// The next field as a fixed-point decimal printed with exactly `decimals` digits after
    /// the point (an optional `-`, digits without a superfluous leading zero, `.`,
    /// `decimals` digits): its value times 10^`decimals` and whether it had a minus sign.
    /// Integer arithmetic only (no software floating point on an FPU-less or f32-only MCU).
    pub fn next_fixed(&mut self, decimals: usize) -> Result<(u64, bool), FieldError> {
        let idx = self.index;
        fixed_point(self.next_str()?, decimals).ok_or(FieldError::Malformed(idx))
    }

    /// The next field as a finite `f32` printed with exactly `decimals` digits after the
    /// point (see [`Fields::next_fixed`]). The value is the integer over 10^`decimals`, both
    /// exact in `f32` up to 2^24 and 10^10, so the one rounded division gives the nearest
    /// `f32`, as `f32::from_str` does; larger values go through `f32::from_str`.
    pub fn next_fixed_f32(&mut self, decimals: usize) -> Result<f32, FieldError> {
        let idx = self.index;
        let s = self.next_str()?;
        let (units, negative) = fixed_point(s, decimals).ok_or(FieldError::Malformed(idx))?;
        let magnitude = match POW10_F32.get(decimals) {
            Some(&scale) if units < (1 << 24) => units as f32 / scale,
            _ => parse_f32(s.strip_prefix('-').unwrap_or(s)).ok_or(FieldError::Malformed(idx))?,
        };
        Ok(if negative { -magnitude } else { magnitude })
    }

    /// The next field as a finite `f64`.
    pub fn next_f64(&mut self) -> Result<f64, FieldError> {
        let idx = self.index;
        parse_f64(self.next_str()?).ok_or(FieldError::Malformed(idx))
    }

    /// The next field as an integer of type `T` (an optional sign, then digits only).
    pub fn next_int<T: FromStr>(&mut self) -> Result<T, FieldError> {
        let idx = self.index;
        let s = self.next_str()?;
        parse_int(s).ok_or(FieldError::Malformed(idx))
    }

    /// The next field as one of two flag letters: `Ok(true)` for `yes`, `Ok(false)` for `no`.
    pub fn next_flag(&mut self, yes: u8, no: u8) -> Result<bool, FieldError> {
        let idx = self.index;
        match self.next_str()?.as_bytes() {
            [b] if *b == yes => Ok(true),
            [b] if *b == no => Ok(false),
            _ => Err(FieldError::Malformed(idx)),
        }
    }

    /// `Ok` when every field has been read, `Extra` otherwise.
    pub fn end(&self) -> Result<(), FieldError> {
        match self.rest {
            None => Ok(()),
            Some(_) => Err(FieldError::Extra),
        }
    }
}

/// Powers of ten exact in `f32` (10^10 = 2^10 x 9,765,625, under 2^24 x 2^10).
const POW10_F32: [f32; 11] = [
    1.0,
    10.0,
    100.0,
    1_000.0,
    10_000.0,
    100_000.0,
    1_000_000.0,
    10_000_000.0,
    100_000_000.0,
    1_000_000_000.0,
    10_000_000_000.0,
];

/// `s` as `[-] digits . decimals-digits`, as C's `%.Nf` prints it: the digits as one
/// integer and whether the sign was `-`. `None` for anything else: a `+`, no digit before
/// the point, a leading zero before another digit (`01.250`), another count of decimals, or
/// more than 19 digits.
pub fn fixed_point(s: &str, decimals: usize) -> Option<(u64, bool)> {
    let (negative, digits) = match s.as_bytes() {
        [b'-', rest @ ..] => (true, rest),
        rest => (false, rest),
    };
    let point = digits.iter().position(|&b| b == b'.')?;
    let (int, frac) = digits.split_at(point);
    let frac = frac.get(1..)?;
    if int.is_empty() || frac.len() != decimals || matches!(int, [b'0', _, ..]) {
        return None;
    }
    let mut units = 0_u64;
    for &b in int.iter().chain(frac) {
        if !b.is_ascii_digit() {
            return None;
        }
        units = units.checked_mul(10)?.checked_add(u64::from(b - b'0'))?;
    }
    Some((units, negative))
}

/// Characters a decimal number in these formats may contain: digits, sign, point, exponent.
fn is_number_text(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_digit() || matches!(b, b'+' | b'-' | b'.' | b'e' | b'E'))
        && s.bytes().any(|b| b.is_ascii_digit())
}

/// A finite `f32` from decimal text; `None` for anything else (including "inf" and "NaN",
/// which `f32::from_str` would accept).
pub fn parse_f32(s: &str) -> Option<f32> {
    if !is_number_text(s) {
        return None;
    }
    s.parse::<f32>().ok().filter(|v| v.is_finite())
}

/// A finite `f64` from decimal text, as [`parse_f32`].
pub fn parse_f64(s: &str) -> Option<f64> {
    if !is_number_text(s) {
        return None;
    }
    s.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// An integer from an optional sign and digits; `None` otherwise or on overflow.
pub fn parse_int<T: FromStr>(s: &str) -> Option<T> {
    let digits = s.strip_prefix(['+', '-']).unwrap_or(s);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    s.parse::<T>().ok()
}

/// The value of one ASCII hex digit (either case).
pub fn hex_digit(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'a'..=b'f' => Some(b - b'a' + 10),
        b'A'..=b'F' => Some(b - b'A' + 10),
        _ => None,
    }
}

/// Splits `line` at its last `*` into the covered text and the two hex digits after it.
/// `None` when there is no `*` or it is not followed by exactly two hex digits.
pub fn split_checksum(line: &[u8]) -> Option<(&[u8], u8)> {
    let star = line.iter().rposition(|&b| b == b'*')?;
    let (body, tail) = line.split_at(star);
    match tail {
        [_, hi, lo] => Some((body, (hex_digit(*hi)? << 4) | hex_digit(*lo)?)),
        _ => None,
    }
}

/// `line` without its trailing CR / LF characters.
pub fn trim_line_end(line: &[u8]) -> &[u8] {
    let end = line
        .iter()
        .rposition(|&b| b != b'\r' && b != b'\n')
        .map_or(0, |p| p + 1);
    line.get(..end).unwrap_or(&[])
}
