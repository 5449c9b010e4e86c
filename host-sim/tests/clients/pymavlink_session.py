"""A pymavlink ground station flies a served vehicle through `rov-topside --tcp`.

Usage: pymavlink_session.py PORT. Listens on udpin:127.0.0.1:PORT for the topside (which
sends to udpout:127.0.0.1:PORT). Exits 0 and prints PASS lines, or raises.
"""
import sys
import time

from pymavlink import mavutil

from gcs import expect, wait

MANUAL, STABILIZE, ALT_HOLD, AUTO, POSHOLD = 19, 0, 2, 3, 16
mav = mavutil.mavlink


def ack_of(m, command, timeout=10.0):
    return wait(m, "COMMAND_ACK", timeout, lambda a: a.command == command)


def sticks(m, seconds, x=0, z=500, r=0):
    """Send the sticks at 20 Hz (wall clock) for `seconds` of the vehicle's time (its
    messages' `time_boot_ms`: a served vehicle runs faster or slower than the wall clock);
    return what arrived meanwhile, by type. At most 60 s of wall time a vehicle second."""
    seen = {}
    start = end = None
    wall_end = time.time() + 60.0 * seconds
    while time.time() < wall_end:
        m.mav.manual_control_send(m.target_system, x, 0, z, r, 0)
        stop = time.time() + 0.05
        while time.time() < stop:
            msg = m.recv_match(blocking=True, timeout=0.01)
            if msg is None:
                continue
            seen.setdefault(msg.get_type(), []).append(msg)
            # The vehicle's clock, as the state messages carry it.
            t_ms = getattr(msg, "time_boot_ms", None)
            if t_ms is not None and msg.get_type() in ("LOCAL_POSITION_NED", "ATTITUDE"):
                if start is None:
                    start, end = t_ms, t_ms + 1000.0 * seconds
                elif t_ms >= end:
                    return seen
    return seen


