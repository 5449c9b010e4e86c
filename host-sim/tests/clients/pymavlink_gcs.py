"""What a ground station asks at connection, go-to in every frame ArduSub takes, and the
refusals a station reads, against `rov-topside --tcp` in front of `host-sim vehicle`.

Usage: pymavlink_gcs.py PORT. Listens on udpin:127.0.0.1:PORT. Prints PASS lines, every
STATUSTEXT received as `TEXT: ...` (the test checks them for internal names), exits 0 or
raises.
"""
import math
import re
import sys
import time

from pymavlink import mavutil

from gcs import expect

mav = mavutil.mavlink
GUIDED, POSHOLD, AUTO = 4, 16, 3
TEXTS = []
# Where the texts answering the latest message sent begin.
MARK = [0]


def sent():
    MARK[0] = len(TEXTS)
ORIGIN = (-35.3632620, 149.1652370)


def recv(m, kind, timeout=10.0, cond=lambda msg: True):
    """The next message of type `kind` (a name or a list) for which `cond` holds, every
    STATUSTEXT meanwhile recorded and printed."""
    kinds = [kind] if isinstance(kind, str) else kind
    end = time.time() + timeout
    while time.time() < end:
        msg = m.recv_match(blocking=True, timeout=max(0.05, end - time.time()))
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            TEXTS.append(msg.text)
            print(f"TEXT: {msg.text}", flush=True)
        if msg.get_type() in kinds and cond(msg):
            return msg
    return None


def drain(m, seconds):
    recv(m, "NOTHING", seconds)


def command(m, cmd, *params):
    p = list(params) + [0] * (7 - len(params))
    sent()
    m.mav.command_long_send(m.target_system, m.target_component, cmd, 0, *p)
    return recv(m, "COMMAND_ACK", 10, lambda a: a.command == cmd)


def set_mode(m, mode):
    return command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)


def said(m, pattern, seconds=3.0):
    """A STATUSTEXT matching `pattern` since the latest message sent, within `seconds` (a
    long text comes as several of 50 characters: they are joined)."""
    end = time.time() + seconds
    while True:
        if re.search(pattern, " ".join(TEXTS[MARK[0]:])):
            return True
        if time.time() >= end:
            return False
        recv(m, "NOTHING", 0.2)


def position(m):
    p = recv(m, "LOCAL_POSITION_NED", 5)
    return (p.x, p.y, p.z) if p else None


def reaches(m, target, what, timeout=90.0, within=0.3):
    """The vehicle's position comes within `within` of `target` and stays 2 s."""
    end = time.time() + timeout
    since, last = None, None
    while time.time() < end:
        p = recv(m, "LOCAL_POSITION_NED", 5)
        if p is None:
            continue
        last = (p.x, p.y, p.z)
        d = math.dist(last, target)
        if d <= within:
            since = since or time.time()
            if time.time() - since >= 2.0:
                expect(True, f"{what}: at ({p.x:.2f}, {p.y:.2f}, {p.z:.2f}), {d:.3f} m from "
                             f"({target[0]:.2f}, {target[1]:.2f}, {target[2]:.2f})")
                return last
        else:
            since = None
    expect(False, f"{what}: not within {within} m of {target} (last {last})")


def target_local(m, frame, x, y, z, mask=0b110111111000):
    sent()
    m.mav.set_position_target_local_ned_send(0, m.target_system, m.target_component, frame,
                                             mask, x, y, z, 0, 0, 0, 0, 0, 0, 0, 0)


def offset(north, east):
    """The point `north`, `east` metres from the origin (WGS-84 radii of curvature, as the
    surface converts)."""
    a, e2 = 6378137.0, 6.69437999014e-3
    lat = math.radians(ORIGIN[0])
    s = 1 - e2 * math.sin(lat) ** 2
    rn = a * (1 - e2) / s ** 1.5
    re_ = a / math.sqrt(s)
    return (ORIGIN[0] + math.degrees(north / rn),
            ORIGIN[1] + math.degrees(east / (re_ * math.cos(lat))))


