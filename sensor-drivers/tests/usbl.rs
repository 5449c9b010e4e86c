//! NMEA 0183 from a USBL / underwater GPS: Water Linked's `$PSIMSSB` example, the
//! Kongsberg field layout as integrators document it, Water Linked's GGA bridge test vectors
//! and the NMEA standard's GGA example; the refusals and the local frame.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use sensor_drivers::usbl::{parse, xor_checksum, LocalOrigin, NmeaError, Orientation, Sentence};

fn ssb(line: &[u8]) -> sensor_drivers::usbl::SsbFix {
    match parse(line) {
        Ok(Sentence::Ssb(s)) => s,
        other => panic!("{other:?}"),
    }
}

fn gga(line: &[u8]) -> sensor_drivers::usbl::GgaFix {
    match parse(line) {
        Ok(Sentence::Gga(g)) => g,
        other => panic!("{other:?}"),
    }
}

/// Water Linked's Underwater GPS examples (`nmeaoutput` to Olex): "Valid sentence", north up.
#[test]
fn water_linked_psimssb_example_decodes() {
    let s = ssb(b"$PSIMSSB,180554.432,M44,A,,C,N,M,-61.300,39.017,34.026,0.072,T,0.050576,*47\r\n");
    assert!((s.time_of_day_s - (18.0 * 3600.0 + 5.0 * 60.0 + 54.432)).abs() < 1e-9);
    assert_eq!(&s.transponder[..3], b"M44");
    assert_eq!(s.orientation, Orientation::NorthUp);
    assert_eq!(s.filter, b'M');
    assert_eq!((s.x_m, s.y_m, s.depth_m), (-61.300, 39.017, 34.026));
    assert_eq!(s.accuracy_m, Some(0.072));
}

/// The example of an integrator's manual (Navis NavDP, "Simrad SSBL"), head up: its printed
/// checksum `*20` is not the XOR of the sentence (0x0C), so it is refused as printed and
/// read with the right one.
#[test]
fn head_up_example_with_a_wrong_printed_checksum() {
    assert_eq!(
        parse(b"$PSIMSSB,085405.61,B42,A,,C,H,M,134.5,114.5,120.0,,,,*20"),
        Err(NmeaError::Checksum {
            sent: 0x20,
            computed: 0x0c
        })
    );
    let s = ssb(b"$PSIMSSB,085405.61,B42,A,,C,H,M,134.5,114.5,120.0,,,,*0C");
    assert_eq!(s.orientation, Orientation::HeadUp);
    assert_eq!((s.x_m, s.y_m, s.depth_m), (134.5, 114.5, 120.0));
    assert_eq!(s.accuracy_m, None);
    assert!((s.time_of_day_s - (8.0 * 3600.0 + 54.0 * 60.0 + 5.61)).abs() < 1e-9);
}

#[test]
fn psimssb_refusals() {
    // Status V with an error code.
    assert_eq!(
        parse(b"$PSIMSSB,180554.432,M44,V,NRY,C,N,M,-61.300,39.017,34.026,0.072,T,0.050576,*15"),
        Err(NmeaError::NotOk)
    );
    let with_sum =
        |body: &str| format!("${body}*{:02X}", xor_checksum(body.as_bytes())).into_bytes();
    // Polar and UTM coordinates are not read.
    for cs in ["P", "U", "R"] {
        let body = format!("PSIMSSB,180554.43,B01,A,,{cs},N,M,1.0,2.0,3.0,,,,");
        assert_eq!(
            parse(&with_sum(&body)),
            Err(NmeaError::NotCartesian),
            "{cs}"
        );
    }
    // Missing field, extra field, bad time, bad filter, non-finite coordinate.
    for body in [
        "PSIMSSB,180554.43,B01,A,,C,N,M,1.0,2.0,3.0,,,",
        "PSIMSSB,180554.43,B01,A,,C,N,M,1.0,2.0,3.0,,,,,",
        "PSIMSSB,186554.43,B01,A,,C,N,M,1.0,2.0,3.0,,,,",
        "PSIMSSB,1805,B01,A,,C,N,M,1.0,2.0,3.0,,,,",
        "PSIMSSB,180554.43,B01,A,,C,N,X,1.0,2.0,3.0,,,,",
        "PSIMSSB,180554.43,B01,A,,C,N,M,inf,2.0,3.0,,,,",
        "PSIMSSB,180554.43,B01,A,,C,Q,M,1.0,2.0,3.0,,,,",
        "PSIMSSB,180554.43,,A,,C,N,M,1.0,2.0,3.0,,,,",
        "PSIMSSB,180554.43,B01,A,,C,N,M,1.0,2.0,,,,,",
    ] {
        assert!(
            matches!(parse(&with_sum(body)), Err(NmeaError::Field(_))),
            "{body}: {:?}",
            parse(&with_sum(body))
        );
    }
    // Water Linked's example script's own head-up output puts `T` where the accuracy goes
    // and has 13 fields, not 14: refused, not guessed at.
    let wl_script = "PSIMSSB,120000,UGPS,A,,C,H,M,1.50,-2.25,10.00,T,,";
    assert!(matches!(
        parse(&with_sum(wl_script)),
        Err(NmeaError::Field(_))
    ));
    // Framing.
    assert_eq!(
        parse(b"PSIMSSB,180554.43,B01,A,,C,N,M,1.0,2.0,3.0,,,,*00"),
        Err(NmeaError::NoStart)
    );
    assert_eq!(
        parse(b"$PSIMSSB,180554.43,B01,A,,C,N,M,1.0,2.0,3.0,,,,"),
        Err(NmeaError::NoChecksum)
    );
    assert_eq!(
        parse(&with_sum(
            "GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W"
        )),
        Err(NmeaError::Unsupported)
    );
}

