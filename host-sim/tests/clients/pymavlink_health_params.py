"""pymavlink sets ArduSub's health, ground-station-failsafe, pilot-speed and system-id
parameters through `rov-topside --tcp` in front of `host-sim vehicle`.

Usage: pymavlink_health_params.py PORT PHASE, PHASE one of:
- `set`: refusals in words (range, rule, the vehicle's own refusal while armed); a low-voltage
  threshold above the battery's volts and the vehicle says "battery low"; a depth limit of 2 m
  and a mission waypoint at 3 m refused by the vehicle; `SYSID_THISMAV` 2 saved for the next
  start.
- `restart`: the surface restarted on the saved file is MAVLink system 2 and reads back what
  `set` saved.
- `gcs`: `FS_GCS_ENABLE` 1 (warn), 2 (disarm) and 3 (depth hold): the station stops its
  heartbeats and the surface acts `FS_GCS_TIMEOUT` (2 s) later.
- `pilot`: in ALT_HOLD, the heave stick full down (0.5 after the default joystick gain) for
  8 s with `PILOT_SPEED_DN` 20 cm/s, then 500: prints `RATE limited X` and `RATE free Y`, the
  mean depth rates (m/s) over each run's last 5 s (the vehicle's LOCAL_POSITION_NED).
Prints PASS lines, every STATUSTEXT as `TEXT: ...`; exits 0 or raises.
"""
import re
import sys
import time

from pymavlink import mavutil

from gcs import expect

mav = mavutil.mavlink
MANUAL, ALT_HOLD = 19, 2
TEXTS = []
MARK = [0]
BEAT = {"on": True, "next": 0.0, "last": 0.0}


def beat(m):
    """Our heartbeat once a second while it is on."""
    now = time.time()
    if BEAT["on"] and now >= BEAT["next"]:
        m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        BEAT["next"] = now + 1.0
        BEAT["last"] = now


def recv(m, kind, timeout=10.0, cond=lambda msg: True):
    kinds = [kind] if isinstance(kind, str) else kind
    end = time.time() + timeout
    while time.time() < end:
        beat(m)
        msg = m.recv_match(blocking=True, timeout=max(0.02, min(0.2, end - time.time())))
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            TEXTS.append(msg.text)
            print(f"TEXT: {msg.text}", flush=True)
        if msg.get_type() in kinds and cond(msg):
            return msg
    return None


def said(m, pattern, seconds=3.0):
    end = time.time() + seconds
    while True:
        if re.search(pattern, " ".join(TEXTS[MARK[0]:])):
            return True
        if time.time() >= end:
            return False
        recv(m, "NOTHING", 0.1)


def name_of(p):
    n = p.param_id
    return n.decode() if isinstance(n, bytes) else n


def param_set(m, name, value):
    """PARAM_SET; the PARAM_VALUE answered (the value in force)."""
    MARK[0] = len(TEXTS)
    m.mav.param_set_send(m.target_system, m.target_component, name.encode(), value,
                         mav.MAV_PARAM_TYPE_REAL32)
    p = recv(m, "PARAM_VALUE", 10, lambda p: name_of(p) == name)
    expect(p is not None, f"{name} answered")
    return p.param_value


def param_get(m, name):
    m.mav.param_request_read_send(m.target_system, m.target_component, name.encode(), -1)
    p = recv(m, "PARAM_VALUE", 10, lambda p: name_of(p) == name)
    expect(p is not None, f"{name} read")
    return p.param_value


def refused(m, name, value, in_force, pattern):
    v = param_set(m, name, value)
    expect(abs(v - in_force) < 1e-3 and said(m, pattern),
           f"{name} {value} refused (still {v}), said /{pattern}/")


def taken(m, name, value):
    v = param_set(m, name, value)
    expect(abs(v - value) < 1e-3, f"{name} {value} taken (reads {v})")


def command(m, cmd, *params):
    p = list(params) + [0] * (7 - len(params))
    MARK[0] = len(TEXTS)
    m.mav.command_long_send(m.target_system, m.target_component, cmd, 0, *p)
    return recv(m, "COMMAND_ACK", 10, lambda a: a.command == cmd)


def vehicle_heartbeat(m, timeout=5.0):
    return recv(m, "HEARTBEAT", timeout, lambda h: h.get_srcSystem() == m.target_system
                and h.type == mav.MAV_TYPE_SUBMARINE)


