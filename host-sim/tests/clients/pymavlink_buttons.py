"""pymavlink's joystick buttons (MANUAL_CONTROL.buttons) through `rov-topside --tcp` in front of
`host-sim vehicle`, with ArduSub's default BTNn_FUNCTION.

Usage: pymavlink_buttons.py PORT PORT2. The commander on udpin PORT, a second station on
udpin PORT2. Arm (button 6), STABILIZE (3), ALT_HOLD (2), MANUAL (1); the gain buttons (11 up,
12 down) step once per press however long held; a replayed frame, a frame from the second
station and a button held across a lapse of the stream never act; disarm (4). Prints PASS
lines, every STATUSTEXT as `TEXT: ...` and `MARK: surge-at-50` before the sticks full ahead
at a gain of 50 %. Exits 0 or raises.
"""
import sys
import time

from pymavlink import mavutil

from gcs import expect

mav = mavutil.mavlink
TEXTS = []


def pump(m, seconds):
    """Read (and record STATUSTEXT) for `seconds`; the latest HEARTBEAT of the vehicle."""
    end = time.time() + seconds
    hb = None
    while time.time() < end:
        msg = m.recv_match(blocking=True, timeout=0.01)
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            TEXTS.append(msg.text)
            print(f"TEXT: {msg.text}", flush=True)
        elif msg.get_type() == "HEARTBEAT" and msg.get_srcSystem() == 1:
            hb = msg
    return hb


def frames(m, seconds, buttons=0, x=0):
    """MANUAL_CONTROL at 20 Hz for `seconds` (centred unless `x`), `buttons` held; the
    latest HEARTBEAT of the vehicle meanwhile."""
    end = time.time() + seconds
    hb = None
    while time.time() < end:
        m.mav.manual_control_send(1, x, 0, 500, 0, buttons)
        hb = pump(m, 0.05) or hb
    return hb


def press(m, button, held=0.25):
    frames(m, held, 1 << button)
    frames(m, 0.2)


def state(m):
    """(armed, custom mode) from the vehicle's last HEARTBEAT over two seconds of centred
    frames: at 1 Hz, the last one is at least a second after what was pressed, so a command
    still on its way over the tether (a loaded machine) is not read as refused."""
    hb = frames(m, 2.1)
    expect(hb is not None, "a HEARTBEAT")
    return bool(hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED), hb.custom_mode


def gains_said(since):
    return [t for t in TEXTS[since:] if t.startswith("#Gain is")]


def main():
    port, port2 = int(sys.argv[1]), int(sys.argv[2])
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    other = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port2}", source_system=254)
    expect(m.wait_heartbeat(timeout=30) is not None, "a HEARTBEAT arrives")
    other.wait_heartbeat(timeout=10)
    frames(m, 1.0)
    press(m, 6)
    expect(state(m)[0], "button 6 (ArduSub's arm) armed")
    for button, mode, name in [(3, 0, "STABILIZE"), (2, 2, "ALT_HOLD"), (1, 19, "MANUAL")]:
        press(m, button)
        got = state(m)[1]
        expect(got == mode, f"button {button}: {name} (mode {got})")

    # Held for 1.5 s: one step. Then each press one more, within JS_GAIN_MIN..MAX.
    k = len(TEXTS)
    frames(m, 1.5, 1 << 11)
    frames(m, 0.3)
    expect(gains_said(k) == ["#Gain is 75%"], f"held gain up: one step ({gains_said(k)})")
    k = len(TEXTS)
    press(m, 11)
    press(m, 11)
    expect(gains_said(k) == ["#Gain is 100%", "#Gain is 100%"],
           f"gain up twice: at JS_GAIN_MAX ({gains_said(k)})")
    k = len(TEXTS)
    press(m, 12)
    press(m, 12)
    expect(gains_said(k) == ["#Gain is 75%", "#Gain is 50%"], f"gain down twice ({gains_said(k)})")
    print("MARK: surge-at-50", flush=True)
    frames(m, 1.0, 0, x=1000)
    frames(m, 0.5)

    # A replayed frame (its sequence number again, or an older one) does nothing.
    seq = m.mav.seq
    m.mav.manual_control_send(1, 0, 0, 500, 0, 0)
    for again in [seq, (seq - 3) % 256]:
        m.mav.seq = again
        m.mav.manual_control_send(1, 0, 0, 500, 0, 1 << 4)
    m.mav.seq = (seq + 1) % 256
    frames(m, 0.3)
    expect(state(m)[0], "a replayed frame with the disarm button did not disarm")

    # The second station's buttons do nothing.
    for _ in range(3):
        frames(other, 0.25, 1 << 4)
        frames(other, 0.25)
        frames(m, 0.1)
    expect(state(m)[0], "the other station's disarm button did nothing")

    # The stream lapses (1 s); the disarm button held when it resumes does not act until
    # pressed again.
    pump(m, 1.0)
    frames(m, 1.0, 1 << 4)
    expect(state(m)[0], "a button held across a lapse of the stream did not act")
    frames(m, 0.3)
    press(m, 4)
    expect(not state(m)[0], "button 4 (ArduSub's disarm) disarmed")


if __name__ == "__main__":
    main()
