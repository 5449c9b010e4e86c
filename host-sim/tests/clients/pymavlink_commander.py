"""One commander at a time, and the MAVLink probes of the surface's bad input.

Usage: pymavlink_commander.py PORT_A PORT_B

Station A (udpin PORT_A) sets MANUAL and arms: it is in control. Its bad commands are refused
and change nothing: ARM_DISARM with param1 = NaN (no disarm), DO_SET_MODE with NaN or -5 (no
STABILIZE). A flies full ahead on MANUAL_CONTROL while station B (udpin PORT_B) sends full
astern: B's sticks are ignored (every SERVO_OUTPUT_RAW stays ahead) and B is told why; B's
mode change is TEMPORARILY_REJECTED. B takes control with CHANGE_OPERATOR_CONTROL: now B's
mode change is accepted and A's refused. In GUIDED, a target 50 m above the surface is refused
with the reason. A (not in control) may still disarm: the emergency stop.
"""
import math
import sys
import threading
import time

from pymavlink import mavutil

from gcs import expect, wait

mav = mavutil.mavlink
MANUAL, STABILIZE, GUIDED, POSHOLD = 19, 0, 4, 16
PASSKEY = 5150


def connect(port):
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=60) is not None, f"station on {port}: a HEARTBEAT arrives")
    return m


def command(m, cmd, *params, timeout=5.0):
    p = list(params) + [0] * (7 - len(params))
    m.mav.command_long_send(m.target_system, m.target_component, cmd, 0, *p)
    return wait(m, "COMMAND_ACK", timeout, lambda a: a.command == cmd)


def set_mode(m, mode):
    return command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)


def heartbeat(m, cond, timeout=5.0):
    return wait(m, "HEARTBEAT", timeout, cond)


def armed(h):
    return h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED != 0


def text(m, needle, timeout=5.0):
    return wait(m, "STATUSTEXT", timeout, lambda s: needle in s.text)


