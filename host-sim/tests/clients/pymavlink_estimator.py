"""A pymavlink ground station flies `nav-circle-3d` served by `host-sim vehicle` through
`rov-topside --tcp`, the vehicle navigating on its own estimator: POSHOLD as soon as the
estimate is ready, then a mission in AUTO. It prints every LOCAL_POSITION_NED it sees, for the
test to hold against the served vehicle's truth log.

Usage: pymavlink_estimator.py PORT SECONDS [RESTART_S]. Listens on udpin:127.0.0.1:PORT for the
surface program; holds, flies the mission, then holds its last waypoint until the vehicle's
clock reads SECONDS (the scenario's duration, for a figure over the same span as its software
run). With RESTART_S, the vehicle's estimator is restarted from the surface
(`MAV_CMD_USER_1`, param1 = 1) when the vehicle's clock passes it. Prints PASS lines and one
`POS time_boot_ms x y z` line per LOCAL_POSITION_NED; exits 0, or raises. Prints `READY` first,
once it listens.
"""
import sys
import time

from pymavlink import mavutil

from gcs import arm_and_auto, expect, wait
from pymavlink_mission import upload

mav = mavutil.mavlink


def main():
    port, seconds = int(sys.argv[1]), float(sys.argv[2])
    restart_s = float(sys.argv[3]) if len(sys.argv) > 3 else None
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    # Listening: the test starts the dive now, so that the vehicle's clock starts with its
    # ground station ready (not after this interpreter's start-up, which a loaded machine
    # stretches by seconds of the vehicle's time).
    print("READY", flush=True)
    expect(m.wait_heartbeat(timeout=30) is not None, "a HEARTBEAT arrives")
    expect(wait(m, "LOCAL_POSITION_NED", 5) is not None, "LOCAL_POSITION_NED streams")
    # POSHOLD once the vehicle's estimate is ready (refused NavNotReady before).
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
    # A triangle 3 m on a side from where the vehicle's estimate (ready now) puts it, 0.5 m
    # deeper at the end.
    p0 = wait(m, "LOCAL_POSITION_NED", 5)
    expect(p0 is not None, "LOCAL_POSITION_NED after POSHOLD")
    pts = [(p0.x + 3, p0.y, p0.z), (p0.x + 3, p0.y + 3, p0.z), (p0.x, p0.y + 3, p0.z + 0.5)]
    r = upload(m, pts)
    expect(r == mav.MAV_MISSION_ACCEPTED, f"a 3-waypoint mission is accepted ({r})")
    arm_and_auto(m)
    reached = []
    n = 0
    t_ms = 0
    end = time.time() + 240
    while (len(reached) < 3 or t_ms < 1000 * seconds) and time.time() < end:
        msg = m.recv_match(type=["MISSION_ITEM_REACHED", "LOCAL_POSITION_NED"], blocking=True,
                           timeout=1)
        if msg is None:
            continue
        if msg.get_type() == "LOCAL_POSITION_NED":
            n += 1
            t_ms = msg.time_boot_ms
            print(f"POS {msg.time_boot_ms} {msg.x:.5f} {msg.y:.5f} {msg.z:.5f}")
            if restart_s is not None and t_ms >= 1000 * restart_s:
                restart_s = None
                m.mav.command_long_send(m.target_system, m.target_component,
                                        mav.MAV_CMD_USER_1, 0, 1, 0, 0, 0, 0, 0, 0)
                a = wait(m, "COMMAND_ACK", 5, lambda a: a.command == mav.MAV_CMD_USER_1)
                expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED,
                       f"the estimator restarted from the surface at {t_ms / 1000:.1f} s")
        else:
            reached.append(msg.seq)
    expect(t_ms >= 1000 * seconds, f"flown until {seconds:.0f} s on the vehicle's clock")
    expect(reached == [0, 1, 2], f"every waypoint reached on the estimate ({reached})")
    expect(n >= 100, f"LOCAL_POSITION_NED streamed in AUTO ({n})")


if __name__ == "__main__":
    main()
