"""The surface program's safety, probed as an operator would (pymavlink against `host-sim topside`).

Usage: pymavlink_surface_safety.py CHECK PORT [PORT_B] [...]

CHECK is one of:
- `target PORT`: commands addressed to another system (2) or component (5) change nothing
  (no answer, not armed, the mode and a parameter unchanged); broadcast (0) is obeyed.
- `sticks PORT`: arming in MANUAL with the stick held full ahead is refused with the reason in
  words and gives 0 pulses away from neutral within 1 s; with the sticks centred it arms, and
  the stick then drives; a mode change with the stick held gives 0 pulses away from neutral
  within 1 s until the stick is seen at centre.
- `handover PORT_A PORT_B`: CHANGE_OPERATOR_CONTROL needs the passkey (CTRL_PASSKEY); the
  holder is told; the new commander's stick held full astern gives 0 pulses away from neutral
  within 1 s of the grant; two stations asking at once get one grant; 100 swaps in 2 s with
  full ahead against full astern reverse no thruster; anyone may disarm.
- `dive PORT`: arms in MANUAL, flies ahead, sets TRK_XY_KP (saved), and keeps flying (the test
  kills the surface program mid-dive).
- `resume PORT KP`: the ground station already listening (it prints READY), the surface
  program restarted at the UNIX time read from stdin: a heartbeat, TRK_XY_KP = KP restored,
  MANUAL and arming accepted, each within 5 s of that time, and no thrust before a stick asks.

A pulse is "away from neutral" when it is more than the ESC's dead band (25 us) from 1500 us.
"""
import sys
import threading
import time

from pymavlink import mavutil

from gcs import expect, wait

mav = mavutil.mavlink
MANUAL, STABILIZE, POSHOLD = 19, 0, 16
NEUTRAL_US, DEADBAND_US = 1500, 25
PASSKEY = 4321


def connect(port):
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=60) is not None, f"station on {port}: a HEARTBEAT arrives")
    return m


def away(s):
    return any(abs(p - NEUTRAL_US) > DEADBAND_US for p in (s.servo1_raw, s.servo2_raw, s.servo3_raw))


class Sticks:
    """MANUAL_CONTROL at 50 Hz from a thread: `x` surge (-1000..1000), z 500 (neutral)."""

    def __init__(self, m):
        self.m, self.x, self.on = m, 0, True
        self.stop = threading.Event()
        self.t = threading.Thread(target=self.run, daemon=True)
        self.t.start()

    def run(self):
        while not self.stop.is_set():
            if self.on:
                self.m.mav.manual_control_send(1, self.x, 0, 500, 0, 0)
            time.sleep(0.02)

    def close(self):
        self.stop.set()
        self.t.join()


TEXTS = {}


def command(m, cmd, *params, target=(1, 1), timeout=5.0):
    """The COMMAND_ACK of `cmd`; the status texts meanwhile kept for `text`."""
    p = list(params) + [0] * (7 - len(params))
    m.mav.command_long_send(target[0], target[1], cmd, 0, *p)
    end = time.time() + timeout
    while time.time() < end:
        msg = m.recv_match(type=["COMMAND_ACK", "STATUSTEXT"], blocking=True,
                           timeout=max(0.02, end - time.time()))
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            TEXTS.setdefault(id(m), []).append(msg)
            print(f"TEXT: {msg.text}", flush=True)
        elif msg.command == cmd:
            return msg
    return None


def set_mode(m, mode, target=(1, 1), timeout=5.0):
    return command(m, mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode,
                   target=target, timeout=timeout)


def arm(m, value=1, target=(1, 1), timeout=5.0):
    return command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, value, target=target, timeout=timeout)


def accepted(ack):
    return ack is not None and ack.result == mav.MAV_RESULT_ACCEPTED


def armed(h):
    return h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED != 0


def heartbeat(m, timeout=3.0):
    return wait(m, "HEARTBEAT", timeout, lambda h: h.get_srcSystem() == 1)


def pulses(m, seconds):
    """Every SERVO_OUTPUT_RAW for `seconds`, and the status texts meanwhile."""
    out, texts = [], []
    end = time.time() + seconds
    while time.time() < end:
        msg = m.recv_match(type=["SERVO_OUTPUT_RAW", "STATUSTEXT"], blocking=True,
                           timeout=max(0.02, end - time.time()))
        if msg is None:
            continue
        if msg.get_type() == "SERVO_OUTPUT_RAW":
            out.append(msg)
        else:
            texts.append(msg.text)
    return out, texts


