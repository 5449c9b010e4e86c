//! PD6: Water Linked's documented PD6 output (their "PD formats" page, the example copied
//! from their encoder's test) decodes to its values; the "no value" -32768 and the `V`
//! status of Teledyne's field definitions; the refusals.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use sensor_drivers::fields::FieldError;
use sensor_drivers::pd6::{parse, Ensemble, Line, Pd6Error, VelocityGroup};

/// The documented ensemble, line by line, as the DVL sends it (CR LF).
const WATER_LINKED_EXAMPLE: [&str; 10] = [
    ":SA, +0.00, +0.00,  0.00",
    ":TS,22020812061800, 0.0, +0.0,   0.0,1475.0,  0",
    ":WI,    +0,    +0,    +0,    +0,V",
    ":WS,    +0,    +0,    +0,V",
    ":WE,    +0,    +0,    +0,V",
    ":WD,       +0.00,       +0.00,       +0.00,   0.00,  0.00",
    ":BI,  +123,  -420, +2000,    +0,A",
    ":BS,  -420,  +123, +2000,A",
    ":BE,    +0,    +0,    +0,V",
    ":BD,       +0.00,       +0.00,       +0.00,   5.32,  0.00",
];

#[test]
fn documented_water_linked_example_decodes() {
    let lines: Vec<Line> = WATER_LINKED_EXAMPLE
        .iter()
        .map(|l| parse(format!("{l}\r\n").as_bytes()).unwrap())
        .collect();
    assert_eq!(lines[0], Line::Other(*b"SA"));
    match lines[1] {
        Line::TimingScaling(t) => {
            assert_eq!(t.stamp, [22, 2, 8, 12, 6, 18, 0]);
            assert_eq!(t.salinity_ppt, 0.0);
            assert_eq!(t.temperature_c, 0.0);
            assert_eq!(t.depth_m, 0.0);
            assert_eq!(t.speed_of_sound_m_s, 1475.0);
            assert_eq!(t.bit, 0);
        }
        ref other => panic!("{other:?}"),
    }
    for (i, id) in [(2, b"WI"), (3, b"WS"), (4, b"WE"), (5, b"WD")] {
        assert_eq!(lines[i], Line::Other(*id));
    }
    assert_eq!(
        lines[6],
        Line::BottomInstrument(VelocityGroup {
            velocity_m_s: [Some(0.123), Some(-0.420), Some(2.000)],
            error_m_s: Some(0.0),
            good: true,
        })
    );
    // Ship frame: transverse (the y velocity), longitudinal (x), normal (z).
    assert_eq!(
        lines[7],
        Line::BottomShip(VelocityGroup {
            velocity_m_s: [Some(-0.420), Some(0.123), Some(2.000)],
            error_m_s: None,
            good: true,
        })
    );
    assert_eq!(
        lines[8],
        Line::BottomEarth(VelocityGroup {
            velocity_m_s: [Some(0.0), Some(0.0), Some(0.0)],
            error_m_s: None,
            good: false,
        })
    );
    match lines[9] {
        Line::BottomDistance(d) => {
            assert_eq!(d.distance_m, [0.0, 0.0, 0.0]);
            assert_eq!(d.range_to_bottom_m, 5.32);
            assert_eq!(d.since_good_s, 0.0);
        }
        ref other => panic!("{other:?}"),
    }
    // The ensemble completes at :BD with the instrument-frame velocity usable, the earth
    // frame (status V) not.
    let mut e = Ensemble::new();
    let mut done = None;
    for l in lines {
        if let Some(t) = e.push(l) {
            done = Some(t);
        }
    }
    let t = done.unwrap();
    assert_eq!(t.instrument_velocity_m_s(), Some([0.123, -0.420, 2.000]));
    assert_eq!(t.earth.unwrap().usable(), None);
    assert_eq!(t.ship.unwrap().usable(), Some([-0.420, 0.123, 2.000]));
    assert_eq!(t.distance.unwrap().range_to_bottom_m, 5.32);
    assert_eq!(t.timing.unwrap().speed_of_sound_m_s, 1475.0);
}

/// Teledyne's PD6 definitions: a velocity PD6 does not have is -32768, with status V.
#[test]
fn missing_values_and_bad_status_are_not_usable() {
    for (line, n) in [
        (":BI,-32768,-32768,-32768,-32768,V", 3),
        (":BS,-32768,-32768,-32768,V", 3),
        (":BE,-32768,-32768,-32768,V", 3),
        (":BI,  +123,-32768, +2000,    +0,A", 1),
    ] {
        let g = match parse(line.as_bytes()).unwrap() {
            Line::BottomInstrument(g) | Line::BottomShip(g) | Line::BottomEarth(g) => g,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            g.velocity_m_s.iter().filter(|v| v.is_none()).count(),
            n,
            "{line}"
        );
        assert_eq!(g.usable(), None, "{line}");
    }
    // Good status with all three present: usable.
    let Line::BottomEarth(g) = parse(b":BE,   +15,   -20,    +1,A").unwrap() else {
        panic!()
    };
    assert_eq!(g.usable(), Some([0.015, -0.020, 0.001]));
}

