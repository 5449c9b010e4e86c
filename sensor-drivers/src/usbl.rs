//! NMEA 0183 from a USBL or an underwater GPS, for the surface program.
//!
//! - Framing: `$`, the address, comma-separated fields, `*` and the XOR of every byte between
//!   `$` and `*` as two hex digits, CR LF. The checksum is required: a USBL's fix steers the
//!   vehicle, so a sentence without one is refused.
//! - `GGA` (Water Linked Underwater GPS gives the vehicle's position so): parsed by the
//!   `nmea` crate (no_std, GGA only). Before it, the latitude and longitude fields are checked
//!   to be `ddmm.m...` and `dddmm.m...`: the crate reads the first two (three) digits as
//!   degrees whatever the field's width, so an unpadded `113.8` (1 deg 13.8') would be read
//!   as 11 deg 3.8'. A fix without position or with fix quality 0 is refused.
//! - `$PSIMSSB` (Kongsberg HiPAP / HPR, and emulated by Water Linked and others): the
//!   transponder's position relative to the vessel, no crate parses it. Fields: time of the
//!   measurement `hhmmss.ss`, transponder code, status `A` (good) / `V`, error code,
//!   coordinate system (`C` Cartesian is the one read here), orientation (`H` vessel head up:
//!   x starboard, y forward; `N` north up: x east, y north), software filter (`M` measured,
//!   `F` filtered, `P` predicted), x, y (m), depth (m), expected accuracy (m), additional
//!   information letter and two additional values. Status other than `A`, or a coordinate
//!   system other than `C`, is refused.
//!
//! [`LocalOrigin`] turns a GGA fix into north / east metres from the dive's origin.

use crate::fields::{hex_digit, trim_line_end, FieldError, Fields};

/// Why a sentence was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NmeaError {
    /// Not `$`, then an address, then `,`.
    NoStart,
    /// No `*` followed by two hex digits at the end.
    NoChecksum,
    /// The XOR checksum does not match.
    Checksum {
        /// The checksum the sentence carries.
        sent: u8,
        /// The checksum computed over the sentence.
        computed: u8,
    },
    /// A sentence this module does not read.
    Unsupported,
    /// A field is missing, malformed or extra.
    Field(FieldError),
    /// The `nmea` crate refused the GGA sentence.
    Gga,
    /// The latitude or longitude field is not `ddmm.m` / `dddmm.m`, or out of range.
    LatLon,
    /// GGA without a position fix (quality 0 or empty position).
    NoFix,
    /// `$PSIMSSB` with status other than `A`.
    NotOk,
    /// `$PSIMSSB` in a coordinate system other than Cartesian (`C`).
    NotCartesian,
}

impl From<FieldError> for NmeaError {
    fn from(e: FieldError) -> Self {
        NmeaError::Field(e)
    }
}

/// Time of day of a measurement (UTC or local, as the instrument is set up), in seconds
/// since midnight.
pub type TimeOfDayS = f64;

/// A GGA position fix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GgaFix {
    /// Time of the fix (s since midnight), when sent.
    pub time_of_day_s: Option<TimeOfDayS>,
    /// Latitude (degrees, north positive).
    pub latitude_deg: f64,
    /// Longitude (degrees, east positive).
    pub longitude_deg: f64,
    /// Fix quality digit (1 GPS, 2 DGPS, ...).
    pub quality: u8,
    /// Satellites in use, when sent.
    pub satellites: Option<u32>,
    /// Horizontal dilution of precision, when sent.
    pub hdop: Option<f32>,
    /// Altitude above mean sea level (m); an underwater GPS sends minus the depth.
    pub altitude_m: Option<f32>,
}

/// Orientation of a `$PSIMSSB` Cartesian position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Orientation {
    /// `H`: x to starboard, y forward of the vessel.
    HeadUp,
    /// `N`: x east, y north.
    NorthUp,
}

