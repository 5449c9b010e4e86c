//! PD6: the ASCII speed-log format of Teledyne RD Instruments DVLs, also sent by Nortek DVLs
//! and by Water Linked's (serial protocol number 2).
//!
//! One ensemble is a group of lines, each `:` + two letters + comma-separated fields + CR LF;
//! fields are padded with spaces to fixed widths. PD6 has **no checksum**: a corrupted digit
//! is a different valid number. What the format allows is checked: each field's width (the
//! `±XXXXX` and `DDDD.DD` of the definitions below, so a deleted or inserted character is
//! refused), its sign and decimals, the ranges, and across one ensemble the velocity groups
//! that are good agreeing in magnitude ([`BottomTrack::frames_agree`]: the ship and earth
//! frames are rotations of the instrument frame). Velocities are integers in mm/s; -32768
//! means "no value".
//!
//! - `:BI,±XXXXX,±YYYYY,±ZZZZZ,±EEEEE,S`: bottom-track velocity in the instrument (Water
//!   Linked: vehicle) frame, x, y, z and error velocity, status `A` good / `V` bad.
//! - `:BS,±TTTTT,±LLLLL,±NNNNN,S`: bottom-track velocity in the ship frame: transverse
//!   (+ port to starboard), longitudinal (+ aft to forward), normal (+ away from the bottom).
//! - `:BE,±EEEEE,±NNNNN,±UUUUU,S`: bottom-track velocity in the earth frame: east, north, up.
//! - `:BD,±EEEEEEEE.EE,±NNNNNNNN.NN,±UUUUUUUU.UU,DDDD.DD,TTT.TT`: distance made good east,
//!   north, up (m), range to the bottom (m), time since the last good velocity (s).
//! - `:TS,YYMMDDHHmmsshh,SS.S,+TT.T,DDDD.D,CCCC.C,BBB`: time stamp (hundredths of a second),
//!   salinity (ppt), temperature (degC), transducer depth (m), speed of sound (m/s), built-in
//!   test result.
//!
//! Other groups (`:SA` attitude, `:WI` / `:WS` / `:WE` / `:WD` water-mass) are recognised and
//! returned as [`Line::Other`]. [`Ensemble`] collects one ensemble's bottom-track lines
//! and completes it at `:BD`, the last bottom-track line of an ensemble.

use crate::fields::{fixed_point, parse_int, trim_line_end, FieldError, Fields};

/// The value PD6 sends for a velocity it does not have.
pub const MISSING_MM_S: i32 = -32768;

/// Why a PD6 line was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pd6Error {
    /// The line does not start with `:` and two upper-case letters.
    NoStart,
    /// A field is missing, malformed or extra.
    Field(FieldError),
    /// A velocity outside +-32767 mm/s (and not -32768), or a distance or time outside the
    /// field's width.
    OutOfRange,
}

impl From<FieldError> for Pd6Error {
    fn from(e: FieldError) -> Self {
        Pd6Error::Field(e)
    }
}

/// One velocity group (`:BI`, `:BS` or `:BE`): three components in m/s, `None` where PD6 sent
/// -32768, and the status letter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityGroup {
    /// The three components (m/s), in the group's own order (see the module documentation).
    pub velocity_m_s: [Option<f32>; 3],
    /// Error velocity (m/s), sent by `:BI` only.
    pub error_m_s: Option<f32>,
    /// `true` for status `A` (good), `false` for `V` (bad).
    pub good: bool,
}

impl VelocityGroup {
    /// The three components when the status is good and none is missing.
    pub fn usable(&self) -> Option<[f32; 3]> {
        match (self.good, self.velocity_m_s) {
            (true, [Some(a), Some(b), Some(c)]) => Some([a, b, c]),
            _ => None,
        }
    }
}

/// `:BD`: bottom-track distance made good and range to the bottom.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BottomDistance {
    /// Distance made good east, north, up (m).
    pub distance_m: [f64; 3],
    /// Range to the bottom (m).
    pub range_to_bottom_m: f32,
    /// Time since the last good velocity estimate (s).
    pub since_good_s: f32,
}

/// `:TS`: the ensemble's time stamp and water properties.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimingScaling {
    /// Year (two digits), month, day, hour, minute, second, hundredths.
    pub stamp: [u8; 7],
    /// Salinity (ppt).
    pub salinity_ppt: f32,
    /// Water temperature (degC).
    pub temperature_c: f32,
    /// Transducer depth (m).
    pub depth_m: f32,
    /// Speed of sound (m/s).
    pub speed_of_sound_m_s: f32,
    /// Built-in test result (0: no fault).
    pub bit: u16,
}

/// One parsed PD6 line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Line {
    /// `:BI`, instrument frame x, y, z.
    BottomInstrument(VelocityGroup),
    /// `:BS`, ship frame transverse, longitudinal, normal.
    BottomShip(VelocityGroup),
    /// `:BE`, earth frame east, north, up.
    BottomEarth(VelocityGroup),
    /// `:BD`.
    BottomDistance(BottomDistance),
    /// `:TS`.
    TimingScaling(TimingScaling),
    /// Any other two-letter group (`SA`, `WI`, `WS`, `WE`, `WD`, ...), fields not read.
    Other([u8; 2]),
}