def param(m, name, timeout=3.0):
    m.mav.param_request_read_send(1, 1, name.encode(), -1)
    p = wait(m, "PARAM_VALUE", timeout, lambda p: p.param_id == name)
    return None if p is None else p.param_value


def param_set(m, name, value, target=(1, 1), timeout=3.0):
    m.mav.param_set_send(target[0], target[1], name.encode(), value,
                         mav.MAV_PARAM_TYPE_REAL32)
    p = wait(m, "PARAM_VALUE", timeout, lambda p: p.param_id == name)
    return None if p is None else p.param_value


def text(m, needle, timeout=3.0):
    """A status text with `needle`, among those kept while waiting for an ACK or new."""
    kept = TEXTS.get(id(m), [])
    for i, t in enumerate(kept):
        if needle in t.text:
            del kept[: i + 1]
            return t
    return wait(m, "STATUSTEXT", timeout, lambda s: needle in s.text)


def check_target(port):
    m = connect(port)
    kp = param(m, "TRK_XY_KP")
    expect(kp is not None, f"TRK_XY_KP reads {kp}")
    for target in ((2, 1), (1, 5)):
        p = param_set(m, "TRK_XY_KP", kp * 2, target=target, timeout=1.5)
        expect(p is None, f"PARAM_SET to {target} is not answered ({p})")
        ack = set_mode(m, MANUAL, target=target, timeout=1.5)
        expect(ack is None, f"DO_SET_MODE to {target} is not answered ({ack})")
        ack = arm(m, target=target, timeout=1.5)
        expect(ack is None, f"ARM to {target} is not answered ({ack})")
    hb = heartbeat(m)
    expect(hb is not None and not armed(hb), "the vehicle is not armed")
    expect(param(m, "TRK_XY_KP") == kp, "TRK_XY_KP unchanged")
    # Armed in MANUAL by commands to us (broadcast 0 is for every system), the sticks at rest:
    # full ahead addressed to system 2 gives no thrust, and a disarm to system 2 is ignored.
    expect(accepted(set_mode(m, MANUAL, target=(0, 0))), "DO_SET_MODE broadcast (0, 0) is obeyed")
    s = Sticks(m)
    try:
        time.sleep(0.3)
        expect(accepted(arm(m)), "armed with the sticks at rest")
        time.sleep(0.3)
        s.on = False
        end = time.time() + 1.0
        while time.time() < end:
            m.mav.manual_control_send(2, 1000, 0, 500, 0, 0)
            time.sleep(0.02)
        s.on = True
        seen, _ = pulses(m, 0.5)
        expect(seen and not any(away(p) for p in seen),
               f"MANUAL_CONTROL to system 2: 0 pulses away from neutral ({len(seen)} samples)")
        ack = arm(m, 0, target=(2, 1), timeout=1.5)
        hb = heartbeat(m)
        expect(ack is None and hb is not None and armed(hb), "a disarm to system 2 is ignored")
    finally:
        s.close()
    expect(accepted(arm(m, 0)), "disarmed")


def check_sticks(port):
    m = connect(port)
    expect(accepted(set_mode(m, MANUAL)), "MANUAL accepted")
    s = Sticks(m)
    try:
        s.x = 1000
        time.sleep(1.0)
        t0 = time.time()
        ack = arm(m)
        why = text(m, "centre", timeout=1.0)
        seen, _ = pulses(m, 1.0 - (time.time() - t0))
        bad = [p for p in seen if away(p)]
        expect(ack is not None and ack.result == mav.MAV_RESULT_DENIED,
               f"arming with the stick held full ahead is refused ({ack.result if ack else None})")
        expect(why is not None, f"with the reason in words: {why.text if why else None!r}")
        expect(len(seen) >= 3 and not bad,
               f"0 pulses away from neutral within 1 s ({len(bad)} of {len(seen)})")
        hb = heartbeat(m)
        expect(hb is not None and not armed(hb), "not armed")

        s.x = 0
        time.sleep(0.5)
        expect(accepted(arm(m)), "with the sticks centred, arming is accepted")
        time.sleep(0.3)
        s.x = 1000
        seen, _ = pulses(m, 1.5)
        ahead = [p for p in seen if p.servo1_raw > NEUTRAL_US + DEADBAND_US]
        expect(len(ahead) >= 3, f"then the stick drives ({len(ahead)} samples ahead)")

        # A mode change with the stick held: neutral until the stick is seen at centre.
        for mode in (POSHOLD, MANUAL):
            ack = set_mode(m, mode)
            expect(accepted(ack), f"mode {mode} accepted with the stick held")
        t0 = time.time()
        seen, _ = pulses(m, 1.0)
        bad = [p for p in seen if away(p)]
        expect(len(seen) >= 5 and not bad,
               f"after MANUAL again, 0 pulses away from neutral within 1 s ({len(bad)} of {len(seen)})")
        s.x = 0
        time.sleep(0.3)
        s.x = -1000
        seen, _ = pulses(m, 1.5)
        astern = [p for p in seen if p.servo1_raw < NEUTRAL_US - DEADBAND_US]
        expect(len(astern) >= 3, f"after a centred stick the stick drives ({len(astern)} astern)")
    finally:
        s.close()
    expect(accepted(arm(m, 0)), "disarmed")


