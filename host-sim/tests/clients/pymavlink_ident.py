"""pymavlink starts the identification manoeuvre (MAV_CMD_USER_2) through `rov-topside --tcp`
in front of `host-sim vehicle`.

Usage: pymavlink_ident.py PORT [quick]. Refused while disarmed and with a radius out of range
(in words); armed in POSHOLD, started with the default room, its progress said, flown to its
end, then started again with a 20 m room and a 1.5 m band and stopped by a stick off centre;
with `quick`, flown for its first 40 s (two progress lines) and stopped there by the stick. Prints PASS lines,
every STATUSTEXT as `TEXT: ...` and `MARK: start` / `MARK: end` around the flown one.
Exits 0 or raises.
"""
import re
import sys
import time

from pymavlink import mavutil

from gcs import expect

mav = mavutil.mavlink
POSHOLD = 16
IDENT = 31011  # MAV_CMD_USER_2
TEXTS = []
# The vehicle's clock in the latest message that carries it (`time_boot_ms`, s).
VEHICLE_S = [None]


def pump(m, seconds, until=None, x=0):
    """Centred sticks (or `x` ahead) at 20 Hz for up to `seconds`, recording STATUSTEXT;
    stops early when a text matches `until`, and returns it."""
    end = time.time() + seconds
    while time.time() < end:
        m.mav.manual_control_send(m.target_system, x, 0, 500, 0, 0)
        stop = time.time() + 0.05
        while time.time() < stop:
            msg = m.recv_match(blocking=True, timeout=0.01)
            if msg is not None and getattr(msg, "time_boot_ms", None) is not None:
                VEHICLE_S[0] = msg.time_boot_ms / 1e3
            if msg is not None and msg.get_type() == "STATUSTEXT":
                TEXTS.append(msg.text)
                print(f"TEXT: {msg.text}", flush=True)
                if until is not None and re.search(until, msg.text):
                    return msg.text
    return None


def command(m, cmd, *params):
    p = list(params) + [0] * (7 - len(params))
    m.mav.command_long_send(m.target_system, m.target_component, cmd, 0, *p)
    end = time.time() + 10
    while time.time() < end:
        a = m.recv_match(blocking=True, timeout=0.5)
        if a is None:
            continue
        if getattr(a, "time_boot_ms", None) is not None:
            VEHICLE_S[0] = a.time_boot_ms / 1e3
        if a.get_type() == "STATUSTEXT":
            TEXTS.append(a.text)
            print(f"TEXT: {a.text}", flush=True)
        elif a.get_type() == "COMMAND_ACK" and a.command == cmd:
            return a
    return None


def refused(m, params, pattern, what):
    k = len(TEXTS)
    a = command(m, IDENT, *params)
    pump(m, 0.5)
    said = " ".join(TEXTS[k:])
    expect(a is not None and a.result == mav.MAV_RESULT_DENIED and re.search(pattern, said),
           f"{what}: DENIED, said /{pattern}/")


def on_the_vehicles_clock(progress, started_s):
    """The progress line's seconds are the vehicle's (the served vehicle runs faster than
    the wall clock): within 2 s of its clock since the start."""
    said_s = float(re.search(r"(\d+) of 160 s", progress).group(1))
    flown_s = VEHICLE_S[0] - started_s
    expect(abs(flown_s - said_s) <= 2.0,
           f"'{said_s:.0f} of 160 s' said at {flown_s:.1f} s of the vehicle's clock")


def main():
    port = int(sys.argv[1])
    quick = len(sys.argv) > 2 and sys.argv[2] == "quick"
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=30) is not None, "a HEARTBEAT arrives")
    refused(m, (20, 1.5), r"Identification refused: the vehicle is disarmed: arm first",
            "disarmed")
    refused(m, (2, 1.5), r"radius 2 m outside 3-100 m", "radius 2 m")
    pump(m, 3.0)  # the vehicle's estimate converges
    a = command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, POSHOLD)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "POSHOLD")
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "armed")
    pump(m, 2.0)
    refused(m, (30, 12), r"not deeper than the depth band 12 m", "a band deeper than the start")

    print("MARK: start", flush=True)
    a = command(m, IDENT, 0, 0)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED,
           "identification accepted (the default room: 30 m, 6 m up or down)")
    started_s = VEHICLE_S[0]
    progress = pump(m, 120, r"^Identification: \d+ of 160 s")
    expect(progress is not None, f"its progress said ({progress})")
    on_the_vehicles_clock(progress, started_s)
    if quick:
        # The quick run: the manoeuvre's first 40 s (its second progress line), then a stick
        # stops it.
        progress = pump(m, 120, r"^Identification: \d+ of 160 s")
        expect(progress is not None, f"its progress said again ({progress})")
        on_the_vehicles_clock(progress, started_s)
        print("MARK: end", flush=True)
        stop = pump(m, 10, r"^Identification stopped", x=600)
        expect(stop is not None and "a stick off" in stop, f"a stick stops it ({stop})")
    else:
        end = pump(m, 600, r"^Identification (finished|stopped)")
        print("MARK: end", flush=True)
        # Flown to its end, or stopped by the vehicle's own checks (a sensor late on a loaded
        # machine is a failsafe): either way said in words.
        expect(end is not None and ("finished" in end or "stopped after" in end),
               f"its end said ({end})")
        a = command(m, IDENT, 20, 1.5)
        expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "started again")
        pump(m, 2.0)
        stop = pump(m, 10, r"^Identification stopped", x=600)
        expect(stop is not None and "a stick off" in stop, f"a stick stops it ({stop})")
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "disarmed")


if __name__ == "__main__":
    main()