def connection(m):
    """What QGroundControl asks first."""
    a = command(m, mav.MAV_CMD_REQUEST_MESSAGE, 148)
    v = recv(m, "AUTOPILOT_VERSION", 5)
    caps = v.capabilities if v else 0
    need = (mav.MAV_PROTOCOL_CAPABILITY_MISSION_INT | mav.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
            | mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
            | mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
            | mav.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT | mav.MAV_PROTOCOL_CAPABILITY_MAVLINK2)
    never = (mav.MAV_PROTOCOL_CAPABILITY_FTP | mav.MAV_PROTOCOL_CAPABILITY_TERRAIN
             | mav.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
             | mav.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED and caps & need == need
           and caps & never == 0,
           f"REQUEST_MESSAGE AUTOPILOT_VERSION: capabilities 0x{caps:x} (MISSION_INT, "
           "COMMAND_INT, position targets, PARAM_FLOAT, MAVLink 2; no FTP, terrain, fence)")
    a = command(m, mav.MAV_CMD_REQUEST_MESSAGE, 242)
    expect(a is not None and a.result == mav.MAV_RESULT_FAILED,
           "HOME_POSITION before an origin: FAILED (ArduPilot's answer while home is not set)")
    m.mav.set_gps_global_origin_send(m.target_system, int(ORIGIN[0] * 1e7),
                                     int(ORIGIN[1] * 1e7), 0)
    recv(m, "GPS_GLOBAL_ORIGIN", 5)
    a = command(m, mav.MAV_CMD_REQUEST_MESSAGE, 242)
    h = recv(m, "HOME_POSITION", 5)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED and h is not None
           and abs(h.latitude - int(ORIGIN[0] * 1e7)) <= 1,
           f"HOME_POSITION after the origin: {h.latitude if h else None}")
    st = recv(m, "SYSTEM_TIME", 5)
    expect(st is not None and abs(st.time_unix_usec / 1e6 - time.time()) < 5,
           "SYSTEM_TIME streamed with the wall clock")
    ekf = recv(m, "EKF_STATUS_REPORT", 5)
    expect(ekf is not None and ekf.flags & mav.EKF_POS_HORIZ_REL and ekf.flags & mav.EKF_ATTITUDE,
           f"EKF_STATUS_REPORT: flags 0x{ekf.flags if ekf else 0:x}, position ready")
    bat = recv(m, "BATTERY_STATUS", 5)
    expect(bat is not None, f"BATTERY_STATUS: {bat.voltages[0] if bat else None} mV")

    # SET_MESSAGE_INTERVAL honoured: ATTITUDE every 40 ms, then off, then back to the
    # default 100 ms. The surface counts its own control periods (the wall clock in front of
    # a vehicle on its own clock); the mean interval of the messages received over 3 s.
    def attitude_interval_ms(seconds):
        stamps = []
        end = time.time() + seconds
        while time.time() < end:
            a = recv(m, "ATTITUDE", 0.5)
            if a is not None:
                stamps.append(time.time())
        if len(stamps) < 3:
            return None
        return 1e3 * (stamps[-1] - stamps[0]) / (len(stamps) - 1)

    a = command(m, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 30, 40000)
    drain(m, 0.3)
    ms = attitude_interval_ms(3.0)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED and ms is not None
           and 32 <= ms <= 55, f"ATTITUDE at 40 ms asked: every {ms:.1f} ms")
    a = command(m, mav.MAV_CMD_GET_MESSAGE_INTERVAL, 30)
    mi = recv(m, "MESSAGE_INTERVAL", 5)
    expect(mi is not None and mi.interval_us == 40000, "GET_MESSAGE_INTERVAL says 40000 us")
    command(m, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 30, -1)
    drain(m, 0.3)
    expect(recv(m, "ATTITUDE", 1.5) is None, "ATTITUDE off (-1): none in 1.5 s")
    command(m, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 30, 0)
    drain(m, 0.3)
    ms = attitude_interval_ms(3.0)
    expect(ms is not None and 85 <= ms <= 125,
           f"ATTITUDE back to the default: every {ms:.1f} ms")
    a = command(m, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 30, float("nan"))
    expect(a is not None and a.result == mav.MAV_RESULT_DENIED
           and said(m, "interval refused"), "a NaN interval refused in words")


