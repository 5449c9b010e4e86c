"""A pymavlink ground station flies a survey served by `host-sim vehicle` through
`rov-topside --tcp`, the vehicle navigating on its own estimator: POSHOLD as soon as the
estimate is ready, then the survey's waypoints as a mission in AUTO. It prints every
LOCAL_POSITION_NED it sees, for the test to hold against the served vehicle's truth log.

Usage: pymavlink_survey.py PORT SECONDS N,E,D [N,E,D ...]. Listens on udpin:127.0.0.1:PORT for
the surface program; flies the waypoints (local NED, m), then holds the last one until SECONDS
of the vehicle's clock have passed since AUTO was taken. Prints PASS lines, `START
time_boot_ms` (the vehicle's clock when AUTO was taken) and one `POS time_boot_ms x y z` line
per LOCAL_POSITION_NED, and `REACHED [seq, ...]` (the waypoints the vehicle reported
reaching) at the end; exits 0, or raises.
"""
import sys
import time

from pymavlink import mavutil

from gcs import arm_and_auto, expect, wait
from pymavlink_mission import upload

mav = mavutil.mavlink


def main():
    port, seconds = int(sys.argv[1]), float(sys.argv[2])
    pts = [tuple(float(v) for v in a.split(",")) for a in sys.argv[3:]]
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=30) is not None, "a HEARTBEAT arrives")
    expect(wait(m, "LOCAL_POSITION_NED", 5) is not None, "LOCAL_POSITION_NED streams")
    held = False
    end = time.time() + 60
    while not held and time.time() < end:
        m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_DO_SET_MODE, 0,
                                mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 16, 0, 0, 0, 0, 0)
        a = wait(m, "COMMAND_ACK", 5, lambda a: a.command == mav.MAV_CMD_DO_SET_MODE)
        held = a is not None and a.result == mav.MAV_RESULT_ACCEPTED
        if not held:
            time.sleep(0.5)
    expect(held, "POSHOLD accepted on the vehicle's estimate")
    r = upload(m, pts)
    expect(r == mav.MAV_MISSION_ACCEPTED, f"a {len(pts)}-waypoint survey is accepted ({r})")
    arm_and_auto(m)
    p = wait(m, "LOCAL_POSITION_NED", 5)
    expect(p is not None, "LOCAL_POSITION_NED streams in AUTO")
    start_ms = p.time_boot_ms
    print(f"START {start_ms}", flush=True)
    reached = []
    n = 0
    t_ms = start_ms
    end = time.time() + 900
    while t_ms < start_ms + 1000 * seconds and time.time() < end:
        msg = m.recv_match(type=["MISSION_ITEM_REACHED", "LOCAL_POSITION_NED"], blocking=True,
                           timeout=1)
        if msg is None:
            continue
        if msg.get_type() == "LOCAL_POSITION_NED":
            n += 1
            t_ms = msg.time_boot_ms
            print(f"POS {msg.time_boot_ms} {msg.x:.5f} {msg.y:.5f} {msg.z:.5f}")
        else:
            reached.append(msg.seq)
    expect(t_ms >= start_ms + 1000 * seconds,
           f"flown for {seconds:.0f} s of the vehicle's clock from AUTO")
    print(f"REACHED {reached}", flush=True)
    expect(n >= 100, f"LOCAL_POSITION_NED streamed in AUTO ({n})")


if __name__ == "__main__":
    main()