def check_handover(port_a, port_b):
    a, b = connect(port_a), connect(port_b)
    expect(param_set(a, "CTRL_PASSKEY", PASSKEY) == PASSKEY, f"A sets CTRL_PASSKEY {PASSKEY}")
    expect(accepted(set_mode(a, MANUAL)), "A: MANUAL accepted")
    sa, sb = Sticks(a), Sticks(b)
    try:
        expect(accepted(arm(a)), "A arms (sticks centred)")
        time.sleep(0.3)
        sa.x, sb.x = 1000, -1000
        seen, _ = pulses(a, 1.5)
        expect(sum(p.servo1_raw > NEUTRAL_US + DEADBAND_US for p in seen) >= 3, "A flies full ahead")

        b.mav.change_operator_control_send(1, 0, 0, b"1234")
        c = wait(b, "CHANGE_OPERATOR_CONTROL_ACK", 3)
        expect(c is not None and c.ack == 1, f"B with a wrong passkey: NACK 1 ({c.ack if c else None})")
        seen, _ = pulses(a, 1.0)
        expect(seen and all(p.servo1_raw > NEUTRAL_US + DEADBAND_US for p in seen),
               "A still flies ahead")

        b.mav.change_operator_control_send(1, 0, 0, str(PASSKEY).encode())
        c = wait(b, "CHANGE_OPERATOR_CONTROL_ACK", 3)
        t0 = time.time()
        expect(c is not None and c.ack == 0, f"B with the passkey: granted ({c.ack if c else None})")
        # On B's connection: what was sent after the grant (A's holds older samples).
        seen, _ = pulses(b, 1.0 - (time.time() - t0))
        bad = [p for p in seen if away(p)]
        expect(len(seen) >= 3 and not bad,
               f"B's full astern: 0 pulses away from neutral within 1 s ({len(bad)} of {len(seen)})")
        told = text(a, "Control taken", 2.0)
        expect(told is not None, f"A is told: {told.text if told else None!r}")
        sb.x = 0
        time.sleep(0.3)
        sb.x = -1000
        seen, _ = pulses(b, 1.5)
        expect(sum(p.servo1_raw < NEUTRAL_US - DEADBAND_US for p in seen) >= 3,
               "B's stick drives after it was seen at centre")

        # Rapid swapping: A and B take control in turn, 100 times in 2 s, sticks held apart.
        samples = []
        stop = threading.Event()

        def watch():
            while not stop.is_set():
                msg = a.recv_match(type="SERVO_OUTPUT_RAW", blocking=True, timeout=0.1)
                if msg is not None:
                    samples.append(msg.servo1_raw)

        sa.x, sb.x = 1000, -1000
        w = threading.Thread(target=watch, daemon=True)
        w.start()
        for i in range(100):
            (a if i % 2 == 0 else b).mav.change_operator_control_send(1, 0, 0, str(PASSKEY).encode())
            time.sleep(0.02)
        time.sleep(1.0)
        stop.set()
        w.join()
        reversals, last = 0, 0
        for p in samples:
            sign = 1 if p > NEUTRAL_US + DEADBAND_US else -1 if p < NEUTRAL_US - DEADBAND_US else 0
            if sign and last and sign != last:
                reversals += 1
            last = sign if sign else 0
        print(f"swaps: {len(samples)} pulses sampled, {reversals} reversals without neutral")
        expect(len(samples) >= 15 and reversals == 0, f"100 swaps reverse no thruster ({reversals})")

        # Two stations asking at once: one grant. Free control first.
        sa.on = sb.on = False
        time.sleep(2.2)
        holder = None
        for m in (a, b):
            m.mav.change_operator_control_send(1, 1, 0, b"")
        time.sleep(0.5)
        while a.recv_match(blocking=False) is not None:
            pass
        while b.recv_match(blocking=False) is not None:
            pass
        a.mav.change_operator_control_send(1, 0, 0, str(PASSKEY).encode())
        b.mav.change_operator_control_send(1, 0, 0, str(PASSKEY).encode())
        ca = wait(a, "CHANGE_OPERATOR_CONTROL_ACK", 3)
        cb = wait(b, "CHANGE_OPERATOR_CONTROL_ACK", 3)
        grants = [c for c in (ca, cb) if c is not None and c.ack == 0]
        expect(ca is not None and cb is not None and len(grants) == 1,
               f"two stations asking at once: one grant ({ca.ack if ca else None}, {cb.ack if cb else None})")
        holder = a if ca.ack == 0 else b
        other = b if holder is a else a
        # The other, not in control, may still disarm: the emergency stop.
        expect(accepted(arm(other, 0)), "the station not in control disarms")
        hb = heartbeat(holder)
        expect(hb is not None and not armed(hb), "disarmed")
    finally:
        sa.close()
        sb.close()


