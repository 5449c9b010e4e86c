//! Water Linked DVL A50 / A125 serial protocol (protocol versions 2.6.x and 2.7.x).
//!
//! Every packet from the DVL starts with `w`, then the direction `r` (response), the report
//! letter and its comma-separated fields, then `*` and the CRC-8 of everything before the `*`
//! as two hex digits, then CR, LF or CR LF. The CRC is CRC-8 with polynomial 0x07, initial
//! value 0, no reflection, no final XOR (check value 0xF4): the `crc` crate's `CRC_8_SMBUS`.
//! The DVL always sends the checksum, so a report without one is refused.
//!
//! - `wrz`: velocity report: vx, vy, vz (m/s, DVL or vehicle frame), valid (`y` / `n`: bottom
//!   lock), altitude (m), figure of merit (m/s), the 3x3 velocity covariance ((m/s)^2, nine
//!   entries separated by `;`), time of validity and time of transmission (Unix time in
//!   microseconds), time since the previous report (ms), status (bit 0: high temperature).
//! - `wrp`: dead-reckoning report: time stamp (Unix s, read to the microsecond), x, y, z (m), position standard
//!   deviation (m), roll, pitch, yaw (degrees), status (0 good, 1 not).
//!
//! The fixed-point fields must carry their documented number of decimals (see [`parse`]).
//! The other numbers (the covariance, `wrp`'s fields) are read by
//! `fields::parse_f32_compact`: the nearest `f32` for the forms the DVL prints, without
//! `f32::from_str`'s tables, so that the parser fits a 32 KiB node image.
//!
//! Other reports (`wru`, `wrs`, `wrx`, `wrt`, acknowledgements) pass the checksum check and
//! come back as [`Report::Other`] with their letter; the vehicle uses only `wrz`.
//!
//! [`VelocityGate`] then decides whether a checked velocity report may reach the estimator:
//! invalid (no bottom lock), inconsistent (an asymmetric covariance, a negative variance or
//! valid altitude) or a figure of merit above the threshold is refused.

use crate::fields::{fixed_point, split_checksum, trim_line_end, FieldError, Fields};
use crc::{Crc, CRC_8_SMBUS};

/// The A50's CRC-8 (polynomial 0x07, init 0x00, no reflection, xorout 0x00).
pub const CRC8: Crc<u8> = Crc::<u8>::new(&CRC_8_SMBUS);

/// Why a line from the DVL was refused before its values were looked at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// The line does not start with `wr` (the DVL's response prefix).
    NoStart,
    /// No `*` followed by two hex digits at the end of the line.
    NoChecksum,
    /// The CRC-8 of the line does not match the one it carries.
    Checksum {
        /// The CRC-8 carried by the line.
        sent: u8,
        /// The CRC-8 computed over the line.
        computed: u8,
    },
    /// A field of a `wrz` or `wrp` report is missing, malformed or extra.
    Field(FieldError),
    /// A value outside what the DVL can report (see [`VelocityReport`]'s limits).
    OutOfRange,
}

impl From<FieldError> for FrameError {
    fn from(e: FieldError) -> Self {
        FrameError::Field(e)
    }
}

/// One `wrz` velocity report, exactly as sent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityReport {
    /// Velocity over the bottom along x, y, z (m/s).
    pub velocity_m_s: [f32; 3],
    /// `true` when the DVL has bottom lock and the velocities and altitude are valid.
    pub valid: bool,
    /// Altitude above the reflecting surface (m); negative when not valid.
    pub altitude_m: f32,
    /// Figure of merit: the velocities' accuracy (m/s).
    pub fom_m_s: f32,
    /// Velocity covariance, row-major ((m/s)^2).
    pub covariance: [f32; 9],
    /// Time of the surface reflection, "centre of ping" (Unix time, microseconds).
    pub time_of_validity_us: u64,
    /// Time just before the report was sent (Unix time, microseconds).
    pub time_of_transmission_us: u64,
    /// Time since the previous velocity report (ms).
    pub since_last_ms: f32,
    /// Status bits; bit 0: high temperature, thermal shutdown soon.
    pub status: u8,
}

