//! Water Linked DVL A50 serial protocol: every example of Water Linked's "DVL A50/A125
//! serial protocol" page (protocol 2.6.x / 2.7.x) decodes to its documented values, and the
//! refusals (checksum, missing checksum, invalid, figure of merit, malformed fields).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use sensor_drivers::a50::{parse, FrameError, Refusal, Report, VelocityGate, VelocityReport, CRC8};
use sensor_drivers::fields::FieldError;

fn velocity(line: &[u8]) -> VelocityReport {
    match parse(line) {
        Ok(Report::Velocity(v)) => v,
        other => panic!("{other:?}"),
    }
}

/// The protocol page's checksum section: CRC-8, polynomial 0x07, init 0, check value 0xF4.
#[test]
fn crc8_is_the_documented_algorithm() {
    assert_eq!(CRC8.checksum(b"123456789"), 0xf4);
    // The page's worked verification: `wrx,1164.94,...,n,1` carries `*39`.
    assert_eq!(
        CRC8.checksum(b"wrx,1164.94,0.000,0.000,0.000,2.707,-1.00,n,1"),
        0x39
    );
}

/// "Example where all velocities are valid" (velocity report, wrz).
#[test]
fn documented_wrz_example_decodes() {
    let v = velocity(
        b"wrz,0.120,-0.400,2.000,y,1.30,1.855,1e-07;0;1.4;0;1.2;0;0.2;0;1e+09,7,14,123.00,1*50\r\n",
    );
    assert_eq!(v.velocity_m_s, [0.120, -0.400, 2.000]);
    assert!(v.valid);
    assert_eq!(v.altitude_m, 1.30);
    assert_eq!(v.fom_m_s, 1.855);
    assert_eq!(
        v.covariance,
        [1e-07, 0.0, 1.4, 0.0, 1.2, 0.0, 0.2, 0.0, 1e+09]
    );
    assert_eq!(v.time_of_validity_us, 7);
    assert_eq!(v.time_of_transmission_us, 14);
    assert_eq!(v.since_last_ms, 123.0);
    assert_eq!(v.status, 1);
}

/// Every line ending the page allows: LF, CR LF, CR, and none (a line already split).
#[test]
fn every_documented_line_ending_is_accepted() {
    let base =
        b"wrz,0.120,-0.400,2.000,y,1.30,1.855,1e-07;0;1.4;0;1.2;0;0.2;0;1e+09,7,14,123.00,1*50";
    for end in [&b""[..], b"\n", b"\r\n", b"\r"] {
        let mut line = base.to_vec();
        line.extend_from_slice(end);
        assert!(matches!(parse(&line), Ok(Report::Velocity(_))), "{end:?}");
    }
}

/// The two dead-reckoning examples (wrp).
#[test]
fn documented_wrp_examples_decode() {
    let cases: [(&[u8], u64, [f32; 3]); 2] = [
        (
            b"wrp,49056.809,0.41,0.15,1.23,0.4,53.9,13.0,19.3,0*de",
            49_056_809_000,
            [0.41, 0.15, 1.23],
        ),
        (
            b"wrp,49057.269,0.39,0.18,1.23,0.4,53.9,13.0,19.3,0*e2",
            49_057_269_000,
            [0.39, 0.18, 1.23],
        ),
    ];
    for (line, t, p) in cases {
        match parse(line) {
            Ok(Report::DeadReckoning(d)) => {
                assert_eq!(d.time_us, t);
                assert_eq!(d.position_m, p);
                assert_eq!(d.position_std_m, 0.4);
                assert_eq!(d.attitude_deg, [53.9, 13.0, 19.3]);
                assert_eq!(d.status, 0);
            }
            other => panic!("{other:?}"),
        }
    }
}

