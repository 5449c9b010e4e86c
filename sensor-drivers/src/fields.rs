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

    /// The next field as a finite `f32`.
    pub fn next_f32(&mut self) -> Result<f32, FieldError> {
        let idx = self.index;
        parse_f32(self.next_str()?).ok_or(FieldError::Malformed(idx))
    }

    /// The next field as a finite `f32` printed with exactly `decimals` digits after the
    /// point (an optional sign, digits, `.`, `decimals` digits).
    pub fn next_fixed_f32(&mut self, decimals: usize) -> Result<f32, FieldError> {
        let idx = self.index;
        let s = self.next_str()?;
        let digits = s.strip_prefix(['+', '-']).unwrap_or(s);
        let ok = match digits.split_once('.') {
            Some((int, frac)) => {
                !int.is_empty()
                    && int.bytes().all(|b| b.is_ascii_digit())
                    && frac.len() == decimals
                    && frac.bytes().all(|b| b.is_ascii_digit())
            }
            None => false,
        };
        if !ok {
            return Err(FieldError::Malformed(idx));
        }
        parse_f32(s).ok_or(FieldError::Malformed(idx))
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