impl VelocityReport {
    /// `true` when the covariance is one and a valid report's altitude is not negative. A
    /// covariance is symmetric, its variances are not negative, and each covariance is
    /// bounded by its two variances (`c_ij^2 <= c_ii c_jj`, positive semi-definite); the
    /// variances stay under [`MAX_SPEED_M_S`] squared, as the velocities do. Not a parser
    /// check: the documentation's own example has an asymmetric covariance
    /// (`1e-07;0;1.4;0;1.2;0;0.2;0;1e+09`) and must decode; [`VelocityGate`] applies it
    /// before the estimator.
    pub fn is_consistent(&self) -> bool {
        let c = &self.covariance;
        let at = |i: usize| c.get(i).copied().unwrap_or(f32::NAN);
        let max_var = MAX_SPEED_M_S * MAX_SPEED_M_S;
        let variances = [0, 4, 8].iter().all(|&i| (0.0..=max_var).contains(&at(i)));
        // (off-diagonal index, its mirror, the two variances' indices)
        let pairs = [(1, 3, 0, 4), (2, 6, 0, 8), (5, 7, 4, 8)];
        let covariances = pairs
            .iter()
            .all(|&(a, b, i, j)| at(a) == at(b) && at(a) * at(a) <= at(i) * at(j));
        variances && covariances && (!self.valid || self.altitude_m >= 0.0)
    }
}

/// One `wrp` dead-reckoning report, exactly as sent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeadReckoningReport {
    /// Time stamp of the report (Unix time, microseconds; sent in seconds with up to six
    /// decimals, read as an integer so that no software `f64` runs on the MCU).
    pub time_us: u64,
    /// Position from the start of the dead-reckoning run: x, y, z (down) (m).
    pub position_m: [f32; 3],
    /// Standard deviation of the position (m).
    pub position_std_m: f32,
    /// Roll, pitch, yaw (degrees).
    pub attitude_deg: [f32; 3],
    /// 0 when the DVL reports no error, 1 otherwise.
    pub status: u8,
}

/// A line from the DVL whose checksum is right and whose fields parse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Report {
    /// `wrz`.
    Velocity(VelocityReport),
    /// `wrp`.
    DeadReckoning(DeadReckoningReport),
    /// Any other response letter (`wru`, `wrs`, `wrx`, `wra`, ...), checksum checked.
    Other(u8),
}

/// Largest speed the parser accepts (m/s): beyond any ROV's and the DVL's range, so only
/// a corrupted report carries it.
pub const MAX_SPEED_M_S: f32 = 20.0;
/// Largest altitude the parser accepts (m): the A125's 125 m range with margin.
pub const MAX_ALTITUDE_M: f32 = 200.0;

/// Longest time from a report's validity to its transmission accepted (us): the DVL's
/// processing takes tens of milliseconds; a report sent before its validity or a second
/// after it has a corrupted time stamp.
pub const MAX_LATENCY_US: u64 = 1_000_000;

/// Checks the line's start and CRC-8 and parses its fields. `line` may end in CR / LF.
///
/// The CRC-8 catches every error within 8 consecutive bits but only 255 in 256 deleted or
/// inserted bytes, so the fields are held to the documented layout: velocities and the
/// figure of merit with 3 decimals, altitude and time since the last report with 2, the
/// time of transmission not before the time of validity nor more than [`MAX_LATENCY_US`]
/// after it. The covariance entries have no fixed layout (`1e-07`, `0`, `1.4`).
pub fn parse(line: &[u8]) -> Result<Report, FrameError> {
    let line = trim_line_end(line);
    let (covered, sent) = match line {
        [b'w', b'r', ..] => split_checksum(line).ok_or(FrameError::NoChecksum)?,
        _ => return Err(FrameError::NoStart),
    };
    let computed = CRC8.checksum(covered);
    if computed != sent {
        return Err(FrameError::Checksum { sent, computed });
    }
    match covered {
        [b'w', b'r', b'z', b',', body @ ..] => parse_wrz(body).map(Report::Velocity),
        [b'w', b'r', b'p', b',', body @ ..] => parse_wrp(body).map(Report::DeadReckoning),
        // A velocity or dead-reckoning letter not followed by its fields is a corrupted
        // report, not another kind.
        [b'w', b'r', b'z' | b'p', ..] => Err(FrameError::NoStart),
        [b'w', b'r', letter, ..] => Ok(Report::Other(*letter)),
        _ => Err(FrameError::NoStart),
    }
}