def armed(m):
    hb = vehicle_heartbeat(m)
    return hb is not None and bool(hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)


def arm_in(m, mode):
    a = command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MANUAL)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "MANUAL")
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "armed")
    if mode != MANUAL:
        a = command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)
        expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, f"mode {mode}")


def disarm(m):
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "disarmed")


def upload(m, points):
    """A local-frame mission; the MISSION_ACK type."""
    m.mav.mission_count_send(m.target_system, m.target_component, len(points))
    while True:
        msg = recv(m, ["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], 10)
        expect(msg is not None, "the vehicle answers the upload")
        if msg.get_type() == "MISSION_ACK":
            return msg.type
        n, e, d = points[msg.seq]
        m.mav.mission_item_int_send(
            m.target_system, m.target_component, msg.seq, mav.MAV_FRAME_LOCAL_NED,
            mav.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0.5, 0, 0, int(n * 1e4), int(e * 1e4), d)


def phase_set(m):
    refused(m, "DEPTH_LIMIT_M", 150, 0, r"DEPTH_LIMIT_M refused: 150 is outside the allowed 0 to 100")
    refused(m, "BATT_FS_LOW_ACT", 7, 1,
            r"BATT_FS_LOW_ACT refused: 7.*0 none, 1 warn, 2 disarm, 3 surface")
    refused(m, "FS_LEAK_ENABLE", 3, 2, r"FS_LEAK_ENABLE refused: 3.*2 surface")
    taken(m, "BATT_LOW_VOLT", 14)
    refused(m, "BATT_CRT_VOLT", 15, 0, r"BATT_CRT_VOLT refused: 15 .*not be above BATT_LOW_VOLT")
    refused(m, "PILOT_SPEED_UP", 600, 500, r"PILOT_SPEED_UP refused: 600 is outside the allowed 20 to 500")
    refused(m, "FS_GCS_TIMEOUT", 0.5, 5, r"FS_GCS_TIMEOUT refused: 0.5 is outside the allowed 2 to 120")
    taken(m, "PILOT_SPEED_DN", 30)
    s = recv(m, "SYS_STATUS", 5)
    volts = s.voltage_battery / 1000.0 if s is not None else 0.0
    expect(volts > 5.0, f"the battery reads {volts:.2f} V")
    taken(m, "BATT_LOW_VOLT", 30)
    expect(said(m, r"battery low", 5), "the vehicle says battery low at the new 30 V threshold")
    # Armed: the vehicle refuses a battery change, takes a depth limit switched on.
    arm_in(m, MANUAL)
    refused(m, "BATT_CAPACITY", 10000, 18000, r"BATT_CAPACITY refused by the vehicle: 10000: .*disarm")
    taken(m, "DEPTH_LIMIT_M", 2)
    MARK[0] = len(TEXTS)
    r = upload(m, [(1, 0, 1), (2, 0, 3)])
    expect(r == mav.MAV_MISSION_INVALID and said(m, r"item 1 refused by the vehicle: deeper than the depth limit DEPTH_LIMIT_M"),
           f"a waypoint at 3 m refused under the 2 m limit ({r})")
    r = upload(m, [(1, 0, 1), (2, 0, 1.5)])
    expect(r == mav.MAV_MISSION_ACCEPTED, f"a mission within the limit accepted ({r})")
    disarm(m)
    v = param_set(m, "SYSID_THISMAV", 2)
    expect(v == 2 and said(m, r"SYSID_THISMAV 2 saved: taken at the next start"),
           "SYSID_THISMAV 2 saved for the next start")
    hb = vehicle_heartbeat(m)
    expect(hb is not None and hb.get_srcSystem() == 1, "still system 1 until the restart")


def phase_restart(m):
    expect(m.target_system == 2, f"the restarted surface is system {m.target_system}")
    for name, value in [("DEPTH_LIMIT_M", 2), ("BATT_LOW_VOLT", 30), ("PILOT_SPEED_DN", 30),
                        ("SYSID_THISMAV", 2), ("BATT_CAPACITY", 18000)]:
        v = param_get(m, name)
        expect(abs(v - value) < 1e-3, f"{name} restored: {v}")


def lose_heartbeat(m, pattern, seconds=8.0):
    """Stop our heartbeat; the text said and how long after the last one."""
    recv(m, "NOTHING", 1.5)
    BEAT["on"] = False
    last = BEAT["last"]
    MARK[0] = len(TEXTS)
    ok = said(m, pattern, seconds)
    after = time.time() - last
    return ok, after


def back(m):
    BEAT["on"] = True
    BEAT["next"] = 0.0
    MARK[0] = len(TEXTS)
    expect(said(m, r"Ground station heartbeat back", 4), "the heartbeat back ends the failsafe")


def phase_gcs(m):
    taken(m, "FS_GCS_TIMEOUT", 2)
    # 1: warn only.
    taken(m, "FS_GCS_ENABLE", 1)
    arm_in(m, MANUAL)
    ok, after = lose_heartbeat(m, r"Ground station heartbeat lost for \d+ s")
    expect(ok, f"warn: said {after:.1f} s after the last heartbeat")
    recv(m, "NOTHING", 1.0)
    expect(armed(m), "warn only: still armed")
    back(m)
    # 2: disarm.
    taken(m, "FS_GCS_ENABLE", 2)
    ok, after = lose_heartbeat(m, r"Ground station failsafe: disarmed")
    expect(ok and 1.9 <= after <= 6.0, f"disarm: {after:.1f} s after the last heartbeat")
    expect(not armed(m), "disarmed")
    print(f"FS_GCS disarm after {after:.2f} s", flush=True)
    back(m)
    # 3: depth hold, the vehicle left armed in ALT_HOLD.
    taken(m, "FS_GCS_ENABLE", 3)
    arm_in(m, MANUAL)
    ok, after = lose_heartbeat(m, r"Ground station failsafe: (depth hold|disarmed)")
    hb = vehicle_heartbeat(m)
    expect(ok and hb is not None and hb.custom_mode == ALT_HOLD
           and bool(hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED),
           f"depth hold {after:.1f} s after the last heartbeat: armed in ALT_HOLD")
    recv(m, "NOTHING", 2.0)
    hb = vehicle_heartbeat(m)
    expect(hb is not None and hb.custom_mode == ALT_HOLD
           and bool(hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED), "still holding 2 s later")
    back(m)
    disarm(m)
    taken(m, "FS_GCS_ENABLE", 0)


def descend(m, seconds):
    """Full stick down in ALT_HOLD for `seconds`; the mean depth rate over the last 5 s."""
    track = []
    end = time.time() + seconds
    next_send = 0.0
    while time.time() < end:
        if time.time() >= next_send:
            m.mav.manual_control_send(m.target_system, 0, 0, 0, 0, 0)
            next_send = time.time() + 0.05
        p = recv(m, "LOCAL_POSITION_NED", 0.05)
        if p is not None:
            track.append((time.time(), p.z))
    late = [(t, z) for t, z in track if t >= end - 5.0]
    expect(len(late) >= 10, f"{len(late)} positions in the last 5 s")
    (t0, z0), (t1, z1) = late[0], late[-1]
    return (z1 - z0) / (t1 - t0)


def phase_pilot(m):
    taken(m, "PILOT_SPEED_DN", 20)
    # Centred sticks first (the vehicle takes sticks only once seen centred).
    for _ in range(10):
        m.mav.manual_control_send(m.target_system, 0, 0, 500, 0, 0)
        recv(m, "NOTHING", 0.05)
    arm_in(m, ALT_HOLD)
    for _ in range(10):
        m.mav.manual_control_send(m.target_system, 0, 0, 500, 0, 0)
        recv(m, "NOTHING", 0.05)
    limited = descend(m, 8.0)
    print(f"RATE limited {limited:.4f}", flush=True)
    taken(m, "PILOT_SPEED_DN", 500)
    free = descend(m, 8.0)
    print(f"RATE free {free:.4f}", flush=True)
    for _ in range(10):
        m.mav.manual_control_send(m.target_system, 0, 0, 500, 0, 0)
        recv(m, "NOTHING", 0.05)
    disarm(m)


def main():
    port, phase = int(sys.argv[1]), sys.argv[2]
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    hb = m.wait_heartbeat(timeout=30)
    expect(hb is not None, "a HEARTBEAT arrives")
    beat(m)
    {"set": phase_set, "restart": phase_restart, "gcs": phase_gcs, "pilot": phase_pilot}[phase](m)


if __name__ == "__main__":
    main()
