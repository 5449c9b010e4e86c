"""pymavlink runs ArduSub's motor test (MAV_CMD_DO_MOTOR_TEST) through `rov-topside --tcp`
in front of `host-sim vehicle`.

Usage: pymavlink_motor_test.py PORT. Refused while disarmed and with bad parameters (each in
words); armed in MANUAL, the vertical thruster at 1700 us for ArduSub's 0.5 s, the others
neutral, then the vehicle disarms and says so; kept going by requests resent within the
window; ended at once by a change of mode. Prints PASS lines, every STATUSTEXT as
`TEXT: ...`, and `MARK: name` at each phase (the test reads the truth log between them).
Exits 0 or raises.
"""
import re
import sys
import time

from pymavlink import mavutil

from gcs import expect

mav = mavutil.mavlink
MANUAL, STABILIZE = 19, 0
MOTOR_TEST = 209  # MAV_CMD_DO_MOTOR_TEST
PWM, PERCENT = 1, 0
TEXTS = []
MARK = [0]


def recv(m, kind, timeout=10.0, cond=lambda msg: True):
    kinds = [kind] if isinstance(kind, str) else kind
    end = time.time() + timeout
    while time.time() < end:
        msg = m.recv_match(blocking=True, timeout=max(0.02, end - time.time()))
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            TEXTS.append(msg.text)
            print(f"TEXT: {msg.text}", flush=True)
        if msg.get_type() in kinds and cond(msg):
            return msg
    return None


def command(m, cmd, *params):
    p = list(params) + [0] * (7 - len(params))
    MARK[0] = len(TEXTS)
    m.mav.command_long_send(m.target_system, m.target_component, cmd, 0, *p)
    return recv(m, "COMMAND_ACK", 10, lambda a: a.command == cmd)


def said(m, pattern, seconds=3.0):
    end = time.time() + seconds
    while True:
        if re.search(pattern, " ".join(TEXTS[MARK[0]:])):
            return True
        if time.time() >= end:
            return False
        recv(m, "NOTHING", 0.1)


def refused(m, params, pattern, what):
    a = command(m, MOTOR_TEST, *params)
    expect(a is not None and a.result == mav.MAV_RESULT_DENIED and said(m, pattern),
           f"{what}: DENIED, said /{pattern}/")


def armed(m, timeout=5.0):
    hb = recv(m, "HEARTBEAT", timeout, lambda h: h.get_srcSystem() == m.target_system)
    return hb is not None and bool(hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)


def arm(m):
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "armed")


def servos(m, seconds, resend=None, every=0.1):
    """SERVO_OUTPUT_RAW's three outputs over `seconds`, resending `resend` every `every` s."""
    seen = []
    end = time.time() + seconds
    next_send = time.time()
    while time.time() < end:
        if resend is not None and time.time() >= next_send:
            m.mav.command_long_send(m.target_system, m.target_component, MOTOR_TEST, 0,
                                    *resend, *([0] * (7 - len(resend))))
            next_send += every
        s = recv(m, "SERVO_OUTPUT_RAW", 0.05)
        if s is not None:
            seen.append((s.servo1_raw, s.servo2_raw, s.servo3_raw))
    return seen


def main():
    port = int(sys.argv[1])
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=30) is not None, "a HEARTBEAT arrives")
    a = command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MANUAL)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "MANUAL")

    refused(m, (3, PWM, 1700), r"Motor test refused: the vehicle is disarmed: arm first",
            "disarmed")
    arm(m)
    refused(m, (4, PWM, 1700), r"motor 4 does not exist \(1 port, 2 starboard, 3 vertical\)",
            "motor 4")
    refused(m, (1, PWM, 2100), r"PWM 2100 us outside 1100-1900 us", "PWM 2100")
    refused(m, (1, PERCENT, 150), r"throttle 150 % outside 0-100", "150 %")
    refused(m, (1, 2, 50), r"throttle type 2 is not offered", "throttle type pilot")
    refused(m, (1, PWM, 1600, 0, 3), r"one thruster at a time", "three motors")
    expect(armed(m), "still armed after the refusals")

    # One request: the vertical thruster at 1700 us for ArduSub's 0.5 s, then a disarm.
    print("MARK: single", flush=True)
    a = command(m, MOTOR_TEST, 3, PWM, 1700, 0)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED
           and said(m, r"Motor test: motor 3 \(vertical\) at 1700 us for 0\.5 s"),
           "motor 3 at 1700 us accepted, said")
    seen = servos(m, 1.5)
    tested = [s for s in seen if s[2] == 1700]
    expect(len(tested) >= 1 and all(s[0] == 1500 and s[1] == 1500 for s in tested),
           f"SERVO_OUTPUT_RAW: output 3 at 1700 us ({len(tested)} reports), 1 and 2 neutral")
    expect(seen and seen[-1] == (1500, 1500, 1500), f"neutral after the window: {seen[-1:]}")
    expect(said(m, r"Motor test timed out: the vehicle disarmed", 3) and not armed(m),
           "the window's end disarmed the vehicle, said")
    print("MARK: single-end", flush=True)

    # Resent every 0.1 s (0.2 s of the vehicle's time at 2x) for 2 s: it goes on.
    arm(m)
    print("MARK: keep", flush=True)
    seen = servos(m, 2.0, resend=(1, PERCENT, 75, 0), every=0.1)
    on = [s for s in seen[3:]]
    expect(len(on) >= 5 and all(s == (1700, 1500, 1500) for s in on),
           f"kept going by resending: 75 % = 1700 us on output 1 in {len(on)} reports")
    print("MARK: keep-end", flush=True)
    expect(said(m, r"Motor test timed out", 3) and not armed(m), "then timed out, disarmed")

    # A change of mode ends it at once, the vehicle armed.
    arm(m)
    a = command(m, MOTOR_TEST, 2, PWM, 1300, 0.5)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "motor 2 at 1300 us")
    a = command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, STABILIZE)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "STABILIZE")
    recv(m, "NOTHING", 0.3)
    seen = servos(m, 1.0)
    expect(seen and all(s == (1500, 1500, 1500) for s in seen) and armed(m),
           f"the mode change ended it: neutral, still armed ({len(seen)} reports)")
    a = command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "disarmed")


if __name__ == "__main__":
    main()
