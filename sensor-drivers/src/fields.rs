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

    /// The next field as a finite `f32` read by [`parse_f32_compact`] (no `f32::from_str`:
    /// the instrument parsers of a small MCU's image).
    pub fn next_f32_compact(&mut self) -> Result<f32, FieldError> {
        let idx = self.index;
        parse_f32_compact(self.next_str()?).ok_or(FieldError::Malformed(idx))
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
    /// `f32`, as `f32::from_str` does; larger values through [`nearest_f32`] (the same).
    pub fn next_fixed_f32(&mut self, decimals: usize) -> Result<f32, FieldError> {
        let idx = self.index;
        let s = self.next_str()?;
        let (units, negative) = fixed_point(s, decimals).ok_or(FieldError::Malformed(idx))?;
        let magnitude = match POW10_F32.get(decimals) {
            Some(&scale) if units < (1 << 24) => units as f32 / scale,
            _ => {
                nearest_f32(units, -(decimals.min(19) as i32)).ok_or(FieldError::Malformed(idx))?
            }
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

/// A finite `f32` from decimal text (`[+-]digits[.digits][(e|E)[+-]digits]`), without
/// `f32::from_str`, whose algorithm links 18 KiB of code and tables (more than half of a
/// 32 KiB node image). The significand's digits, at most 19 without the leading zeros (else
/// `None`), make an integer `m` and the point and the exponent a power of ten `e`: for
/// `|e| <= 19` the value is the nearest `f32` to `m x 10^e`, as `f32::from_str` gives it
/// (integer arithmetic, [`nearest_f32`]); beyond, that of `10^+-19` is scaled by the rest in
/// `f32` steps, a few units in the last place from the nearest. `None` for anything else,
/// and for a value beyond `f32::MAX`.
pub fn parse_f32_compact(s: &str) -> Option<f32> {
    let (negative, body) = match s.as_bytes() {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        rest => (false, rest),
    };
    let (significand, exponent) = match body.iter().position(|&b| matches!(b, b'e' | b'E')) {
        Some(i) => (body.get(..i)?, Some(body.get(i + 1..)?)),
        None => (body, None),
    };
    let (mut m, mut digits, mut e10) = (0_u64, 0_u32, 0_i32);
    let (mut point, mut any_digit) = (false, false);
    for &b in significand {
        match b {
            b'.' if !point => point = true,
            b'0'..=b'9' => {
                any_digit = true;
                if m != 0 || b != b'0' {
                    if digits == 19 {
                        return None;
                    }
                    m = m * 10 + u64::from(b - b'0');
                    digits += 1;
                }
                if point {
                    e10 -= 1;
                }
            }
            _ => return None,
        }
    }
    if !any_digit {
        return None;
    }
    if let Some(e) = exponent {
        let (e_negative, e_digits) = match e {
            [b'-', rest @ ..] => (true, rest),
            [b'+', rest @ ..] => (false, rest),
            rest => (false, rest),
        };
        if e_digits.is_empty() || e_digits.len() > 4 {
            return None;
        }
        let mut v = 0_i32;
        for &b in e_digits {
            if !b.is_ascii_digit() {
                return None;
            }
            v = v * 10 + i32::from(b - b'0');
        }
        e10 += if e_negative { -v } else { v };
    }
    let magnitude = scale_pow10(m, e10)?;
    Some(if negative { -magnitude } else { magnitude })
}

/// `10^k` for `k` in `0..=19` (all of them below `u64::MAX`).
const POW10_U64: [u64; 20] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
    10_000_000_000,
    100_000_000_000,
    1_000_000_000_000,
    10_000_000_000_000,
    100_000_000_000_000,
    1_000_000_000_000_000,
    10_000_000_000_000_000,
    100_000_000_000_000_000,
    1_000_000_000_000_000_000,
    10_000_000_000_000_000_000,
];

/// `2^-n` for `n` in `0..=126` (a normal `f32`).
const fn pow2_neg(n: u32) -> f32 {
    f32::from_bits((127 - n) << 23)
}

/// The nearest `f32` to `m x 10^e10` for `|e10| <= 19` (else `None`), by integers: for
/// `e10 >= 0` the product exactly in `u128`, converted once (round to nearest, ties to
/// even); for `e10 < 0` the quotient of `m x 2^s` (its top bit at bit 127) by `10^-e10`,
/// 64 bits or more, with a sticky bit for the remainder, converted once and scaled back by
/// two exact powers of two. Infinite (beyond `f32::MAX`) is `None`.
pub fn nearest_f32(m: u64, e10: i32) -> Option<f32> {
    let k = e10.unsigned_abs() as usize;
    let pow = u128::from(*POW10_U64.get(k)?);
    if m == 0 {
        return Some(0.0);
    }
    let x = match POW10_F32.get(k) {
        // Both exact in `f32`: one rounded operation is the nearest (the common case, and
        // the cheap one: no 128-bit division on a 32-bit MCU).
        Some(&p) if m < (1 << 24) => {
            if e10 >= 0 {
                m as f32 * p
            } else {
                m as f32 / p
            }
        }
        _ if e10 >= 0 => (u128::from(m) * pow) as f32,
        _ => {
            let s = m.leading_zeros() + 64;
            let num = u128::from(m) << s;
            let q = num / pow;
            let sticky = u128::from(q * pow != num);
            let h = s / 2;
            ((q | sticky) as f32) * pow2_neg(h) * pow2_neg(s - h)
        }
    };
    x.is_finite().then_some(x)
}

/// `m x 10^e10` as a finite `f32` (see [`parse_f32_compact`]).
fn scale_pow10(m: u64, e10: i32) -> Option<f32> {
    if m == 0 || e10 < -80 {
        // Below the smallest subnormal whatever the 19 digits: zero, as `f32::from_str`.
        return Some(0.0);
    }
    if e10 > 40 {
        return None;
    }
    let mut x = nearest_f32(m, e10.clamp(-19, 19))?;
    let mut e = e10 - e10.clamp(-19, 19);
    let pow = |k: i32| POW10_F32.get(k.unsigned_abs() as usize).copied();
    while e > 0 {
        let k = e.min(10);
        x *= pow(k)?;
        e -= k;
    }
    while e < 0 {
        let k = e.max(-10);
        x /= pow(k)?;
        e -= k;
    }
    x.is_finite().then_some(x)
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
