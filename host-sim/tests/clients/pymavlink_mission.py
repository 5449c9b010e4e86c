"""A pymavlink ground station uploads a mission through `rov-topside --tcp` and flies it in AUTO
(a real client).

Usage: pymavlink_mission.py PORT. Listens on udpin:127.0.0.1:PORT for the topside. Exits 0 and
prints PASS lines, or raises. The mission protocol is driven by hand, message by message, as
QGroundControl does: MISSION_COUNT, then one MISSION_ITEM_INT per MISSION_REQUEST_INT, then
MISSION_ACK; download with MISSION_REQUEST_LIST.
"""
import math
import sys
import time

from pymavlink import mavutil

from gcs import arm_and_auto, expect, wait

AUTO, MANUAL = 3, 19
SPEED = 0.35  # m/s along the path (the default is 0.25)
mav = mavutil.mavlink


def send_item(m, seq, north, east, depth, frame=None, command=None):
    """One MISSION_ITEM_INT through the connection's own encoder (its MAVLink version)."""
    m.mav.mission_item_int_send(
        m.target_system, m.target_component, seq,
        mav.MAV_FRAME_LOCAL_NED if frame is None else frame,
        mav.MAV_CMD_NAV_WAYPOINT if command is None else command,
        0, 1, 0, 0.5, 0, 0, int(north * 1e4), int(east * 1e4), depth)


TEXTS = []


def upload(m, points, **bad):
    """Upload `points` [(north, east, depth)]; returns the MISSION_ACK type (the STATUSTEXTs
    that came meanwhile go to TEXTS)."""
    m.mav.mission_count_send(m.target_system, m.target_component, len(points))
    requests = 0
    while True:
        msg = m.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK",
                                 "STATUSTEXT"], blocking=True, timeout=10)
        expect(msg is not None or requests > 0, "the vehicle answers the upload")
        if msg is None:
            raise AssertionError("no answer to an item")
        if msg.get_type() == "STATUSTEXT":
            TEXTS.append(msg.text)
            continue
        if msg.get_type() == "MISSION_ACK":
            return msg.type
        requests += 1
        n, e, d = points[msg.seq]
        kw = bad if msg.seq == len(points) - 1 else {}
        send_item(m, msg.seq, n, e, d, **kw)


def download(m):
    m.mav.mission_request_list_send(m.target_system, m.target_component)
    c = wait(m, "MISSION_COUNT", 10)
    expect(c is not None, "MISSION_COUNT answers MISSION_REQUEST_LIST")
    got = []
    for seq in range(c.count):
        m.mav.mission_request_int_send(m.target_system, m.target_component, seq)
        it = wait(m, "MISSION_ITEM_INT", 10, lambda i, s=seq: i.seq == s)
        expect(it is not None, f"item {seq} downloaded")
        got.append((it.x / 1e4, it.y / 1e4, it.z))
    m.mav.mission_ack_send(m.target_system, m.target_component, mav.MAV_MISSION_ACCEPTED)
    return got


def position(m):
    p = wait(m, "LOCAL_POSITION_NED", 5)
    expect(p is not None, "LOCAL_POSITION_NED streams")
    return p


