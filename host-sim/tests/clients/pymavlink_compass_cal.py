"""pymavlink starts the compass calibration turn through `rov-topside --tcp`.

Usage: pymavlink_compass_cal.py PORT SIN_DEG COS_DEG. SIN_DEG / COS_DEG: the simulated
compass's true deviation, as COMPASS_DEV_SIN / COMPASS_DEV_COS would hold it. Refused while
disarmed; then POSHOLD, armed, MAV_CMD_DO_START_MAG_CAL accepted; the turn ends with a
STATUSTEXT "accepted" and the fitted COMPASS_DEV_* read back within 1 deg of the truth (the
largest difference of the two curves over every heading). Exits 0 and prints PASS lines, or
raises.
"""
import math
import sys
import time

from pymavlink import mavutil

from gcs import expect, wait

mav = mavutil.mavlink
POSHOLD = 16
START_MAG_CAL = 42424  # MAV_CMD_DO_START_MAG_CAL (ardupilotmega)


def command(m, cmd, *params):
    p = list(params) + [0] * (7 - len(params))
    m.mav.command_long_send(m.target_system, m.target_component, cmd, 0, *p)
    return wait(m, "COMMAND_ACK", 10, lambda a: a.command == cmd)


def centred(m, seconds, until=None):
    """Centred sticks at 20 Hz for up to `seconds`; the first message `until` takes, if any."""
    end = time.time() + seconds
    while time.time() < end:
        m.mav.manual_control_send(m.target_system, 0, 0, 500, 0, 0)
        stop = time.time() + 0.05
        while time.time() < stop:
            msg = m.recv_match(blocking=True, timeout=0.01)
            if msg is not None and until is not None and until(msg):
                return msg
    return None


def param(m, name):
    m.mav.param_request_read_send(m.target_system, m.target_component, name.encode(), -1)
    return wait(m, "PARAM_VALUE", 10, lambda p: p.param_id == name)


def main():
    port, want_sin, want_cos = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=30) is not None, "a HEARTBEAT arrives")

    a = command(m, START_MAG_CAL)
    expect(a is not None and a.result == mav.MAV_RESULT_DENIED,
           "DO_START_MAG_CAL refused while disarmed")
    before = [param(m, n) for n in ("COMPASS_DEV_SIN", "COMPASS_DEV_COS")]
    expect(all(p is not None and p.param_value == 0.0 for p in before),
           "the refusal left COMPASS_DEV_* at 0")

    centred(m, 3.0)  # the vehicle's estimate converges
    a = command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, POSHOLD)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "POSHOLD accepted")
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "arming accepted")
    centred(m, 2.0)

    a = command(m, START_MAG_CAL)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED,
           "DO_START_MAG_CAL accepted armed in POSHOLD")
    ended = centred(m, 150.0, lambda msg: msg.get_type() == "STATUSTEXT"
                    and msg.text.startswith("Compass calibration")
                    and any(w in msg.text for w in ("accepted", "refused", "stopped")))
    expect(ended is not None and "accepted" in ended.text,
           f"the turn ends with the fit accepted ({ended.text if ended else 'no STATUSTEXT'})")

    got = [param(m, n) for n in ("COMPASS_DEV_SIN", "COMPASS_DEV_COS")]
    expect(all(p is not None for p in got), "COMPASS_DEV_SIN / COS read back")
    ds, dc = got[0].param_value - want_sin, got[1].param_value - want_cos
    print(f"FIT COMPASS_DEV_SIN {got[0].param_value:.3f} COMPASS_DEV_COS "
          f"{got[1].param_value:.3f} deg; truth {want_sin:.3f} {want_cos:.3f}", flush=True)
    expect(math.hypot(ds, dc) <= 1.0, "the fitted deviation within 1 deg of the truth")

    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "disarmed")


if __name__ == "__main__":
    main()