/// The page's other report examples (transducer wru, old-format wrx and wrt): their
/// checksums verify, and the vehicle is told which report letter they are.
#[test]
fn documented_other_reports_pass_the_checksum() {
    let lines: [(&[u8], u8); 13] = [
        (b"wru,0,0.070,1.10,-40,-95*9c", b'u'),
        (b"wru,1,-0.500,1.25,-62,-104*f0", b'u'),
        (b"wru,2,2.200,1.40,-56,-98*18", b'u'),
        (b"wru,3,1.800,1.35,-58,-96*a3", b'u'),
        (b"wrx,112.83,0.007,0.017,0.006,0.000,0.93,y,0*d2", b'x'),
        (b"wrx,140.43,0.008,0.021,0.012,0.000,0.92,y,0*b7", b'x'),
        (b"wrx,118.47,0.009,0.020,0.013,0.000,0.92,y,0*54", b'x'),
        (b"wrx,1075.51,0.000,0.000,0.000,2.707,-1.00,n,1*04", b'x'),
        (b"wrx,1249.29,0.000,0.000,0.000,2.707,-1.00,n,1*6a", b'x'),
        (b"wrx,1164.94,0.000,0.000,0.000,2.707,-1.00,n,1*39", b'x'),
        (b"wrt,15.00,15.20,14.90,14.20*b1", b't'),
        (b"wrt,14.90,15.10,14.80,14.10*ac", b't'),
        (b"wrt,14.90,15.10,14.80,-1.00*53", b't'),
    ];
    for (line, letter) in lines {
        assert_eq!(parse(line), Ok(Report::Other(letter)), "{line:?}");
    }
    assert_eq!(
        parse(b"wrt,15.00,15.20,14.90,-1.00*71"),
        Ok(Report::Other(b't'))
    );
}

/// The page's water-tracking example (`wrs`) carries `*50`, copied from the `wrz` example
/// above it; its own CRC-8 is 0x7b, so the line as printed is refused.
#[test]
fn documented_wrs_example_has_a_copied_checksum_and_is_refused() {
    assert_eq!(
        parse(b"wrs,0.120,-0.400,2.000,y,1.855,1e-07;0;1.4;0;1.2;0;0.2;0;1e+09,7,14,123.00,1*50"),
        Err(FrameError::Checksum {
            sent: 0x50,
            computed: 0x7b
        })
    );
    assert_eq!(
        parse(b"wrs,0.120,-0.400,2.000,y,1.855,1e-07;0;1.4;0;1.2;0;0.2;0;1e+09,7,14,123.00,1*7b"),
        Ok(Report::Other(b's'))
    );
}

/// Builds a `wrz` line with its CRC-8, as the DVL does.
fn wrz(body: &str) -> Vec<u8> {
    let covered = format!("wrz,{body}");
    format!("{covered}*{:02x}\r\n", CRC8.checksum(covered.as_bytes())).into_bytes()
}

#[test]
fn a_bad_or_missing_checksum_is_refused() {
    let good =
        b"wrz,0.120,-0.400,2.000,y,1.30,1.855,1e-07;0;1.4;0;1.2;0;0.2;0;1e+09,7,14,123.00,1*50";
    let mut flipped = good.to_vec();
    flipped[5] = b'2'; // 0.120 -> 0.220
    assert!(matches!(
        parse(&flipped),
        Err(FrameError::Checksum { sent: 0x50, .. })
    ));
    let no_sum = &good[..good.len() - 3];
    assert_eq!(parse(no_sum), Err(FrameError::NoChecksum));
    let one_digit = &good[..good.len() - 1];
    assert_eq!(parse(one_digit), Err(FrameError::NoChecksum));
    assert_eq!(parse(b"xrz,1*00"), Err(FrameError::NoStart));
    assert_eq!(parse(b""), Err(FrameError::NoStart));
}

#[test]
fn malformed_fields_are_refused_even_with_a_right_checksum() {
    let cases = [
        // 10 fields, not 11.
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00",
        // An extra field.
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0,9",
        // Eight covariance entries.
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0,7,14,123.00,0",
        // Ten covariance entries.
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        // Valid flag neither y nor n.
        "0.100,0.200,0.300,Y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        // Not-a-number and infinite velocities.
        "NaN,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        "inf,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        // Empty field.
        "0.100,,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        // Negative or fractional time stamp.
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,-7,14,123.00,0",
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7.5,14,123.00,0",
        // Status beyond 8 bits.
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,256",
    ];
    for body in cases {
        assert!(
            matches!(parse(&wrz(body)), Err(FrameError::Field(_))),
            "{body}: {:?}",
            parse(&wrz(body))
        );
    }
    assert_eq!(
        parse(&wrz(
            "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00"
        )),
        Err(FrameError::Field(FieldError::Missing(10)))
    );
    // The documented layout: 3 decimals for velocities and the figure of merit, 2 for
    // altitude and time (what a deleted or inserted digit breaks, which the CRC-8 misses
    // once in 256).
    for body in [
        "0.10,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        "0.100,0.200,0.3000,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        "0.100,0.200,0.300,y,1.0,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        "0.100,0.200,0.300,y,1.00,0.01,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.0,0",
        "0.100,0.200,.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        "0.100,0.200,1e-3,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
    ] {
        assert!(
            matches!(parse(&wrz(body)), Err(FrameError::Field(_))),
            "{body}"
        );
    }
    // Transmitted before its validity, or more than a second after.
    for body in [
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,15,14,123.00,0",
        "0.100,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,1000008,123.00,0",
    ] {
        assert_eq!(parse(&wrz(body)), Err(FrameError::OutOfRange), "{body}");
    }
    // Speeds no DVL reports, a negative figure of merit.
    for body in [
        "25.000,0.200,0.300,y,1.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        "0.100,0.200,0.300,y,1.00,-0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
        "0.100,0.200,0.300,y,500.00,0.010,0;0;0;0;0;0;0;0;0,7,14,123.00,0",
    ] {
        assert_eq!(parse(&wrz(body)), Err(FrameError::OutOfRange), "{body}");
    }
}