/// A `$PSIMSSB` relative Cartesian position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SsbFix {
    /// Time of the measurement (s since midnight).
    pub time_of_day_s: TimeOfDayS,
    /// Transponder code (`B01`, `M44`, ...), up to 8 bytes, the rest zero.
    pub transponder: [u8; 8],
    /// Head up or north up.
    pub orientation: Orientation,
    /// Software filter letter: `M` measured, `F` filtered, `P` predicted.
    pub filter: u8,
    /// x (m): starboard (head up) or east (north up).
    pub x_m: f32,
    /// y (m): forward (head up) or north (north up).
    pub y_m: f32,
    /// Depth (m).
    pub depth_m: f32,
    /// Expected accuracy (m), when sent.
    pub accuracy_m: Option<f32>,
}

/// A checked sentence of a kind this module reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sentence {
    /// `$--GGA`.
    Gga(GgaFix),
    /// `$PSIMSSB`.
    Ssb(SsbFix),
}

/// The NMEA XOR checksum of `data` (the bytes between `$` and `*`).
pub fn xor_checksum(data: &[u8]) -> u8 {
    data.iter().fold(0, |c, b| c ^ b)
}

/// Checks the framing and the checksum and parses a GGA or `$PSIMSSB` sentence.
pub fn parse(line: &[u8]) -> Result<Sentence, NmeaError> {
    let line = trim_line_end(line);
    let inner = match line {
        [b'$', rest @ ..] => rest,
        _ => return Err(NmeaError::NoStart),
    };
    let star = inner
        .iter()
        .rposition(|&b| b == b'*')
        .ok_or(NmeaError::NoChecksum)?;
    let (data, tail) = inner.split_at(star);
    let sent = match tail {
        [_, hi, lo] => match (hex_digit(*hi), hex_digit(*lo)) {
            (Some(h), Some(l)) => (h << 4) | l,
            _ => return Err(NmeaError::NoChecksum),
        },
        _ => return Err(NmeaError::NoChecksum),
    };
    let computed = xor_checksum(data);
    if computed != sent {
        return Err(NmeaError::Checksum { sent, computed });
    }
    match data {
        [b'P', b'S', b'I', b'M', b'S', b'S', b'B', b',', body @ ..] => {
            parse_ssb(body).map(Sentence::Ssb)
        }
        [t1, t2, b'G', b'G', b'A', b',', body @ ..]
            if t1.is_ascii_uppercase() && t2.is_ascii_uppercase() =>
        {
            check_lat_lon(body)?;
            parse_gga(line).map(Sentence::Gga)
        }
        [_, _, _, _, _, b',', ..] | [b'P', ..] => Err(NmeaError::Unsupported),
        _ => Err(NmeaError::NoStart),
    }
}

/// Seconds since midnight from `hhmmss` or `hhmmss.s...`.
fn time_of_day(s: &str) -> Option<TimeOfDayS> {
    let b = s.as_bytes();
    let digits = |i: usize| -> Option<u32> {
        match (b.get(i), b.get(i + 1)) {
            (Some(a), Some(c)) if a.is_ascii_digit() && c.is_ascii_digit() => {
                Some(u32::from(a - b'0') * 10 + u32::from(c - b'0'))
            }
            _ => None,
        }
    };
    let (h, m) = (digits(0)?, digits(2)?);
    let sec_text = s.get(4..)?;
    let sec_ok = sec_text
        .get(..2)
        .is_some_and(|t| t.bytes().all(|c| c.is_ascii_digit()))
        && match sec_text.get(2..) {
            Some("") => true,
            Some(frac) => {
                frac.len() > 1
                    && frac.starts_with('.')
                    && frac.bytes().skip(1).all(|c| c.is_ascii_digit())
            }
            None => false,
        };
    if !sec_ok {
        return None;
    }
    let sec = crate::fields::parse_f64(sec_text)?;
    if h >= 24 || m >= 60 || !(0.0..60.0).contains(&sec) {
        return None;
    }
    Some(f64::from(h * 3600 + m * 60) + sec)
}