def main():
    port = int(sys.argv[1])
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=30) is not None, "a HEARTBEAT arrives")
    p0 = position(m)
    # A triangle 4 m on a side from where the vehicle is, 0.5 m deeper at the end.
    pts = [(p0.x + 4, p0.y, p0.z), (p0.x + 4, p0.y + 4, p0.z), (p0.x, p0.y + 4, p0.z + 0.5)]
    # The speed along the path is a parameter, sent with the mission.
    m.mav.param_set_send(m.target_system, m.target_component, b"MIS_SPEED", SPEED,
                         mav.MAV_PARAM_TYPE_REAL32)
    p = wait(m, "PARAM_VALUE", 10, lambda p: p.param_id == "MIS_SPEED")
    expect(p is not None and abs(p.param_value - SPEED) < 1e-6, f"MIS_SPEED set to {SPEED} m/s")
    r = upload(m, pts)
    expect(r == mav.MAV_MISSION_ACCEPTED, f"a 3-waypoint mission is accepted ({r}, {TEXTS})")
    got = download(m)
    same = all(abs(a - b) < 1e-3 for p, q in zip(pts, got) for a, b in zip(p, q))
    expect(len(got) == 3 and same, f"the mission downloads as uploaded ({got})")

    # Refused missions leave the mission in use as it was.
    r = upload(m, [(1, 1, 1)] * 40)
    expect(r == mav.MAV_MISSION_NO_SPACE, f"40 items refused: no space ({r})")
    r = upload(m, [(1, 1, 1), (2, 2, float("nan"))])
    expect(r == mav.MAV_MISSION_INVALID_PARAM7, f"a NaN depth refused ({r})")
    r = upload(m, [(1, 1, 1), (2, 2, 500.0)])
    expect(r == mav.MAV_MISSION_INVALID_PARAM7, f"an unreachable depth refused ({r})")
    r = upload(m, [(1, 1, 1), (2, 2, 1)], frame=mav.MAV_FRAME_GLOBAL_INT)
    expect(r == mav.MAV_MISSION_UNSUPPORTED_FRAME, f"a global frame refused ({r})")
    refusals = [t for t in TEXTS if "Mission refused" in t]
    expect(len(refusals) == 4, f"a STATUSTEXT says why, each time ({refusals})")
    expect(len(download(m)) == 3, "the mission in use is still the 3-waypoint one")

    # AUTO: arm, fly it, every waypoint reported reached, the vehicle ends on the last one.
    arm_and_auto(m)
    expect(wait(m, "MISSION_CURRENT", 10) is not None, "MISSION_CURRENT in AUTO")
    reached = []
    end = time.time() + 90
    # Ground speeds on the second leg (between waypoints 0 and 1): the cruise, after the
    # start's transient.
    leg = []
    while len(reached) < 3 and time.time() < end:
        r = m.recv_match(type=["MISSION_ITEM_REACHED", "VFR_HUD"], blocking=True, timeout=1)
        if r is not None and r.get_type() == "VFR_HUD":
            if len(reached) == 1:
                leg.append(r.groundspeed)
        elif r is not None:
            reached.append(r.seq)
    expect(reached == [0, 1, 2], f"MISSION_ITEM_REACHED for each waypoint, in order ({reached})")
    leg.sort()
    median = leg[len(leg) // 2] if leg else 0.0
    expect(abs(median - SPEED) < 0.03,
           f"flown at MIS_SPEED: median {median:.3f} m/s over the ground on the second leg "
           f"({len(leg)} samples) for {SPEED} m/s")
    n, e, d = pts[-1]
    # The reference stops on the last waypoint; the vehicle settles. Read everything that
    # comes meanwhile (a client that sleeps lets its socket overflow and loses messages).
    p = None
    for _ in range(8):
        end = time.time() + 1.0
        while time.time() < end:
            msg = m.recv_match(blocking=True, timeout=0.1)
            if msg is not None and msg.get_type() == "LOCAL_POSITION_NED":
                p = msg
        expect(p is not None, "LOCAL_POSITION_NED streams")
        print(f"  after the last waypoint: off by ({p.x - n:+.3f}, {p.y - e:+.3f}, "
              f"{p.z - d:+.3f}) m")
    off = math.sqrt((p.x - n) ** 2 + (p.y - e) ** 2 + (p.z - d) ** 2)
    # Measured 0.30 m, closing slowly: an underactuated vehicle holding a point it reached
    # with a sideways error must turn and drive to remove it (the end-of-path hold).
    expect(off < 0.5, f"the vehicle holds within 0.5 m of the last waypoint ({off:.3f} m)")

    # Clearing is refused while AUTO flies it, accepted after.
    m.mav.mission_clear_all_send(m.target_system, m.target_component)
    a = wait(m, "MISSION_ACK", 10)
    expect(a is not None and a.type == mav.MAV_MISSION_DENIED,
           f"no clearing while in AUTO ({a.type if a else None})")
    m.mav.set_mode_send(m.target_system, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MANUAL)
    expect(wait(m, "HEARTBEAT", 5, lambda h: h.custom_mode == MANUAL) is not None, "MANUAL")
    m.mav.mission_clear_all_send(m.target_system, m.target_component)
    a = wait(m, "MISSION_ACK", 10)
    expect(a is not None and a.type == mav.MAV_MISSION_ACCEPTED, "cleared")
    expect(len(download(m)) == 0, "no mission after clearing")
    m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_DO_SET_MODE, 0,
                            mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, AUTO, 0, 0, 0, 0, 0)
    a = wait(m, "COMMAND_ACK", 10, lambda a: a.command == mav.MAV_CMD_DO_SET_MODE)
    expect(a is not None and a.result == mav.MAV_RESULT_DENIED, "AUTO without a mission refused")


if __name__ == "__main__":
    main()
