"""A mission upload is a transaction of one station (issue 22, item 4).

Usage: pymavlink_two_uploads.py PORT_A PORT_B

A starts uploading 3 waypoints; B interleaves its own MISSION_COUNT and an item: each is refused
with MISSION_ACK DENIED while A's upload goes on; A's upload is accepted, and the mission
downloaded (by B) is A's, item for item. An upload that stops sending items is abandoned
(OPERATION_CANCELLED). In AUTO a new mission is refused (DENIED) and the one flown stays.
"""
import sys

from pymavlink import mavutil

from gcs import arm_and_auto, expect, wait

mav = mavutil.mavlink
A_POINTS = [(1.0, 0.0, 1.0), (2.0, 1.0, 1.5), (3.0, 0.0, 1.0)]
B_POINTS = [(-5.0, -5.0, 3.0), (-6.0, -5.0, 3.0)]


def connect(port):
    m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    expect(m.wait_heartbeat(timeout=60) is not None, f"station on {port}: a HEARTBEAT arrives")
    return m


def item(m, seq, p):
    x, y, z = p
    m.mav.mission_item_int_send(m.target_system, m.target_component, seq,
                                mav.MAV_FRAME_LOCAL_NED, mav.MAV_CMD_NAV_WAYPOINT, 0, 1,
                                0, 0, 0, 0, int(x * 1e4), int(y * 1e4), z)


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


def main():
    a, b = connect(int(sys.argv[1])), connect(int(sys.argv[2]))
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
    expect(got == A_POINTS, f"the mission is A's, item for item: {got}")

    # An upload that stops is abandoned after 5 s without an item.
    a.mav.mission_count_send(a.target_system, a.target_component, 2)
    expect(request(a, 0) is not None, "a second upload by A starts")
    r = wait(a, "MISSION_ACK", 12)
    expect(r is not None and r.type == mav.MAV_MISSION_OPERATION_CANCELLED,
           f"and, with no item sent, is abandoned ({r.type if r else None})")
    expect(download(a) == A_POINTS, "the mission in use stays")

    # In AUTO a new mission is refused; the one flown stays.
    arm_and_auto(a)
    a.mav.mission_count_send(a.target_system, a.target_component, len(B_POINTS))
    r = mission_ack(a)
    expect(r is not None and r.type == mav.MAV_MISSION_DENIED,
           f"a new mission during AUTO is DENIED ({r.type if r else None})")
    t = wait(a, "STATUSTEXT", 3, lambda s: "AUTO" in s.text)
    expect(t is not None, f"with the reason: {t.text if t else None!r}")
    expect(download(a) == A_POINTS, "the mission flown is still A's")
    a.mav.command_long_send(a.target_system, a.target_component,
                            mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    d = wait(a, "COMMAND_ACK", 5, lambda x: x.command == mav.MAV_CMD_COMPONENT_ARM_DISARM)
    expect(d is not None and d.result == mav.MAV_RESULT_ACCEPTED, "disarmed")


if __name__ == "__main__":
    main()
