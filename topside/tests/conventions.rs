//! The surface program's conventions with ground stations: ArduSub's sticks, the global
//! origin's degrees and metres, status texts within MAVLink's 50 characters.

#[test]
fn the_global_origin_maps_degrees_to_metres_both_ways() {
    use topside::surface::GlobalOrigin;
    let o = GlobalOrigin::from_mavlink(450_000_000, 100_000_000, 0).unwrap();
    // At 45 degrees the WGS-84 meridian radius is 6,367,381.8 m: 1e-5 degree is 1.11132 m.
    let [n, e] = o.to_local(45.00001, 10.0);
    assert!((n - 1.111_32).abs() < 1e-4 && e.abs() < 1e-9, "{n} {e}");
    for (n, e) in [(4.0, -3.0), (-700.0, 650.0), (0.01, 0.02)] {
        let [lat, lon] = o.to_global(n, e);
        let [n2, e2] = o.to_local(lat, lon);
        assert!((n2 - n).abs() < 1e-6 && (e2 - e).abs() < 1e-6);
    }
    assert!(GlobalOrigin::from_mavlink(950_000_000, 0, 0).is_none());
}

#[test]
fn long_status_texts_are_split_between_words() {
    use topside::surface::split_text;
    let t =
        "VEH_BUOY refused: not safe to fly: buoyancy_offset_n: more than half the vertical thrust";
    let lines = split_text(t, 50);
    assert!(lines.iter().all(|l| l.chars().count() <= 50), "{lines:?}");
    assert_eq!(lines.join(" "), t);
    assert_eq!(split_text("short", 50), ["short"]);
    assert_eq!(split_text(&"x".repeat(120), 50).concat(), "x".repeat(120));
}

#[test]
fn manual_control_follows_ardusub_conventions() {
    use topside::surface::manual_thrust;
    let m = manual_thrust(1000, 500, 0);
    assert_eq!((m.surge, m.yaw, m.heave), (1.0, 0.0, 0.0));
    // z above 500 is up; the core's heave is positive down.
    assert_eq!(manual_thrust(0, 1000, 0).heave, -1.0);
    assert_eq!(manual_thrust(0, 0, 0).heave, 1.0);
    assert_eq!(manual_thrust(0, 500, -1000).yaw, -1.0);
    // Out-of-range sticks are clamped, never passed on.
    assert!(manual_thrust(i16::MAX, i16::MIN, i16::MIN).is_valid());
}