fn parse_ssb(body: &[u8]) -> Result<SsbFix, NmeaError> {
    let mut f = Fields::new(body, b',');
    let time_idx = f.index();
    let time_of_day_s = time_of_day(f.next_str()?).ok_or(FieldError::Malformed(time_idx))?;
    let tp_idx = f.index();
    let tp = f.next_raw()?;
    let mut transponder = [0_u8; 8];
    if tp.is_empty()
        || tp.len() > transponder.len()
        || !tp.iter().all(|b| b.is_ascii_alphanumeric())
    {
        return Err(FieldError::Malformed(tp_idx).into());
    }
    for (slot, b) in transponder.iter_mut().zip(tp) {
        *slot = *b;
    }
    let ok = f.next_flag(b'A', b'V')?;
    let err_idx = f.index();
    let error_code = f.next_raw()?;
    if error_code.len() > 4 || !error_code.iter().all(|b| b.is_ascii_alphanumeric()) {
        return Err(FieldError::Malformed(err_idx).into());
    }
    let cs_idx = f.index();
    let coordinate_system = f.next_raw()?;
    let or_idx = f.index();
    let orientation = match f.next_raw()? {
        b"H" => Orientation::HeadUp,
        b"N" => Orientation::NorthUp,
        b"E" => return Err(NmeaError::NotCartesian),
        _ => return Err(FieldError::Malformed(or_idx).into()),
    };
    let flt_idx = f.index();
    let filter = match f.next_raw()? {
        [c @ (b'M' | b'F' | b'P')] => *c,
        _ => return Err(FieldError::Malformed(flt_idx).into()),
    };
    let x_m = f.next_f32()?;
    let y_m = f.next_f32()?;
    let depth_m = f.next_f32()?;
    let acc_idx = f.index();
    let accuracy_m = match f.next_str()? {
        "" => None,
        s => Some(crate::fields::parse_f32(s).ok_or(FieldError::Malformed(acc_idx))?),
    };
    // Additional information letter and its two values: read for syntax, not used.
    let add_idx = f.index();
    match f.next_raw()? {
        [] | [b'N' | b'C' | b'I' | b'D' | b'T' | b'V'] => {}
        _ => return Err(FieldError::Malformed(add_idx).into()),
    }
    for _ in 0..2 {
        let idx = f.index();
        match f.next_str()? {
            "" => {}
            s => {
                crate::fields::parse_f64(s).ok_or(FieldError::Malformed(idx))?;
            }
        }
    }
    f.end()?;
    if !ok {
        return Err(NmeaError::NotOk);
    }
    match coordinate_system {
        b"C" => {}
        b"P" | b"U" | b"R" => return Err(NmeaError::NotCartesian),
        _ => return Err(FieldError::Malformed(cs_idx).into()),
    }
    let plausible = x_m.abs() < 1e5
        && y_m.abs() < 1e5
        && (-100.0..1e4).contains(&depth_m)
        && accuracy_m.is_none_or(|a| a >= 0.0);
    if !plausible {
        return Err(NmeaError::Field(FieldError::Malformed(acc_idx)));
    }
    Ok(SsbFix {
        time_of_day_s,
        transponder,
        orientation,
        filter,
        x_m,
        y_m,
        depth_m,
        accuracy_m,
    })
}

/// `ddmm.m...` (`deg_digits` = 2) or `dddmm.m...` (3): the degrees padded to their width,
/// minutes below 60.
fn lat_lon_field_ok(s: &str, deg_digits: usize) -> bool {
    let Some(point) = s.find('.') else {
        return false;
    };
    let b = s.as_bytes();
    point == deg_digits + 2
        && b.iter()
            .enumerate()
            .all(|(i, c)| c.is_ascii_digit() || i == point)
        && s.len() > point + 1
        && s.get(deg_digits..)
            .and_then(crate::fields::parse_f64)
            .is_some_and(|m| m < 60.0)
}

