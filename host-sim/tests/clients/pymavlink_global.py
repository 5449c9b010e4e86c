"""A mission in a global frame: refused before an origin is set, flown after.

Usage: pymavlink_global.py PORT. The ground station sets the local frame's origin with
SET_GPS_GLOBAL_ORIGIN, sees GLOBAL_POSITION_INT on the map's terms, uploads two waypoints in
MAV_FRAME_GLOBAL_RELATIVE_ALT_INT (latitude and longitude computed by pymavlink's own
`gps_offset`, altitude negative below the surface as ArduSub takes it) and flies them in AUTO.
"""
import math
import sys
import time

from pymavlink import mavextra, mavutil

from gcs import arm_and_auto, expect, wait

MANUAL = 19
mav = mavutil.mavlink
LAT0, LON0, ALT0_MM = 59.4300000, 10.6000000, 0  # a fjord


def upload(m, items, frame):
    """items: [(lat_deg, lon_deg, alt_m)]; returns the MISSION_ACK type and STATUSTEXTs."""
    m.mav.mission_count_send(m.target_system, m.target_component, len(items))
    texts = []
    while True:
        msg = m.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK",
                                 "STATUSTEXT"], blocking=True, timeout=10)
        expect(msg is not None, "the vehicle answers the upload")
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
            continue
        if msg.get_type() == "MISSION_ACK":
            return msg.type, texts
        lat, lon, alt = items[msg.seq]
        m.mav.mission_item_int_send(m.target_system, m.target_component, msg.seq, frame,
                                    mav.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0.5, 0, 0,
                                    int(round(lat * 1e7)), int(round(lon * 1e7)), alt)


def main():
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{int(sys.argv[1])}", source_system=255)
    expect(m.wait_heartbeat(timeout=30) is not None, "a HEARTBEAT arrives")
    frame = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    # Waypoints 4 m north, then 4 m north and 4 m east of the origin, 2 m deep.
    pts = [mavextra.gps_offset(LAT0, LON0, 0.0, 4.0), mavextra.gps_offset(LAT0, LON0, 4.0, 4.0)]
    items = [(lat, lon, -2.0) for lat, lon in pts]

    r, texts = upload(m, items, frame)
    expect(r == mav.MAV_MISSION_UNSUPPORTED_FRAME and any("ORIGIN" in t for t in texts),
           f"a global mission before an origin is refused, saying why ({r}, {texts})")

    m.mav.set_gps_global_origin_send(m.target_system, int(LAT0 * 1e7), int(LON0 * 1e7), ALT0_MM)
    o = wait(m, "GPS_GLOBAL_ORIGIN", 5)
    expect(o is not None and o.latitude == int(LAT0 * 1e7) and o.longitude == int(LON0 * 1e7),
           "GPS_GLOBAL_ORIGIN answers with the origin set")
    g = wait(m, "GLOBAL_POSITION_INT", 5)
    expect(g is not None, "GLOBAL_POSITION_INT streams once the origin is set")
    p = wait(m, "LOCAL_POSITION_NED", 5)
    # North of the origin by pymavlink's own geodesy (a sphere; centimetres over metres).
    dn = math.copysign(mavextra.distance_lat_lon(LAT0, LON0, g.lat * 1e-7, LON0), g.lat * 1e-7 - LAT0)
    expect(abs(dn - p.x) < 0.05 and abs(g.relative_alt / 1000.0 + p.z) < 0.05,
           f"it is the local position on the globe (north {dn:.3f} vs {p.x:.3f} m, "
           f"relative alt {g.relative_alt / 1000.0:.3f} vs depth {p.z:.3f} m)")

    r, texts = upload(m, items, frame)
    expect(r == mav.MAV_MISSION_ACCEPTED, f"the global mission is accepted ({r}, {texts})")

    arm_and_auto(m)
    reached = []
    end = time.time() + 90
    while len(reached) < 2 and time.time() < end:
        r = m.recv_match(type="MISSION_ITEM_REACHED", blocking=True, timeout=1)
        if r is not None:
            reached.append(r.seq)
    expect(reached == [0, 1], f"both waypoints reached, in order ({reached})")
    # Settle, reading everything (a sleeping client's socket overflows).
    g = p = None
    end = time.time() + 6
    while time.time() < end:
        msg = m.recv_match(blocking=True, timeout=0.1)
        if msg is not None and msg.get_type() == "GLOBAL_POSITION_INT":
            g = msg
        if msg is not None and msg.get_type() == "LOCAL_POSITION_NED":
            p = msg
    expect(g is not None and p is not None, "the position streams")
    off_global = mavextra.distance_lat_lon(g.lat * 1e-7, g.lon * 1e-7, *items[-1][:2])
    off_local = math.hypot(p.x - 4.0, p.y - 4.0)
    print(f"  at the end: {off_global:.3f} m from the last waypoint on the globe, "
          f"local ({p.x:.3f}, {p.y:.3f}, {p.z:.3f}) m")
    expect(off_global < 0.5 and off_local < 0.5 and abs(p.z - 2.0) < 0.1,
           "the vehicle holds the last global waypoint: 4 m north, 4 m east, 2 m deep")
    m.mav.set_mode_send(m.target_system, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MANUAL)
    m.mav.command_long_send(m.target_system, m.target_component,
                            mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    a = wait(m, "COMMAND_ACK", 10, lambda a: a.command == mav.MAV_CMD_COMPONENT_ARM_DISARM)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "disarmed")


if __name__ == "__main__":
    main()