def main():
    a, b = connect(int(sys.argv[1])), connect(int(sys.argv[2]))
    ack = set_mode(a, MANUAL)
    expect(ack is not None and ack.result == mav.MAV_RESULT_ACCEPTED, "A: MANUAL accepted")
    ack = command(a, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    expect(ack is not None and ack.result == mav.MAV_RESULT_ACCEPTED, "A arms: A is in control")
    a.mav.param_set_send(a.target_system, a.target_component, b"CTRL_PASSKEY", PASSKEY,
                         mav.MAV_PARAM_TYPE_REAL32)
    p = wait(a, "PARAM_VALUE", 5, lambda p: p.param_id == "CTRL_PASSKEY")
    expect(p is not None and p.param_value == PASSKEY, "A sets CTRL_PASSKEY")

    # ARM_DISARM with param1 = NaN: refused, still armed.
    ack = command(a, mav.MAV_CMD_COMPONENT_ARM_DISARM, math.nan)
    expect(ack is not None and ack.result == mav.MAV_RESULT_DENIED,
           f"ARM_DISARM with NaN refused ({ack.result if ack else None})")
    expect(heartbeat(a, armed) is not None and heartbeat(a, lambda h: not armed(h), 1.5) is None,
           "and the vehicle stays armed")
    # DO_SET_MODE with NaN or -5: refused, still MANUAL (never STABILIZE).
    for bad in (math.nan, -5.0, 2.5):
        ack = set_mode(a, bad)
        expect(ack is not None and ack.result == mav.MAV_RESULT_DENIED,
               f"DO_SET_MODE {bad} refused ({ack.result if ack else None})")
    expect(heartbeat(a, lambda h: h.custom_mode == MANUAL) is not None
           and heartbeat(a, lambda h: h.custom_mode == STABILIZE, 1.5) is None,
           "the mode stays MANUAL")

    # A full ahead, B full astern, both at 50 Hz for 3 s: A's sticks drive.
    stop = threading.Event()

    def sticks(m, x):
        # At rest for 0.3 s first (thrust follows a stick seen at centre), then x.
        t0 = time.time()
        while not stop.is_set():
            m.mav.manual_control_send(m.target_system, x if time.time() - t0 > 0.3 else 0, 0, 500, 0, 0)
            time.sleep(0.02)

    # A's sticks seen at centre first: after an arming or a change of mode a stick acts
    # only once the vehicle has seen the sticks centred.
    for _ in range(15):
        a.mav.manual_control_send(a.target_system, 0, 0, 500, 0, 0)
        time.sleep(0.02)
    threads = [threading.Thread(target=sticks, args=(a, 1000)),
               threading.Thread(target=sticks, args=(b, -1000))]
    for t in threads:
        t.start()
    pulses = []
    told = None
    try:
        end = time.time() + 3.0
        while time.time() < end:
            msg = b.recv_match(type=["SERVO_OUTPUT_RAW", "STATUSTEXT"], blocking=True, timeout=0.5)
            if msg is None:
                continue
            if msg.get_type() == "SERVO_OUTPUT_RAW":
                pulses.append(msg.servo1_raw)
            elif "Sticks ignored" in msg.text:
                told = msg.text
        # While A's sticks still run: B's mode change is refused.
        ack = set_mode(b, POSHOLD)
    finally:
        stop.set()
        for t in threads:
            t.join()
    ahead = [p for p in pulses if p > 1550]
    astern = [p for p in pulses if p < 1450]
    print(f"pulses seen by B: {len(pulses)}, ahead {len(ahead)}, astern {len(astern)}")
    expect(len(ahead) >= 10, f"A's full ahead drives the thrusters ({len(ahead)} samples > 1550 us)")
    expect(not astern, f"B's full astern never does ({len(astern)} samples < 1450 us)")
    expect(told is not None, f"B is told its sticks are ignored: {told!r}")
    expect(ack is not None and ack.result == mav.MAV_RESULT_TEMPORARILY_REJECTED,
           f"B's mode change is TEMPORARILY_REJECTED ({ack.result if ack else None})")

    # B takes control explicitly, with the passkey A set.
    b.mav.change_operator_control_send(b.target_system, 0, 0, str(PASSKEY).encode())
    c = wait(b, "CHANGE_OPERATOR_CONTROL_ACK", 5)
    expect(c is not None and c.ack == 0, "B takes control (CHANGE_OPERATOR_CONTROL_ACK 0)")
    expect(text(a, "Control:") is not None, "A is told control changed")
    ack = set_mode(b, POSHOLD)
    expect(ack is not None and ack.result == mav.MAV_RESULT_ACCEPTED, "B's POSHOLD accepted")
    ack = set_mode(a, MANUAL)
    expect(ack is not None and ack.result == mav.MAV_RESULT_TEMPORARILY_REJECTED,
           "now A's mode change is refused")

    # GUIDED: a target 50 m above the surface (NED z = -50) is refused with the reason.
    ack = set_mode(b, GUIDED)
    expect(ack is not None and ack.result == mav.MAV_RESULT_ACCEPTED, "B: GUIDED accepted")
    b.mav.set_position_target_local_ned_send(0, b.target_system, b.target_component,
                                             mav.MAV_FRAME_LOCAL_NED, 0b110111111000,
                                             1.0, 0.0, -50.0, 0, 0, 0, 0, 0, 0, 0, 0)
    t = text(b, "Target refused")
    expect(t is not None and "-50" in t.text, f"a target 50 m above the surface is refused: {t.text if t else None!r}")

    # A, not in control, may still disarm (the emergency stop).
    ack = command(a, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    expect(ack is not None and ack.result == mav.MAV_RESULT_ACCEPTED, "A's disarm accepted")
    expect(heartbeat(b, lambda h: not armed(h)) is not None, "disarmed")


if __name__ == "__main__":
    main()
