"""pymavlink reads and writes the topside's parameters.

Usage: pymavlink_params.py PORT set        -> lists, changes TRK_XY_KP, VEH_MASS and
                                              FS_PILOT_STALE, is refused bad values
       pymavlink_params.py PORT check V    -> TRK_XY_KP reads back V, and the other two
                                              their new values (after a restart)
"""
import sys
import time

from pymavlink import mavutil

from gcs import expect, wait

mav = mavutil.mavlink


def read(m, name):
    m.mav.param_request_read_send(m.target_system, m.target_component, name.encode(), -1)
    return wait(m, "PARAM_VALUE", 10, lambda p: p.param_id == name)


# The vehicle's description and a failsafe timeout, changed and restored with the gains.
CHANGES = {"VEH_MASS": 12.5, "FS_PILOT_STALE": 0.8}
# Values the vehicle must refuse: buoyancy beyond half the vertical thrust (unsafe for the
# depth law), a pilot timeout of 5 s (beyond the 2 s limit), a NaN mass, a 5 m/s mission.
REFUSED = {"VEH_BUOY": 9.0, "FS_PILOT_STALE": 5.0, "VEH_MASS": float("nan"), "MIS_SPEED": 5.0}


def set_param(m, name, value):
    m.mav.param_set_send(m.target_system, m.target_component, name.encode(), value,
                         mav.MAV_PARAM_TYPE_REAL32)


def refused(m, name, value, in_force):
    """Set an invalid value: the answer is the value in force and a STATUSTEXT says why."""
    set_param(m, name, value)
    p = t = None
    end = time.time() + 10
    while time.time() < end and (p is None or t is None):
        msg = m.recv_match(type=["PARAM_VALUE", "STATUSTEXT"], blocking=True, timeout=1)
        if msg is None:
            continue
        if msg.get_type() == "PARAM_VALUE" and msg.param_id == name:
            p = msg
        elif msg.get_type() == "STATUSTEXT" and f"{name} refused" in msg.text:
            t = msg
    expect(p is not None and abs(p.param_value - in_force) < 1e-5,
           f"{name} = {value} is answered with the value in force {in_force}")
    expect(t is not None, f"and a STATUSTEXT says why: {t.text if t else None!r}")


def main():
    port, what = int(sys.argv[1]), sys.argv[2]
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=30) is not None, "a HEARTBEAT arrives")
    if what == "check":
        want = float(sys.argv[3])
        p = read(m, "TRK_XY_KP")
        expect(p is not None and abs(p.param_value - want) < 1e-5,
               f"TRK_XY_KP restored after the restart: {p.param_value if p else None} == {want}")
        for name, value in CHANGES.items():
            p = read(m, name)
            expect(p is not None and abs(p.param_value - value) < 1e-5,
                   f"{name} restored after the restart: {p.param_value if p else None}")
        return

    m.mav.param_request_list_send(m.target_system, m.target_component)
    seen = {}
    end = time.time() + 10
    while time.time() < end:
        p = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=1)
        if p is not None:
            seen[p.param_id] = p
            if len(seen) == p.param_count:
                break
    count = next(iter(seen.values())).param_count if seen else 0
    expect(count >= 30 and len(seen) == count, f"the whole list arrives ({len(seen)} of {count})")
    expect("TRK_XY_KP" in seen and "PXZ_C1" in seen, "tracking and paper gains are listed")
    expect(all(n in seen for n in ["VEH_MASS", "VEH_THR_FWD", "VEH_PWM_NEUTRAL", "FS_HB_NEUTRAL",
                                   "MIS_SPEED"]),
           "the vehicle's description, the failsafe timeouts and the mission speed are listed")
    expect(abs(seen["VEH_MASS"].param_value - 10.84) < 1e-4, "the Observer's mass, 10.84 kg")

    old = seen["TRK_XY_KP"].param_value
    new = round(old * 1.25, 4)
    m.mav.param_set_send(m.target_system, m.target_component, b"TRK_XY_KP", new,
                         mav.MAV_PARAM_TYPE_REAL32)
    p = wait(m, "PARAM_VALUE", 10, lambda p: p.param_id == "TRK_XY_KP")
    expect(p is not None and abs(p.param_value - new) < 1e-5, f"TRK_XY_KP set to {new}")

    refused(m, "TRK_XY_KP", -1.0, new)
    for name, value in CHANGES.items():
        set_param(m, name, value)
        p = wait(m, "PARAM_VALUE", 10, lambda p: p.param_id == name)
        expect(p is not None and abs(p.param_value - value) < 1e-5, f"{name} set to {value}")
    for name, value in REFUSED.items():
        refused(m, name, value, CHANGES.get(name, seen[name].param_value))
    p = read(m, "TRK_XY_KP")
    expect(p is not None and abs(p.param_value - new) < 1e-5, "reading it back gives the new value")
    print(f"VALUE={new}")


if __name__ == "__main__":
    main()