#[test]
fn the_gate_refuses_no_lock_and_a_poor_figure_of_merit() {
    let gate = VelocityGate { max_fom_m_s: 0.05 };
    let good = velocity(&wrz(
        "0.100,0.200,0.300,y,1.00,0.010,1e-4;0;0;0;1e-4;0;0;0;1e-4,1700000000000000,1700000000050000,100.00,0",
    ));
    assert_eq!(gate.admit(&good), Ok(good));
    // The documented "not valid" figures: altitude -1.00, figure of merit 2.707, valid n.
    let lost = velocity(&wrz(
        "0.000,0.000,0.000,n,-1.00,2.707,0;0;0;0;0;0;0;0;0,1,2,1075.51,1",
    ));
    assert_eq!(gate.admit(&lost), Err(Refusal::NoBottomLock));
    let poor = velocity(&wrz(
        "0.100,0.200,0.300,y,1.00,0.060,0;0;0;0;0;0;0;0;0,1,2,100.00,0",
    ));
    assert_eq!(
        gate.admit(&poor),
        Err(Refusal::PoorFigureOfMerit {
            fom_m_s: 0.06,
            max_m_s: 0.05
        })
    );
    // The documented example's figure of merit, 1.855 m/s, is refused by the default gate.
    let doc = velocity(
        b"wrz,0.120,-0.400,2.000,y,1.30,1.855,1e-07;0;1.4;0;1.2;0;0.2;0;1e+09,7,14,123.00,1*50",
    );
    assert!(matches!(
        VelocityGate::default().admit(&doc),
        Err(Refusal::PoorFigureOfMerit { .. })
    ));
    let nan_gate = VelocityGate {
        max_fom_m_s: f32::NAN,
    };
    assert!(nan_gate.admit(&good).is_err());
}

/// A covariance that is not one (asymmetric, a negative variance) or a valid report with
/// a negative altitude: a digit lost in transit that the CRC-8 let through.
#[test]
fn the_gate_refuses_a_report_that_contradicts_itself() {
    let gate = VelocityGate::default();
    let body = |cov: &str, alt: &str| {
        format!("0.100,0.200,0.000,y,{alt},0.010,{cov},1700000000000000,1700000000050000,100.00,0")
    };
    let sym = "1e-4;2e-5;0;2e-5;1e-4;3e-6;0;3e-6;1e-4";
    assert!(gate.admit(&velocity(&wrz(&body(sym, "1.00")))).is_ok());
    for (cov, alt) in [
        ("1e-4;2e-5;0;2e-6;1e-4;3e-6;0;3e-6;1e-4", "1.00"),
        ("1e-4;2e-5;1e-5;2e-5;1e-4;3e-6;0;3e-6;1e-4", "1.00"),
        ("1e-4;2e-5;0;2e-5;1e-4;3e-6;0;3e-5;1e-4", "1.00"),
        ("-1e-4;2e-5;0;2e-5;1e-4;3e-6;0;3e-6;1e-4", "1.00"),
        ("1e-4;2e-5;0;2e-5;1e-4;3e-6;0;3e-6;1e4", "1.00"),
        ("1e-4;2e-3;0;2e-3;1e-4;3e-6;0;3e-6;1e-4", "1.00"),
        (sym, "-1.00"),
    ] {
        assert_eq!(
            gate.admit(&velocity(&wrz(&body(cov, alt)))),
            Err(Refusal::Inconsistent),
            "{cov} {alt}"
        );
    }
}