def refusals(m):
    """Each refused with a COMMAND_ACK or the value in force, and a STATUSTEXT in words."""
    sent()
    m.mav.param_set_send(m.target_system, m.target_component, b"TRK_XY_KP", 5000,
                         mav.MAV_PARAM_TYPE_REAL32)
    expect(said(m, r"TRK_XY_KP refused: 5000 is outside the allowed [0-9.]+ to [0-9.]+"),
           "TRK_XY_KP 5000 refused with the range allowed")
    sent()
    m.mav.param_set_send(m.target_system, m.target_component, b"FS_HB_NEUTRAL", float("nan"),
                         mav.MAV_PARAM_TYPE_REAL32)
    expect(said(m, r"FS_HB_NEUTRAL refused: NaN"), "FS_HB_NEUTRAL NaN refused")
    sent()
    m.mav.param_set_send(m.target_system, m.target_component, b"NO_SUCH", 1,
                         mav.MAV_PARAM_TYPE_REAL32)
    expect(said(m, r"NO_SUCH refused: no such parameter"), "an unknown name refused")
    for mode, pattern in [(7, r"Mode 7 refused: no such mode"),
                          (AUTO, r"AUTO refused: no mission")]:
        a = set_mode(m, mode)
        expect(a is not None and a.result == mav.MAV_RESULT_DENIED and said(m, pattern),
               f"mode {mode} refused: {pattern}")
    a = command(m, mav.MAV_CMD_DO_SET_MODE, 1, float("nan"))
    expect(a is not None and a.result == mav.MAV_RESULT_DENIED and said(m, "whole custom mode"),
           "DO_SET_MODE NaN refused")
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0.5)
    expect(a is not None and a.result == mav.MAV_RESULT_DENIED and said(m, "must be 1"),
           "arming with 0.5 refused")
    target_local(m, mav.MAV_FRAME_LOCAL_NED, 1, 1, 1)
    expect(said(m, "Target refused: not in GUIDED"), "a target outside GUIDED refused")
    a = set_mode(m, GUIDED)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "GUIDED accepted, disarmed")
    target_local(m, mav.MAV_FRAME_LOCAL_NED, 2, 2, 1)
    expect(said(m, "Target refused: the vehicle is disarmed"),
           "a target while disarmed refused (never flown after arming)")
    a = command(m, mav.MAV_CMD_DO_REPOSITION, -1, 1, 0, 0, ORIGIN[0], ORIGIN[1], -1)
    expect(a is not None and a.result == mav.MAV_RESULT_DENIED and said(m, "disarmed"),
           "DO_REPOSITION while disarmed refused")
    # A mission item with a NaN depth, and one too deep.
    m.mav.mission_count_send(m.target_system, m.target_component, 1)
    recv(m, ["MISSION_REQUEST_INT", "MISSION_REQUEST"], 5)
    sent()
    m.mav.mission_item_int_send(m.target_system, m.target_component, 0,
                                mav.MAV_FRAME_LOCAL_NED, 16, 0, 1, 0, 0, 0, 0, 10000, 0, 150.0)
    ack = recv(m, "MISSION_ACK", 5)
    expect(ack is not None and ack.type == mav.MAV_MISSION_INVALID_PARAM7
           and said(m, "depth 150 m is unreachable"), "a 150 m deep waypoint refused in words")


