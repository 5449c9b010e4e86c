"""Two ground stations at once, one of them flooding MANUAL_CONTROL (bad input).

Usage: pymavlink_two_gcs.py PORT_PILOT PORT_OBSERVER

The pilot's station (udpin PORT_PILOT) sets MANUAL, arms and then sends MANUAL_CONTROL as fast
as Python can for 6 s; the observer's station (udpin PORT_OBSERVER), a second ground station
on another connection, meanwhile counts what it receives and takes control and commands the vehicle itself. The
flood must starve neither: the observer gets the heartbeat and the 10 Hz state streams at
their rates, its own commands are answered at once, and the pilot's sticks still drive the
thrusters.
"""
import sys
import threading
import time

from pymavlink import mavutil

from gcs import expect, wait

mav = mavutil.mavlink
MANUAL, POSHOLD = 19, 16
PASSKEY = 2718


def connect(port):
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=30) is not None, f"station on {port}: a HEARTBEAT arrives")
    return m


def ack(m, command, timeout=3.0):
    t0 = time.time()
    a = wait(m, "COMMAND_ACK", timeout, lambda a: a.command == command)
    return a, time.time() - t0


def main():
    pilot, observer = connect(int(sys.argv[1])), connect(int(sys.argv[2]))
    # The passkey another station needs to take control (CHANGE_OPERATOR_CONTROL).
    pilot.mav.param_set_send(pilot.target_system, pilot.target_component, b"CTRL_PASSKEY", PASSKEY,
                             mav.MAV_PARAM_TYPE_REAL32)
    p = wait(pilot, "PARAM_VALUE", 5, lambda p: p.param_id == "CTRL_PASSKEY")
    expect(p is not None and p.param_value == PASSKEY, "the pilot sets CTRL_PASSKEY")
    pilot.mav.set_mode_send(pilot.target_system, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MANUAL)
    pilot.mav.command_long_send(pilot.target_system, pilot.target_component,
                                mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    a, _ = ack(pilot, mav.MAV_CMD_COMPONENT_ARM_DISARM)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "the pilot arms")

    # The sticks seen at centre first: after an arming a stick acts only once the vehicle
    # has seen the sticks centred.
    for _ in range(15):
        pilot.mav.manual_control_send(pilot.target_system, 0, 0, 500, 0, 0)
        time.sleep(0.02)
    sent = [0]
    stop = threading.Event()

    def flood():
        # The sticks at rest first (thrust follows a stick seen at centre), then 80 % ahead.
        while not stop.is_set():
            x = 0 if sent[0] < 200 else 800
            pilot.mav.manual_control_send(pilot.target_system, x, 0, 500, 0, 0)
            sent[0] += 1

    counts = {}
    t = threading.Thread(target=flood)
    t.start()
    start = time.time()
    try:
        # What the observer receives over 5 s of flood.
        first_pulse = None
        while time.time() - start < 5.0:
            msg = observer.recv_match(blocking=True, timeout=0.5)
            if msg is None:
                continue
            k = msg.get_type()
            counts[k] = counts.get(k, 0) + 1
            if k == "SERVO_OUTPUT_RAW" and first_pulse is None and msg.servo1_raw > 1550:
                first_pulse = time.time() - start
        # The observer's own command during the flood: a mode change, answered at once -
        # refused while the pilot is in control, accepted once the observer takes control
        # (one commander at a time).
        observer.mav.command_long_send(observer.target_system, observer.target_component,
                                       mav.MAV_CMD_DO_SET_MODE, 0,
                                       mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, POSHOLD,
                                       0, 0, 0, 0, 0)
        refused, _ = ack(observer, mav.MAV_CMD_DO_SET_MODE)
        observer.mav.change_operator_control_send(observer.target_system, 0, 0,
                                                  str(PASSKEY).encode())
        took = wait(observer, "CHANGE_OPERATOR_CONTROL_ACK", 3)
        observer.mav.command_long_send(observer.target_system, observer.target_component,
                                       mav.MAV_CMD_DO_SET_MODE, 0,
                                       mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, POSHOLD,
                                       0, 0, 0, 0, 0)
        a, dt = ack(observer, mav.MAV_CMD_DO_SET_MODE)
    finally:
        stop.set()
        t.join()
    elapsed = time.time() - start
    rate = sent[0] / elapsed
    print(f"flood: {sent[0]} MANUAL_CONTROL in {elapsed:.1f} s ({rate:.0f}/s); observer got {counts}")
    expect(rate > 2000, f"the flood is a flood: {rate:.0f} MANUAL_CONTROL a second")
    expect(counts.get("HEARTBEAT", 0) >= 4, f"the observer gets the 1 Hz HEARTBEAT ({counts.get('HEARTBEAT', 0)} in 5 s)")
    expect(counts.get("LOCAL_POSITION_NED", 0) >= 40,
           f"and the 10 Hz state ({counts.get('LOCAL_POSITION_NED', 0)} LOCAL_POSITION_NED in 5 s)")
    expect(first_pulse is not None, f"the pilot's sticks drive the thrusters (pulse > 1550 us after {first_pulse} s)")
    expect(refused is not None and refused.result == mav.MAV_RESULT_TEMPORARILY_REJECTED,
           "the observer's mode change is refused while the pilot is in control")
    expect(took is not None and took.ack == 0, "the observer takes control")
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED and dt < 1.0,
           f"the observer's mode change is answered during the flood ({dt:.2f} s)")
    hb = wait(pilot, "HEARTBEAT", 3, lambda h: h.custom_mode == POSHOLD)
    expect(hb is not None, "both stations see the vehicle in POSHOLD")
    pilot.mav.command_long_send(pilot.target_system, pilot.target_component,
                                mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    a, _ = ack(pilot, mav.MAV_CMD_COMPONENT_ARM_DISARM)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "disarmed")


if __name__ == "__main__":
    main()