fn parse_wrz(body: &[u8]) -> Result<VelocityReport, FrameError> {
    let mut f = Fields::new(body, b',');
    let velocity_m_s = [
        f.next_fixed_f32(3)?,
        f.next_fixed_f32(3)?,
        f.next_fixed_f32(3)?,
    ];
    let valid = f.next_flag(b'y', b'n')?;
    let altitude_m = f.next_fixed_f32(2)?;
    let fom_m_s = f.next_fixed_f32(3)?;
    let cov_idx = f.index();
    let cov_field = f.next_raw()?;
    let mut covariance = [0.0_f32; 9];
    let mut c = Fields::new(cov_field, b';');
    for slot in covariance.iter_mut() {
        *slot = c
            .next_f32_compact()
            .map_err(|_| FieldError::Malformed(cov_idx))?;
    }
    c.end().map_err(|_| FieldError::Malformed(cov_idx))?;
    let time_of_validity_us = f.next_int::<u64>()?;
    let time_of_transmission_us = f.next_int::<u64>()?;
    let since_last_ms = f.next_fixed_f32(2)?;
    let status = f.next_int::<u8>()?;
    f.end()?;
    let latency_ok = time_of_transmission_us
        .checked_sub(time_of_validity_us)
        .is_some_and(|l| l <= MAX_LATENCY_US);
    let in_range = velocity_m_s.iter().all(|v| v.abs() <= MAX_SPEED_M_S)
        && altitude_m <= MAX_ALTITUDE_M
        && (0.0..=MAX_SPEED_M_S).contains(&fom_m_s)
        && since_last_ms >= 0.0
        && latency_ok;
    if !in_range {
        return Err(FrameError::OutOfRange);
    }
    Ok(VelocityReport {
        velocity_m_s,
        valid,
        altitude_m,
        fom_m_s,
        covariance,
        time_of_validity_us,
        time_of_transmission_us,
        since_last_ms,
        status,
    })
}

fn parse_wrp(body: &[u8]) -> Result<DeadReckoningReport, FrameError> {
    let mut f = Fields::new(body, b',');
    let time_us = time_us(f.next_str()?).ok_or(FieldError::Malformed(0))?;
    let position_m = [
        f.next_f32_compact()?,
        f.next_f32_compact()?,
        f.next_f32_compact()?,
    ];
    let position_std_m = f.next_f32_compact()?;
    let attitude_deg = [
        f.next_f32_compact()?,
        f.next_f32_compact()?,
        f.next_f32_compact()?,
    ];
    let status = f.next_int::<u8>()?;
    f.end()?;
    if position_std_m < 0.0 || attitude_deg.iter().any(|a| a.abs() > 360.0) {
        return Err(FrameError::OutOfRange);
    }
    Ok(DeadReckoningReport {
        time_us,
        position_m,
        position_std_m,
        attitude_deg,
        status,
    })
}

/// Seconds printed with one to six decimals (`49056.809`) as microseconds.
fn time_us(s: &str) -> Option<u64> {
    let decimals = s.len().checked_sub(s.find('.')?.checked_add(1)?)?;
    let scale = 10_u64.checked_pow(6_u32.checked_sub(u32::try_from(decimals).ok()?)?)?;
    let (units, negative) = fixed_point(s, decimals)?;
    if negative || decimals == 0 {
        return None;
    }
    units.checked_mul(scale)
}

/// Why a checked velocity report does not reach the estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Refusal {
    /// `valid` is `n`: no bottom lock. The estimator sees a DVL gap.
    NoBottomLock,
    /// The report contradicts itself: a covariance that is not symmetric or has a negative
    /// variance, or an altitude marked valid that is negative. The CRC-8 passes 1 in 256
    /// deleted or inserted bytes; most of those in the covariance show here.
    Inconsistent,
    /// The figure of merit is above the gate's threshold.
    PoorFigureOfMerit {
        /// The report's figure of merit (m/s).
        fom_m_s: f32,
        /// The gate's threshold (m/s).
        max_m_s: f32,
    },
}

/// Admission of velocity reports to the estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityGate {
    /// Largest figure of merit accepted (m/s).
    pub max_fom_m_s: f32,
}

impl Default for VelocityGate {
    /// 0.1 m/s: Water Linked's A50 accuracy is +-1.01 % +-0.1 cm/s; a figure of merit of
    /// 10 cm/s is an order of magnitude worse than its bottom-lock figures.
    fn default() -> Self {
        Self { max_fom_m_s: 0.1 }
    }
}

impl VelocityGate {
    /// `Ok` with the report when it may reach the estimator.
    pub fn admit(&self, r: &VelocityReport) -> Result<VelocityReport, Refusal> {
        if !r.valid {
            return Err(Refusal::NoBottomLock);
        }
        // A NaN threshold refuses everything rather than admitting everything.
        if r.fom_m_s > self.max_fom_m_s || self.max_fom_m_s.is_nan() {
            return Err(Refusal::PoorFigureOfMerit {
                fom_m_s: r.fom_m_s,
                max_m_s: self.max_fom_m_s,
            });
        }
        if !r.is_consistent() {
            return Err(Refusal::Inconsistent);
        }
        Ok(*r)
    }
}