def check_dive(port):
    m = connect(port)
    kp = param(m, "TRK_XY_KP")
    got = param_set(m, "TRK_XY_KP", kp * 1.25)
    expect(got is not None and abs(got - kp * 1.25) < 1e-5, f"TRK_XY_KP set to {got}")
    print(f"KP={got!r}", flush=True)
    expect(accepted(set_mode(m, MANUAL)), "MANUAL accepted")
    s = Sticks(m)
    try:
        expect(accepted(arm(m)), "armed")
        time.sleep(0.3)
        s.x = 800
        seen, _ = pulses(m, 1.0)
        expect(any(p.servo1_raw > NEUTRAL_US + DEADBAND_US for p in seen), "flying ahead")
        print("DIVING", flush=True)
        time.sleep(30)
    finally:
        s.close()


def check_resume(port, kp):
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    print("READY", flush=True)
    t0 = float(sys.stdin.readline())
    hb = m.wait_heartbeat(timeout=10)
    t_hb = time.time() - t0
    expect(hb is not None, f"a HEARTBEAT {t_hb:.2f} s after the restart")
    got = param(m, "TRK_XY_KP")
    t_param = time.time() - t0
    expect(got is not None and abs(got - kp) < 1e-6, f"TRK_XY_KP {got} restored ({t_param:.2f} s)")
    seen, _ = pulses(m, 0.5)
    thrusting = [p for p in seen if away(p)]
    expect(seen and not thrusting,
           f"no thrust before a command asks ({len(seen)} SERVO_OUTPUT_RAW in 0.5 s, "
           f"{len(thrusting)} away from neutral"
           + (f": {[(p.servo1_raw, p.servo2_raw, p.servo3_raw) for p in thrusting[:3]]})"
              if thrusting else ")"))
    expect(accepted(set_mode(m, MANUAL)), "MANUAL accepted")
    s = Sticks(m)
    try:
        time.sleep(0.2)
        expect(accepted(arm(m)), "armed")
        t_control = time.time() - t0
        print(f"RESUMED heartbeat {t_hb:.2f} s, parameters {t_param:.2f} s, control {t_control:.2f} s")
        expect(t_control < 5.0, f"flying again within 5 s ({t_control:.2f} s)")
        seen, _ = pulses(m, 0.5)
        expect(seen and not any(away(p) for p in seen), "armed with centred sticks: no thrust")
        s.x = 1000
        seen, _ = pulses(m, 1.0)
        expect(any(p.servo1_raw > NEUTRAL_US + DEADBAND_US for p in seen), "the stick drives")
    finally:
        s.close()
    expect(accepted(arm(m, 0)), "disarmed")


def mission_ack(m, timeout=1.0):
    return wait(m, "MISSION_ACK", timeout)