/// Parses one PD6 line (it may end in CR / LF).
pub fn parse(line: &[u8]) -> Result<Line, Pd6Error> {
    let line = trim_line_end(line);
    let (id, body) = match line {
        [b':', a, b, b',', body @ ..] if a.is_ascii_uppercase() && b.is_ascii_uppercase() => {
            ([*a, *b], body)
        }
        _ => return Err(Pd6Error::NoStart),
    };
    match &id {
        b"BI" => velocity_group(body, true).map(Line::BottomInstrument),
        b"BS" => velocity_group(body, false).map(Line::BottomShip),
        b"BE" => velocity_group(body, false).map(Line::BottomEarth),
        b"BD" => bottom_distance(body).map(Line::BottomDistance),
        b"TS" => timing_scaling(body).map(Line::TimingScaling),
        _ => Ok(Line::Other(id)),
    }
}

/// A velocity in mm/s (`±XXXXX`: six characters, the sign always printed) to m/s; `None`
/// for -32768.
fn velocity(f: &mut Fields<'_>) -> Result<Option<f32>, Pd6Error> {
    let idx = f.index();
    let mm_s = signed_units(f.next_padded(6)?, 0, true)
        .and_then(|v| i32::try_from(v).ok())
        .ok_or(FieldError::Malformed(idx))?;
    match mm_s {
        MISSING_MM_S => Ok(None),
        -32767..=32767 => Ok(Some(mm_s as f32 / 1000.0)),
        _ => Err(Pd6Error::OutOfRange),
    }
}

fn velocity_group(body: &[u8], with_error: bool) -> Result<VelocityGroup, Pd6Error> {
    let mut f = Fields::new(body, b',');
    let velocity_m_s = [velocity(&mut f)?, velocity(&mut f)?, velocity(&mut f)?];
    let error_m_s = if with_error { velocity(&mut f)? } else { None };
    let good = f.next_flag(b'A', b'V')?;
    f.end()?;
    Ok(VelocityGroup {
        velocity_m_s,
        error_m_s,
        good,
    })
}

/// A fixed-width field `width` wide with `decimals` decimals (a sign first when `signed`;
/// `-` refused otherwise): its value in units of 10^-`decimals`.
fn fixed(f: &mut Fields<'_>, width: usize, decimals: usize, signed: bool) -> Result<i64, Pd6Error> {
    let idx = f.index();
    let text = f.next_padded(width)?;
    signed_units(text, decimals, signed).ok_or(Pd6Error::Field(FieldError::Malformed(idx)))
}

/// `text` as `[±]digits[.decimals]` with the sign required when `signed` and absent
/// otherwise: its value in units of 10^-`decimals`.
fn signed_units(text: &str, decimals: usize, signed: bool) -> Option<i64> {
    let (negative, digits) = match (signed, text.as_bytes()) {
        (true, [b'+', rest @ ..]) => (false, rest),
        (true, [b'-', rest @ ..]) => (true, rest),
        (false, rest @ [b'0'..=b'9', ..]) => (false, rest),
        _ => return None,
    };
    let digits = core::str::from_utf8(digits).ok()?;
    let units = if decimals == 0 {
        if matches!(digits.as_bytes(), [b'0', _, ..]) || digits.is_empty() {
            return None;
        }
        parse_int::<i64>(digits).filter(|_| digits.bytes().all(|b| b.is_ascii_digit()))?
    } else {
        i64::try_from(fixed_point(digits, decimals)?.0).ok()?
    };
    Some(if negative { -units } else { units })
}

fn bottom_distance(body: &[u8]) -> Result<BottomDistance, Pd6Error> {
    let mut f = Fields::new(body, b',');
    // `±EEEEEEEE.EE` x 3, `DDDD.DD`, `TTT.TT`: the widths bound the ranges.
    let mut distance_m = [0.0_f64; 3];
    for d in distance_m.iter_mut() {
        *d = fixed(&mut f, 12, 2, true)? as f64 / 100.0;
    }
    let range_to_bottom_m = fixed(&mut f, 7, 2, false)? as f32 / 100.0;
    let since_good_s = fixed(&mut f, 6, 2, false)? as f32 / 100.0;
    f.end()?;
    Ok(BottomDistance {
        distance_m,
        range_to_bottom_m,
        since_good_s,
    })
}