#[test]
fn malformed_lines_are_refused() {
    let cases: [(&[u8], Pd6Error); 9] = [
        (b"BI,  +123,  -420, +2000,    +0,A", Pd6Error::NoStart),
        (b":bi,  +123,  -420, +2000,    +0,A", Pd6Error::NoStart),
        (
            b":BI,  +123,  -420, +2000,    +0,X",
            Pd6Error::Field(FieldError::Malformed(4)),
        ),
        (
            b":BI,  +123,  -420, +2000,A",
            Pd6Error::Field(FieldError::Malformed(3)),
        ),
        (
            b":BS,  +123,  -420, +2000,A,A",
            Pd6Error::Field(FieldError::Extra),
        ),
        (b":BI,  +123,  -420,+40000,    +0,A", Pd6Error::OutOfRange),
        (
            b":BI,  +1.5,  -420, +2000,    +0,A",
            Pd6Error::Field(FieldError::Malformed(0)),
        ),
        (
            b":BD,       +0.00,       +0.00,       +0.00,  -5.32,  0.00",
            Pd6Error::Field(FieldError::Malformed(3)),
        ),
        (
            b":TS,22130812061800, 0.0, +0.0,   0.0,1475.0,  0",
            Pd6Error::OutOfRange,
        ),
    ];
    for (line, want) in cases {
        assert_eq!(parse(line), Err(want), "{}", String::from_utf8_lossy(line));
    }
    assert!(parse(b":TS,2202081206180, 0.0, +0.0,   0.0,1475.0,  0").is_err());
    assert!(parse(b":BD,+nan,+0.00,+0.00,5.32,0.00").is_err());
}

/// The fixed widths and layouts of the definitions: a character deleted or inserted, a
/// sign missing or added, decimals changed are refused.
#[test]
fn fields_off_their_width_or_layout_are_refused() {
    for line in [
        ":BI,+123,-420,+2000,+0,A",
        ":BI,  +123,  -420, +2000,   +0,A",
        ":BI,   +123,  -420, +2000,    +0,A",
        ":BI,   123,  -420, +2000,    +0,A",
        ":BI,  +1 3,  -420, +2000,    +0,A",
        ":BI, +0123,  -420, +2000,    +0,A",
        ":BS,  -420,  +123,+ 2000,A",
        ":BD,       +0.00,       +0.00,        0.00,   5.32,  0.00",
        ":BD,       +0.00,       +0.00,       +0.00,   5.3,  0.00",
        ":BD,       +0.00,       +0.00,       +0.00,    5.32,  0.00",
        ":BD,       +0.00,       +0.00,       +0.00,   5.32, 0.00",
        ":TS,22020812061800,  0.0, +0.0,   0.0,1475.0,  0",
        ":TS,22020812061800, 0.0,  0.0,   0.0,1475.0,  0",
        ":TS,22020812061800, 0.0, +0.0,   0.0,1475.00,  0",
        ":TS,22020812061800, 0.0, +0.0,   0.0,1475.0,   0",
    ] {
        assert!(parse(line.as_bytes()).is_err(), "{line}");
    }
}

/// Across an ensemble: the good velocity groups must have the same speed (the ship and
/// earth frames are rotations of the instrument frame); a changed digit in one shows.
#[test]
fn an_ensemble_whose_frames_disagree_gives_no_velocity() {
    let collect = |lines: &[&str]| {
        let mut e = Ensemble::new();
        let mut out = None;
        for l in lines {
            out = e.push(parse(l.as_bytes()).unwrap()).or(out);
        }
        out.unwrap()
    };
    let bd = ":BD,       +0.00,       +0.00,       +0.00,   5.32,  0.00";
    let good = collect(&[
        ":BI,  +123,  -420, +2000,    +0,A",
        ":BS,  -420,  +123, +2000,A",
        ":BE,  +300,  +310, +2000,A",
        bd,
    ]);
    // |(123, -420, 2000)| = 2047.3 mm/s, |(300, 310, 2000)| = 2046.0: within rounding.
    assert!(good.frames_agree());
    assert!(good.instrument_velocity_m_s().is_some());
    let corrupted = collect(&[
        ":BI,  +123,  -420, +2900,    +0,A",
        ":BS,  -420,  +123, +2000,A",
        ":BE,    +0,    +0,    +0,V",
        bd,
    ]);
    assert!(!corrupted.frames_agree());
    assert_eq!(corrupted.instrument_velocity_m_s(), None);
    // One good group: nothing to compare with.
    let alone = collect(&[":BI,  +123,  -420, +2900,    +0,A", bd]);
    assert!(alone.frames_agree());
}