def upload_start(m, count, mission_type=0):
    m.mav.mission_count_send(1, 1, count, mission_type)


def item(m, seq, x, y, z, frame=None, command=None):
    m.mav.mission_item_int_send(1, 1, seq, mav.MAV_FRAME_LOCAL_NED if frame is None else frame,
                                mav.MAV_CMD_NAV_WAYPOINT if command is None else command, 0, 1,
                                0, 0, 0, 0, round(x * 1e4), round(y * 1e4), z)


def download(m):
    m.mav.mission_request_list_send(1, 1, 0)
    c = wait(m, "MISSION_COUNT", 3, lambda c: c.mission_type == 0)
    return None if c is None else c.count


def check_missions(port):
    m = connect(port)
    points = [(1.0, 0.0, 2.0), (2.0, 0.0, 2.0)]
    upload_start(m, 2)
    for seq, p in enumerate(points):
        r = wait(m, "MISSION_REQUEST_INT", 3, lambda r: r.seq == seq)
        expect(r is not None, f"item {seq} requested")
        item(m, seq, *p)
    a = mission_ack(m, 3)
    expect(a is not None and a.type == mav.MAV_MISSION_ACCEPTED, "a 2-waypoint mission accepted")
    expect(download(m) == 2, "the mission holds 2")

    m.mav.mission_clear_all_send(1, 1, mav.MAV_MISSION_TYPE_FENCE)
    a = mission_ack(m)
    expect(a is not None and a.mission_type == mav.MAV_MISSION_TYPE_FENCE,
           f"MISSION_CLEAR_ALL for the FENCE answered for the FENCE ({a})")
    expect(download(m) == 2, "and the mission still holds 2")
    for kind in (mav.MAV_MISSION_TYPE_FENCE, mav.MAV_MISSION_TYPE_RALLY, mav.MAV_MISSION_TYPE_ALL):
        upload_start(m, 3, kind)
        a = mission_ack(m)
        expect(a is not None and a.type == mav.MAV_MISSION_UNSUPPORTED and a.mission_type == kind,
               f"an upload of type {kind}: MAV_MISSION_UNSUPPORTED ({a})")
        expect(download(m) == 2, "the mission still holds 2")
    m.mav.mission_request_list_send(1, 1, mav.MAV_MISSION_TYPE_FENCE)
    c = wait(m, ["MISSION_COUNT", "MISSION_ACK"], 1.0)
    expect(c is not None and c.mission_type == mav.MAV_MISSION_TYPE_FENCE
           and (c.get_type() == "MISSION_ACK" or c.count == 0),
           f"the FENCE list is kept apart (empty or unsupported): {c}")

    for what, kw, seq, want in (
            ("a sequence number past the count", {}, 5, mav.MAV_MISSION_INVALID_SEQUENCE),
            ("an unknown command", {"command": 64999}, 0, mav.MAV_MISSION_UNSUPPORTED),
            ("an unknown frame", {"frame": 99}, 0, mav.MAV_MISSION_UNSUPPORTED_FRAME)):
        upload_start(m, 2)
        r = wait(m, "MISSION_REQUEST_INT", 3, lambda r: r.seq == 0)
        expect(r is not None, "item 0 requested")
        item(m, seq, 3.0, 0.0, 2.0, **kw)
        a = mission_ack(m, 1.0)
        expect(a is not None and a.type == want, f"{what}: MISSION_ACK {want} within 1 s ({a})")
        expect(download(m) == 2, "the mission still holds 2")

    m.mav.mission_clear_all_send(1, 1, mav.MAV_MISSION_TYPE_MISSION)
    a = mission_ack(m)
    expect(a is not None and a.type == mav.MAV_MISSION_ACCEPTED, "MISSION_CLEAR_ALL of the mission")
    expect(download(m) == 0, "clears the mission")


def main():
    check, args = sys.argv[1], sys.argv[2:]
    if check == "target":
        check_target(int(args[0]))
    elif check == "sticks":
        check_sticks(int(args[0]))
    elif check == "handover":
        check_handover(int(args[0]), int(args[1]))
    elif check == "missions":
        check_missions(int(args[0]))
    elif check == "dive":
        check_dive(int(args[0]))
    elif check == "resume":
        check_resume(int(args[0]), float(args[1]))
    else:
        raise SystemExit(f"unknown check {check}")


if __name__ == "__main__":
    main()