def goto(m):
    """Armed in GUIDED: each way of giving a point, flown."""
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "armed in GUIDED")
    start = position(m)
    t = (start[0] + 2.0, start[1] + 1.0, 1.5)
    target_local(m, mav.MAV_FRAME_LOCAL_NED, *t)
    echo = recv(m, "POSITION_TARGET_LOCAL_NED", 5, lambda p: abs(p.x - t[0]) < 1e-3)
    expect(echo is not None, "SET_POSITION_TARGET_LOCAL_NED answered with the target taken")
    here = reaches(m, t, "LOCAL_NED target")
    hdg = recv(m, "ATTITUDE", 5).yaw
    t = (here[0] + math.cos(hdg) * 1.5, here[1] + math.sin(hdg) * 1.5, here[2])
    target_local(m, mav.MAV_FRAME_BODY_OFFSET_NED, 1.5, 0, 0)
    here = reaches(m, t, "BODY_OFFSET_NED 1.5 m ahead", within=0.35)
    t = (here[0] - 1.0, here[1] + 1.0, here[2] + 0.5)
    target_local(m, mav.MAV_FRAME_LOCAL_OFFSET_NED, -1.0, 1.0, 0.5)
    here = reaches(m, t, "LOCAL_OFFSET_NED (-1, 1, 0.5)", within=0.35)
    lat, lon = offset(1.0, 2.0)
    m.mav.set_position_target_global_int_send(0, m.target_system, m.target_component,
                                              mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                              0b110111111000, int(lat * 1e7), int(lon * 1e7),
                                              -2.0, 0, 0, 0, 0, 0, 0, 0, 0)
    here = reaches(m, (1.0, 2.0, 2.0), "SET_POSITION_TARGET_GLOBAL_INT (1, 2, 2 m deep)")
    lat, lon = offset(-1.0, 1.0)
    m.mav.command_int_send(m.target_system, m.target_component,
                           mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_DO_REPOSITION,
                           0, 0, -1, 1, 0, 0, int(lat * 1e7), int(lon * 1e7), -1.5)
    a = recv(m, "COMMAND_ACK", 5, lambda a: a.command == mav.MAV_CMD_DO_REPOSITION)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "DO_REPOSITION accepted")
    reaches(m, (-1.0, 1.0, 1.5), "DO_REPOSITION (-1, 1, 1.5 m deep)")
    lat, lon = offset(0.5, -0.5)
    m.mav.mission_item_int_send(m.target_system, m.target_component, 0,
                                mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 16, 2, 0, 0, 0, 0, 0,
                                int(lat * 1e7), int(lon * 1e7), -1.0)
    ack = recv(m, "MISSION_ACK", 5)
    expect(ack is not None and ack.type == mav.MAV_MISSION_ACCEPTED,
           "a guided mission item (current = 2) accepted")
    reaches(m, (0.5, -0.5, 1.0), "guided mission item (0.5, -0.5, 1 m deep)")
    target_local(m, mav.MAV_FRAME_LOCAL_NED, 1, 1, 1, mask=0b110111000111)
    expect(said(m, "only position targets"), "a velocity target refused in words")
    target_local(m, mav.MAV_FRAME_LOCAL_NED, 1, float("nan"), 1)
    expect(said(m, "not a number"), "a NaN target refused in words")
    target_local(m, mav.MAV_FRAME_LOCAL_NED, 1, 1, -3)
    expect(said(m, "outside 0 \\(the surface\\)"), "a target above the surface refused")
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "disarmed")
    # Armed again: the vehicle holds where it is; the last target is not flown again.
    here = position(m)
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    echo = recv(m, "POSITION_TARGET_LOCAL_NED", 5)
    expect(echo is not None and math.dist((echo.x, echo.y, echo.z), here) < 0.2,
           "armed again in GUIDED: the target is where the vehicle is, not the old one")
    command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)


def main():
    port = int(sys.argv[1])
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=60) is not None, "a HEARTBEAT arrives")
    connection(m)
    refusals(m)
    goto(m)
    bad = [w for t in TEXTS for w in re.findall(r"\b[A-Z]\w*[a-z][A-Z]\w*", t) if w != "NaN"]
    expect(not bad, f"{len(TEXTS)} status texts, none with an internal name ({bad})")


if __name__ == "__main__":
    main()