def main():
    port = int(sys.argv[1])
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    hb = m.wait_heartbeat(timeout=30)
    expect(hb is not None, "a HEARTBEAT arrives")
    expect(hb.type == mav.MAV_TYPE_SUBMARINE, "the vehicle is a MAV_TYPE_SUBMARINE")
    expect(hb.autopilot == mav.MAV_AUTOPILOT_ARDUPILOTMEGA, "ArduPilot conventions")
    for kind in ["ATTITUDE", "LOCAL_POSITION_NED", "VFR_HUD", "SERVO_OUTPUT_RAW", "SYS_STATUS"]:
        expect(wait(m, kind) is not None, f"{kind} streams")

    # MANUAL through SET_MODE (what pymavlink's set_mode sends).
    m.mav.set_mode_send(m.target_system, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MANUAL)
    a = ack_of(m, mav.MAV_CMD_DO_SET_MODE)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "MANUAL accepted")

    m.mav.command_long_send(m.target_system, m.target_component,
                            mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    a = ack_of(m, mav.MAV_CMD_COMPONENT_ARM_DISARM)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "arming accepted")
    hb = wait(m, "HEARTBEAT", 5, lambda h: h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
    expect(hb is not None and hb.custom_mode == MANUAL, "HEARTBEAT says armed, MANUAL")

    sticks(m, 0.3)  # the sticks at rest first: thrust follows a stick seen at centre
    seen = sticks(m, 4.0, x=600)  # 60 % forward
    pos = seen.get("LOCAL_POSITION_NED", [])
    servo = seen.get("SERVO_OUTPUT_RAW", [])
    expect(len(pos) > 5 and len(servo) > 5, "telemetry keeps streaming while flying")
    s1 = max(s.servo1_raw for s in servo)
    s2 = max(s.servo2_raw for s in servo)
    expect(s1 > 1550 and s2 > 1550, f"both horizontal thrusters push forward ({s1}, {s2} us)")
    dx = pos[-1].x - pos[0].x
    expect(dx > 0.3, f"the vehicle moved forward {dx:.2f} m on the sticks")

    # The pilot's stream stops: the vehicle's failsafe makes the thrusters neutral.
    t = wait(m, "STATUSTEXT", 10, lambda s: "pilot input lost" in s.text)
    expect(t is not None, f"failsafe STATUSTEXT: {t.text if t else None!r}")
    servo = wait(m, "SERVO_OUTPUT_RAW", 5, lambda s: s.servo1_raw == 1500 and s.servo2_raw == 1500)
    expect(servo is not None, "thrusters neutral after the stream stopped")

    def set_mode(mode, name):
        m.mav.command_long_send(m.target_system, m.target_component,
                                mav.MAV_CMD_DO_SET_MODE, 0,
                                mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode, 0, 0, 0, 0, 0)
        return ack_of(m, mav.MAV_CMD_DO_SET_MODE)

    # ALT_HOLD on the vehicle: the throttle centred holds the depth, the yaw stick centred
    # holds the heading, the surge stick flies.
    a = set_mode(ALT_HOLD, "ALT_HOLD")
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "ALT_HOLD accepted")
    hb = wait(m, "HEARTBEAT", 5, lambda h: h.custom_mode == ALT_HOLD)
    expect(hb is not None, "HEARTBEAT says ALT_HOLD")
    sticks(m, 0.3)  # at rest after the mode change
    seen = sticks(m, 5.0, x=500)  # 50 % forward, throttle and yaw centred
    pos = seen.get("LOCAL_POSITION_NED", [])
    att = seen.get("ATTITUDE", [])
    expect(len(pos) > 10 and len(att) > 10, "telemetry in ALT_HOLD")
    z0, yaw0 = pos[0].z, att[0].yaw
    dz = max(abs(p.z - z0) for p in pos)
    dyaw = max(abs(a.yaw - yaw0) for a in att)
    dx = pos[-1].x - pos[0].x
    expect(dz < 0.1, f"ALT_HOLD holds the depth while flying forward (within {dz:.3f} m)")
    expect(dyaw < 0.1, f"the centred yaw stick holds the heading (within {dyaw:.3f} rad)")
    expect(dx > 0.3, f"the surge stick flies it forward ({dx:.2f} m)")
    seen = sticks(m, 2.0, z=900)  # throttle up: climb
    pos = seen.get("LOCAL_POSITION_NED", [])
    climb = pos[0].z - pos[-1].z
    expect(climb > 0.1, f"throttle up climbs ({climb:.2f} m)")
    seen = sticks(m, 1.0)  # centred again: a new depth is captured ...
    seen = sticks(m, 3.0)  # ... and held
    pos = seen.get("LOCAL_POSITION_NED", [])
    dz = max(p.z for p in pos) - min(p.z for p in pos)
    expect(dz < 0.1, f"the new depth is held after the climb (spread {dz:.3f} m)")

    a = set_mode(STABILIZE, "STABILIZE")
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "STABILIZE accepted")
    hb = wait(m, "HEARTBEAT", 5, lambda h: h.custom_mode == STABILIZE)
    expect(hb is not None, "HEARTBEAT says STABILIZE")
    sticks(m, 1.0)

    # A mode the vehicle does not have yet is refused, with a reason.
    a = set_mode(AUTO, "AUTO")
    expect(a is not None and a.result == mav.MAV_RESULT_DENIED, "AUTO refused (DENIED)")

    m.mav.command_long_send(m.target_system, m.target_component,
                            mav.MAV_CMD_DO_SET_MODE, 0,
                            mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, POSHOLD, 0, 0, 0, 0, 0)
    a = ack_of(m, mav.MAV_CMD_DO_SET_MODE)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "POSHOLD accepted")
    hb = wait(m, "HEARTBEAT", 5, lambda h: h.custom_mode == POSHOLD)
    expect(hb is not None, "HEARTBEAT says POSHOLD")

    m.mav.command_long_send(m.target_system, m.target_component,
                            mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    a = ack_of(m, mav.MAV_CMD_COMPONENT_ARM_DISARM)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "disarming accepted")
    hb = wait(m, "HEARTBEAT", 5, lambda h: not h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
    expect(hb is not None, "HEARTBEAT says disarmed")

    # Garbage on the MAVLink port is ignored, not a crash.
    for address in list(m.clients):
        m.port.sendto(b"\xfd\x09garbage-not-mavlink" * 4, address)
    expect(wait(m, "HEARTBEAT", 5) is not None, "still alive after garbage")


if __name__ == "__main__":
    main()