fn check_lat_lon(body: &[u8]) -> Result<(), NmeaError> {
    let mut f = Fields::new(body, b',');
    let _time = f.next_raw()?;
    let lat = f.next_str()?;
    let ns = f.next_str()?;
    let lon = f.next_str()?;
    let ew = f.next_str()?;
    if lat.is_empty() && ns.is_empty() && lon.is_empty() && ew.is_empty() {
        return Err(NmeaError::NoFix);
    }
    if !lat_lon_field_ok(lat, 2) || !lat_lon_field_ok(lon, 3) {
        return Err(NmeaError::LatLon);
    }
    Ok(())
}

fn parse_gga(line: &[u8]) -> Result<GgaFix, NmeaError> {
    let text = core::str::from_utf8(line).map_err(|_| NmeaError::Gga)?;
    let data = match nmea::parse_str(text) {
        Ok(nmea::ParseResult::GGA(d)) => d,
        _ => return Err(NmeaError::Gga),
    };
    let (Some(latitude_deg), Some(longitude_deg)) = (data.latitude, data.longitude) else {
        return Err(NmeaError::NoFix);
    };
    let quality = match data.fix_type {
        Some(nmea::sentences::FixType::Invalid) | None => return Err(NmeaError::NoFix),
        Some(t) => fix_quality_digit(t),
    };
    if latitude_deg.abs() > 90.0 || longitude_deg.abs() > 180.0 {
        return Err(NmeaError::LatLon);
    }
    // The time field is read here rather than from the crate's `chrono` value, to keep
    // `chrono` out of this crate's interface.
    let time_of_day_s = match data.fix_time {
        Some(_) => Some(gga_time(line).ok_or(NmeaError::Gga)?),
        None => None,
    };
    Ok(GgaFix {
        time_of_day_s,
        latitude_deg,
        longitude_deg,
        quality,
        satellites: data.fix_satellites,
        hdop: data.hdop,
        altitude_m: data.altitude,
    })
}

/// The time field of a GGA sentence (the first after the address).
fn gga_time(line: &[u8]) -> Option<TimeOfDayS> {
    let mut f = Fields::new(line, b',');
    f.next_raw().ok()?;
    let t = core::str::from_utf8(f.next_raw().ok()?).ok()?;
    time_of_day(t)
}

fn fix_quality_digit(t: nmea::sentences::FixType) -> u8 {
    use nmea::sentences::FixType as F;
    match t {
        F::Invalid => 0,
        F::Gps => 1,
        F::DGps => 2,
        F::Pps => 3,
        F::Rtk => 4,
        F::FloatRtk => 5,
        F::Estimated => 6,
        F::Manual => 7,
        F::Simulation => 8,
    }
}

/// WGS-84 equatorial radius (m).
const EARTH_RADIUS_M: f64 = 6_378_137.0;

/// The dive's origin: converts positions to north / east metres from it (local tangent
/// plane, equirectangular: within 1 mm per 100 m at the few-hundred-metre scale of a dive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalOrigin {
    /// Latitude of the origin (degrees).
    pub latitude_deg: f64,
    /// Longitude of the origin (degrees).
    pub longitude_deg: f64,
}

impl LocalOrigin {
    /// North and east (m) of `fix` from the origin.
    pub fn north_east_m(&self, latitude_deg: f64, longitude_deg: f64) -> [f64; 2] {
        let d_lat = (latitude_deg - self.latitude_deg).to_radians();
        let mut d_lon_deg = longitude_deg - self.longitude_deg;
        if d_lon_deg > 180.0 {
            d_lon_deg -= 360.0;
        } else if d_lon_deg < -180.0 {
            d_lon_deg += 360.0;
        }
        let cos_lat = libm::cos(self.latitude_deg.to_radians());
        [
            d_lat * EARTH_RADIUS_M,
            d_lon_deg.to_radians() * EARTH_RADIUS_M * cos_lat,
        ]
    }
}