fn timing_scaling(body: &[u8]) -> Result<TimingScaling, Pd6Error> {
    let mut f = Fields::new(body, b',');
    let stamp_idx = f.index();
    let stamp_text = f.next_padded(14)?.as_bytes();
    let mut stamp = [0_u8; 7];
    if stamp_text.len() != 14 {
        return Err(FieldError::Malformed(stamp_idx).into());
    }
    for (slot, pair) in stamp.iter_mut().zip(stamp_text.chunks_exact(2)) {
        *slot = match pair {
            [a, b] if a.is_ascii_digit() && b.is_ascii_digit() => (a - b'0') * 10 + (b - b'0'),
            _ => return Err(FieldError::Malformed(stamp_idx).into()),
        };
    }
    // `SS.S`, `±TT.T`, `DDDD.D`, `CCCC.C`, `BBB`.
    let salinity_ppt = fixed(&mut f, 4, 1, false)? as f32 / 10.0;
    let temperature_c = fixed(&mut f, 5, 1, true)? as f32 / 10.0;
    let depth_m = fixed(&mut f, 6, 1, false)? as f32 / 10.0;
    let speed_of_sound_m_s = fixed(&mut f, 6, 1, false)? as f32 / 10.0;
    let bit_idx = f.index();
    let bit = u16::try_from(fixed(&mut f, 3, 0, false)?)
        .map_err(|_| Pd6Error::Field(FieldError::Malformed(bit_idx)))?;
    f.end()?;
    let [_, month, day, hour, minute, second, _] = stamp;
    let ok = (1..=12).contains(&month)
        && (1..=31).contains(&day)
        && hour < 24
        && minute < 60
        && second < 60
        && (0.0..=1e4).contains(&depth_m)
        && (0.0..=2500.0).contains(&speed_of_sound_m_s);
    if !ok {
        return Err(Pd6Error::OutOfRange);
    }
    Ok(TimingScaling {
        stamp,
        salinity_ppt,
        temperature_c,
        depth_m,
        speed_of_sound_m_s,
        bit,
    })
}

/// One ensemble's bottom-track lines.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BottomTrack {
    /// `:BI`, if it came.
    pub instrument: Option<VelocityGroup>,
    /// `:BS`, if it came.
    pub ship: Option<VelocityGroup>,
    /// `:BE`, if it came.
    pub earth: Option<VelocityGroup>,
    /// `:BD` (always present: it completes the ensemble).
    pub distance: Option<BottomDistance>,
    /// `:TS`, if it came.
    pub timing: Option<TimingScaling>,
}

/// Largest difference of speed between two good velocity groups of one ensemble (m/s):
/// each component is printed to 1 mm/s, so a rotation of the same velocity differs by at
/// most sqrt(3) x 1 mm/s after rounding.
pub const FRAMES_AGREE_M_S: f32 = 0.0018;

impl BottomTrack {
    /// The instrument-frame velocity (m/s) when `:BI` came, is good and complete, and the
    /// other good groups agree with it ([`BottomTrack::frames_agree`]).
    pub fn instrument_velocity_m_s(&self) -> Option<[f32; 3]> {
        self.instrument
            .as_ref()
            .and_then(VelocityGroup::usable)
            .filter(|_| self.frames_agree())
    }

    /// `true` when the good, complete velocity groups (`:BI`, `:BS`, `:BE`) have the same
    /// speed within [`FRAMES_AGREE_M_S`]: the ship and earth frames are rotations of the
    /// instrument's, so a corrupted digit in one of them shows (not when only one group is
    /// good, nor a digit changed in the same way in all of them).
    pub fn frames_agree(&self) -> bool {
        let speed_sq = |g: &Option<VelocityGroup>| {
            g.as_ref()
                .and_then(VelocityGroup::usable)
                .map(|[a, b, c]| a * a + b * b + c * c)
        };
        let squares = [
            speed_sq(&self.instrument),
            speed_sq(&self.ship),
            speed_sq(&self.earth),
        ];
        let mut good = squares.iter().flatten();
        let Some(&first) = good.next() else {
            return true;
        };
        good.all(|&other| speeds_agree(first, other))
    }
}

/// `|sqrt(a) - sqrt(b)| <= FRAMES_AGREE_M_S` for squared speeds `a`, `b`, without a square
/// root (none in `core`): `(sa - sb)^2 <= t^2` is `a + b - t^2 <= 2 sa sb`.
fn speeds_agree(a: f32, b: f32) -> bool {
    let lhs = a + b - FRAMES_AGREE_M_S * FRAMES_AGREE_M_S;
    lhs <= 0.0 || lhs * lhs <= 4.0 * a * b
}

/// Collects the lines of one ensemble; `:BD` completes it.
#[derive(Debug, Clone, Default)]
pub struct Ensemble {
    current: BottomTrack,
}

impl Ensemble {
    /// A collector with nothing collected.
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes one parsed line; returns the ensemble when `line` is its `:BD`. A refused line
    /// is not passed here, so an ensemble may lack a group (its field is then `None`).
    pub fn push(&mut self, line: Line) -> Option<BottomTrack> {
        match line {
            Line::BottomInstrument(g) => self.current.instrument = Some(g),
            Line::BottomShip(g) => self.current.ship = Some(g),
            Line::BottomEarth(g) => self.current.earth = Some(g),
            Line::TimingScaling(t) => self.current.timing = Some(t),
            Line::BottomDistance(d) => {
                self.current.distance = Some(d);
                return Some(core::mem::take(&mut self.current));
            }
            Line::Other(_) => {}
        }
        None
    }
}