/// The NMEA standard's GGA example (as quoted by every NMEA reference).
#[test]
fn standard_gga_example_decodes() {
    let g = gga(b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n");
    assert_eq!(g.time_of_day_s, Some(12.0 * 3600.0 + 35.0 * 60.0 + 19.0));
    assert!((g.latitude_deg - (48.0 + 7.038 / 60.0)).abs() < 1e-12);
    assert!((g.longitude_deg - (11.0 + 31.0 / 60.0)).abs() < 1e-12);
    assert_eq!(g.quality, 1);
    assert_eq!(g.satellites, Some(8));
    assert_eq!(g.hdop, Some(0.9));
    assert_eq!(g.altitude_m, Some(545.4));
}

/// Water Linked's Underwater GPS NMEA bridge (`ugps-nmea-go`, its serialiser's tests): the
/// vehicle's depth as a negative altitude. Its vectors at 1.23 deg N, 2.34 deg E print the
/// latitude unpadded (`113.8` for 1 deg 13.8'); the `nmea` crate would read that as 11 deg
/// 3.8', so such a field is refused. The same fix with the fields padded decodes.
#[test]
fn water_linked_gga_vectors() {
    for line in [
        &b"$GPGGA,203458.651,113.8,N,220.4,E,1,5,2.3,-5.37,M,,M,,*5F"[..],
        b"$GPGGA,203458.651,113.8,S,220.4,W,5,5,2.3,-2.11,M,,M,,*57",
        b"$GPGGA,203458.651,113.8,N,220.4,E,1,0,,-0.30,M,,M,,*77",
    ] {
        assert_eq!(parse(line), Err(NmeaError::LatLon));
    }
    // The crate alone reads the unpadded field as 11 deg 3.8' (why the check exists).
    match nmea::parse_str("$GPGGA,203458.651,113.8,N,220.4,E,1,5,2.3,-5.37,M,,M,,*5F") {
        Ok(nmea::ParseResult::GGA(d)) => {
            assert!((d.latitude.unwrap() - (11.0 + 3.8 / 60.0)).abs() < 1e-9)
        }
        other => panic!("{other:?}"),
    }
    // Its "empty" vector: no position, quality 0.
    assert_eq!(
        parse(b"$GPGGA,000000.000,,,,,0,0,,0.00,M,,M,,*56"),
        Err(NmeaError::NoFix)
    );
    let g = gga(b"$GPGGA,203458.651,6326.1234,N,01023.4567,E,1,5,2.3,-5.37,M,,M,,*65");
    assert!((g.time_of_day_s.unwrap() - (20.0 * 3600.0 + 34.0 * 60.0 + 58.651)).abs() < 1e-9);
    assert!((g.latitude_deg - (63.0 + 26.1234 / 60.0)).abs() < 1e-12);
    assert!((g.longitude_deg - (10.0 + 23.4567 / 60.0)).abs() < 1e-12);
    assert_eq!(g.altitude_m, Some(-5.37));
    assert_eq!((g.quality, g.satellites, g.hdop), (1, Some(5), Some(2.3)));
}

#[test]
fn gga_refusals() {
    let with_sum =
        |body: &str| format!("${body}*{:02X}", xor_checksum(body.as_bytes())).into_bytes();
    // Quality 0 with a position.
    assert_eq!(
        parse(&with_sum(
            "GPGGA,123519,4807.038,N,01131.000,E,0,08,0.9,545.4,M,46.9,M,,"
        )),
        Err(NmeaError::NoFix)
    );
    // Minutes >= 60, a longitude of 181 degrees, no decimals.
    for body in [
        "GPGGA,123519,4867.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
        "GPGGA,123519,4807.038,N,18131.000,E,1,08,0.9,545.4,M,46.9,M,,",
        "GPGGA,123519,4807,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,",
    ] {
        assert_eq!(parse(&with_sum(body)), Err(NmeaError::LatLon), "{body}");
    }
    // A bad checksum.
    assert_eq!(
        parse(b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*48"),
        Err(NmeaError::Checksum {
            sent: 0x48,
            computed: 0x47
        })
    );
}

/// One arc-minute of latitude is 1855.3 m on the WGS-84 equatorial radius; east shrinks with
/// the cosine of the latitude.
#[test]
fn local_frame_of_the_dive_origin() {
    let o = LocalOrigin {
        latitude_deg: 60.0,
        longitude_deg: 10.0,
    };
    let [n, e] = o.north_east_m(60.0 + 1.0 / 60.0, 10.0 + 1.0 / 60.0);
    assert!((n - 1855.325).abs() < 0.01, "{n}");
    assert!((e - 1855.325 * 0.5).abs() < 0.01, "{e}");
    let [n, e] = o.north_east_m(60.0, 10.0);
    assert_eq!([n, e], [0.0, 0.0]);
    // Across the antimeridian the short way round.
    let o = LocalOrigin {
        latitude_deg: 0.0,
        longitude_deg: 179.9999,
    };
    let [_, e] = o.north_east_m(0.0, -179.9999);
    assert!((e - 22.26).abs() < 0.01, "{e}");
}
