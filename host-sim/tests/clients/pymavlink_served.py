"""A pymavlink ground station flies a vehicle through `host-sim topside`: the parameters read,
ALT_HOLD and POSHOLD armed, GUIDED to a point, disarmed. The same session against `topside
--sim` and `topside --tcp` (a served vehicle, `host-sim vehicle`).

Usage: pymavlink_served.py PORT X Y Z. Listens on udpin:127.0.0.1:PORT for the topside. The
GUIDED target is (X, Y, Z) in MAV_FRAME_LOCAL_NED (Z: depth). Prints PASS lines and, at the
end, `GUIDED reached` with the reported position; exits 0, or raises.
"""
import math
import sys
import time

from pymavlink import mavutil

from gcs import expect, wait

ALT_HOLD, GUIDED, POSHOLD = 2, 4, 16
mav = mavutil.mavlink


def ack_of(m, command, timeout=10.0):
    return wait(m, "COMMAND_ACK", timeout, lambda a: a.command == command)


def command(m, cmd, *params):
    p = list(params) + [0] * (7 - len(params))
    m.mav.command_long_send(m.target_system, m.target_component, cmd, 0, *p)
    return ack_of(m, cmd)


def set_mode(m, mode):
    return command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)


def positions(m, seconds, stick=True):
    """LOCAL_POSITION_NED for `seconds`, the sticks centred at 20 Hz meanwhile."""
    seen = []
    end = time.time() + seconds
    while time.time() < end:
        if stick:
            m.mav.manual_control_send(m.target_system, 0, 0, 500, 0, 0)
        stop = time.time() + 0.05
        while time.time() < stop:
            msg = m.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=0.01)
            if msg is not None:
                seen.append(msg)
    return seen


def main():
    port = int(sys.argv[1])
    target = [float(v) for v in sys.argv[2:5]]
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=60) is not None, "a HEARTBEAT arrives")
    # The vehicle's battery monitor (the served vehicle's simulated pack) in SYS_STATUS.
    st = m.recv_match(type="SYS_STATUS", blocking=True, timeout=5)
    expect(st is not None and 10_000 <= st.voltage_battery <= 25_200
           and 0 <= st.battery_remaining <= 100 and st.current_battery >= 0,
           f"SYS_STATUS carries the battery ({st.voltage_battery if st else None} mV, "
           f"{st.current_battery if st else None} cA, {st.battery_remaining if st else None} %)")

    # Every parameter, by PARAM_REQUEST_LIST.
    m.mav.param_request_list_send(m.target_system, m.target_component)
    got, count = set(), None
    end = time.time() + 20
    while time.time() < end and (count is None or len(got) < count):
        p = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=1)
        if p is not None:
            count = p.param_count
            got.add(p.param_index)
    expect(count is not None and len(got) == count, f"all {count} parameters read")

    a = set_mode(m, ALT_HOLD)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "ALT_HOLD accepted")
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "arming accepted")
    hb = wait(m, "HEARTBEAT", 5, lambda h: h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
    expect(hb is not None and hb.custom_mode == ALT_HOLD, "HEARTBEAT says armed, ALT_HOLD")
    pos = positions(m, 3.0)
    dz = max(abs(p.z - pos[0].z) for p in pos) if pos else math.inf
    expect(len(pos) > 5 and dz < 0.1, f"ALT_HOLD holds the depth (within {dz:.3f} m)")

    a = set_mode(m, POSHOLD)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "POSHOLD accepted")
    pos = positions(m, 3.0)
    drift = max(math.hypot(p.x - pos[0].x, p.y - pos[0].y) for p in pos) if pos else math.inf
    expect(len(pos) > 5 and drift < 0.1, f"POSHOLD holds the point (within {drift:.3f} m)")

    a = set_mode(m, GUIDED)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "GUIDED accepted")
    m.mav.set_position_target_local_ned_send(0, m.target_system, m.target_component,
                                             mav.MAV_FRAME_LOCAL_NED, 0b110111111000,
                                             *target, 0, 0, 0, 0, 0, 0, 0, 0)

    def off(p):
        return math.dist([p.x, p.y, p.z], target)

    reached = wait(m, "LOCAL_POSITION_NED", 90, lambda p: off(p) < 0.05)
    expect(reached is not None, "the vehicle reports the GUIDED target within 5 cm")
    pos = positions(m, 3.0, stick=False)
    worst = max(off(p) for p in pos) if pos else math.inf
    expect(len(pos) > 5 and worst < 0.1, f"and holds it (within {worst:.3f} m)")
    last = pos[-1]
    print(f"GUIDED reached: {last.x:.4f} {last.y:.4f} {last.z:.4f}", flush=True)

    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "disarming accepted")
    hb = wait(m, "HEARTBEAT", 5, lambda h: not h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
    expect(hb is not None, "HEARTBEAT says disarmed")


if __name__ == "__main__":
    main()
