"""A mission upload is a transaction of one station.

Usage: pymavlink_two_uploads.py PORT_A PORT_B

A starts uploading 3 waypoints; B interleaves its own MISSION_COUNT and an item: each is refused
with MISSION_ACK DENIED while A's upload goes on; A's upload is accepted, and the mission
downloaded (by B) is A's, item for item. An upload that stops sending items is abandoned
(OPERATION_CANCELLED). In AUTO a new mission is refused (DENIED) and the one flown stays.
"""
import sys
import time

from pymavlink import mavutil

from gcs import arm_and_auto, expect, wait

mav = mavutil.mavlink
B_POINTS = [(-5.0, -5.0, 3.0), (-6.0, -5.0, 3.0)]


def connect(port):
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=60) is not None, f"station on {port}: a HEARTBEAT arrives")
    return m


def item(m, seq, p):
    x, y, z = p
    m.mav.mission_item_int_send(m.target_system, m.target_component, seq,
                                mav.MAV_FRAME_LOCAL_NED, mav.MAV_CMD_NAV_WAYPOINT, 0, 1,
                                0, 0, 0, 0, round(x * 1e4), round(y * 1e4), z)


def request(m, seq, timeout=5):
    return wait(m, "MISSION_REQUEST_INT", timeout, lambda r: r.seq == seq)


def mission_ack(m, timeout=8):
    return wait(m, "MISSION_ACK", timeout)


def download(m):
    m.mav.mission_request_list_send(m.target_system, m.target_component)
    c = wait(m, "MISSION_COUNT", 5)
    got = []
    for seq in range(c.count if c else 0):
        m.mav.mission_request_int_send(m.target_system, m.target_component, seq)
        it = wait(m, "MISSION_ITEM_INT", 5, lambda i: i.seq == seq)
        got.append((it.x / 1e4, it.y / 1e4, it.z) if it else None)
    return got


def same(got, want):
    return len(got) == len(want) and all(
        g is not None and all(abs(u - v) < 1e-3 for u, v in zip(g, w)) for g, w in zip(got, want))


def main():
    a, b = connect(int(sys.argv[1])), connect(int(sys.argv[2]))
    # A's mission: a 4 m triangle from where the vehicle is (a path AUTO can fly).
    p0 = wait(a, "LOCAL_POSITION_NED", 10)
    x0, y0, z0 = round(p0.x, 1), round(p0.y, 1), max(0.5, round(p0.z, 1))
    A_POINTS = [(x0 + 4, y0, z0), (x0 + 4, y0 + 4, z0), (x0, y0 + 4, z0 + 0.5)]
    a.mav.mission_count_send(a.target_system, a.target_component, len(A_POINTS))
    expect(request(a, 0) is not None, "A's upload starts")
    item(a, 0, A_POINTS[0])
    expect(request(a, 1) is not None, "A's first item taken")

    b.mav.mission_count_send(b.target_system, b.target_component, len(B_POINTS))
    r = mission_ack(b)
    expect(r is not None and r.type == mav.MAV_MISSION_DENIED,
           f"B's interleaved MISSION_COUNT is DENIED ({r.type if r else None})")
    item(b, 1, B_POINTS[0])
    r = mission_ack(b)
    expect(r is not None and r.type == mav.MAV_MISSION_DENIED, "and so is B's item")

    for seq in range(1, len(A_POINTS)):
        if seq > 1:
            expect(request(a, seq) is not None, f"A's item {seq} requested")
        item(a, seq, A_POINTS[seq])
    r = mission_ack(a)
    expect(r is not None and r.type == mav.MAV_MISSION_ACCEPTED, "A's upload is accepted")
    got = download(b)
    expect(same(got, A_POINTS), f"the mission is A's, item for item: {got}")

    # An upload that stops is abandoned after 5 s without an item.
    a.mav.mission_count_send(a.target_system, a.target_component, 2)
    expect(request(a, 0) is not None, "a second upload by A starts")
    r = wait(a, "MISSION_ACK", 12)
    expect(r is not None and r.type == mav.MAV_MISSION_OPERATION_CANCELLED,
           f"and, with no item sent, is abandoned ({r.type if r else None})")
    expect(same(download(a), A_POINTS), "the mission in use stays")

    # In AUTO a new mission is refused; the one flown stays.
    arm_and_auto(a)
    a.mav.mission_count_send(a.target_system, a.target_component, len(B_POINTS))
    # The reason (STATUSTEXT lines) comes just before the MISSION_ACK.
    texts, r = [], None
    end = time.time() + 8
    while r is None and time.time() < end:
        msg = a.recv_match(type=["STATUSTEXT", "MISSION_ACK"], blocking=True, timeout=0.5)
        if msg is not None and msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
        elif msg is not None:
            r = msg
    expect(r is not None and r.type == mav.MAV_MISSION_DENIED,
           f"a new mission during AUTO is DENIED ({r.type if r else None})")
    why = " ".join(texts)
    expect("leave AUTO first" in why, f"with the reason: {why!r}")
    expect(same(download(a), A_POINTS), "the mission flown is still A's")
    a.mav.command_long_send(a.target_system, a.target_component,
                            mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    d = wait(a, "COMMAND_ACK", 5, lambda x: x.command == mav.MAV_CMD_COMPONENT_ARM_DISARM)
    expect(d is not None and d.result == mav.MAV_RESULT_ACCEPTED, "disarmed")


if __name__ == "__main__":
    main()
