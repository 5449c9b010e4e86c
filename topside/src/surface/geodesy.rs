//! Geodesy at the surface: the local frame's origin on the globe (`SET_GPS_GLOBAL_ORIGIN`),
//! and mission items' waypoints from local or global frames into the local frame.

use mavlink::dialects::ardupilotmega::MavFrame;

/// The geodetic point of the local frame's origin (`SET_GPS_GLOBAL_ORIGIN`), on the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlobalOrigin {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Altitude of the surface above mean sea level, metres.
    pub alt_m: f64,
}

impl GlobalOrigin {
    /// From `SET_GPS_GLOBAL_ORIGIN`'s integers (degrees x 1e7, millimetres); `None` off the
    /// globe.
    pub fn from_mavlink(lat_e7: i32, lon_e7: i32, alt_mm: i32) -> Option<Self> {
        let o = Self {
            lat_deg: f64::from(lat_e7) * 1e-7,
            lon_deg: f64::from(lon_e7) * 1e-7,
            alt_m: f64::from(alt_mm) * 1e-3,
        };
        ((-90.0..=90.0).contains(&o.lat_deg) && (-180.0..=180.0).contains(&o.lon_deg)).then_some(o)
    }

    /// Metres per radian north and east at the origin: the WGS-84 ellipsoid's meridian and
    /// prime-vertical radii of curvature (a local tangent plane, exact enough within the
    /// 1 km a mission may reach).
    fn radii_m(&self) -> (f64, f64) {
        const A: f64 = 6_378_137.0;
        const E2: f64 = 6.694_379_990_14e-3;
        let s = self.lat_deg.to_radians().sin();
        let w = (1.0 - E2 * s * s).sqrt();
        (A * (1.0 - E2) / (w * w * w), A / w)
    }

    /// North and east of the origin (m) of a latitude and longitude (degrees).
    pub fn to_local(&self, lat_deg: f64, lon_deg: f64) -> [f64; 2] {
        let (rn, re) = self.radii_m();
        let dlon = (lon_deg - self.lon_deg + 540.0).rem_euclid(360.0) - 180.0;
        [
            (lat_deg - self.lat_deg).to_radians() * rn,
            dlon.to_radians() * re * self.lat_deg.to_radians().cos(),
        ]
    }

    /// Latitude and longitude (degrees) of a point north and east of the origin (m).
    pub fn to_global(&self, north_m: f64, east_m: f64) -> [f64; 2] {
        let (rn, re) = self.radii_m();
        [
            self.lat_deg + (north_m / rn).to_degrees(),
            self.lon_deg + (east_m / (re * self.lat_deg.to_radians().cos())).to_degrees(),
        ]
    }
}

/// A mission item's waypoint as `[north, east, depth]` (m) in the local frame: local frames
/// carry metres x 1e4; global ones degrees x 1e7 and an altitude (negative below the
/// surface, ArduSub's convention), relative to the origin's or above mean sea level.
// The `_INT` frames are superseded by their plain names but still sent (QGroundControl's
// older releases, MAVProxy), so both are taken.
#[allow(deprecated)]
pub fn item_position(
    frame: MavFrame,
    x: i32,
    y: i32,
    z: f32,
    origin: Option<&GlobalOrigin>,
) -> std::result::Result<[f32; 3], String> {
    use MavFrame as F;
    let global = |o: Option<&GlobalOrigin>| {
        o.map(|o| o.to_local(f64::from(x) * 1e-7, f64::from(y) * 1e-7))
            .ok_or_else(|| format!("{frame:?} needs SET_GPS_GLOBAL_ORIGIN first"))
    };
    Ok(match frame {
        F::MAV_FRAME_LOCAL_NED => [x as f32 * 1e-4, y as f32 * 1e-4, z],
        F::MAV_FRAME_GLOBAL_RELATIVE_ALT | F::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT => {
            let [n, e] = global(origin)?;
            [n as f32, e as f32, -z]
        }
        F::MAV_FRAME_GLOBAL | F::MAV_FRAME_GLOBAL_INT => {
            let [n, e] = global(origin)?;
            let surface = origin.map_or(0.0, |o| o.alt_m);
            [n as f32, e as f32, (surface - f64::from(z)) as f32]
        }
        other => {
            return Err(format!(
                "frame {other:?}: MAV_FRAME_LOCAL_NED or a global frame"
            ))
        }
    })
}
