"""MAVSDK (the `mavsdk` package, its native binding) as a third ground station, through
`rov-topside --tcp` in front of `host-sim vehicle`.

Usage: mavsdk_gcs.py PORT LAT LON N,E,Z N,E,Z N,E,Z GN,GE,GZ. Connects (udpin PORT),
downloads the parameters, uploads a 3-waypoint local-frame mission (MISSION_ITEM_INT, x and y
in metres x 1e4, z the depth) and reads it back, arms, flies it in AUTO, sets the origin
(LAT, LON) and goes to the global point GN, GE (metres north and east of it) at depth GZ
(MAV_CMD_DO_REPOSITION: MAVSDK's goto_location cannot switch a submarine's mode), runs the motor test on thruster 1
(MAV_CMD_DO_MOTOR_TEST through MAVSDK's MavlinkDirect) and disarms. Prints PASS lines and
`MARK: name t` (wall clock) at each phase. Exits 0 or raises.
"""
import json
import math
import sys
import threading
import time

from mavsdk import ComponentType, Configuration, Mavsdk
from mavsdk.plugins.action import Action
from mavsdk.plugins.mavlink_direct import MavlinkDirect, MavlinkMessage
from mavsdk.plugins.mission_raw import MissionItem, MissionRaw
from mavsdk.plugins.param import Param

from gcs import expect

AUTO = 3


class Link:
    """What MavlinkDirect hears: the latest of each message, and every COMMAND_ACK."""

    def __init__(self, direct):
        self.direct = direct
        self.lock = threading.Lock()
        self.latest = {}
        self.acks = []
        direct.subscribe_message("", self.on_message)

    def on_message(self, msg, *_):
        fields = json.loads(msg.fields_json)
        with self.lock:
            if msg.system_id == 1:
                self.latest[msg.message_name] = fields
            if msg.message_name == "COMMAND_ACK":
                self.acks.append(fields)
            if msg.message_name == "STATUSTEXT":
                print(f"TEXT: {fields.get('text')}", flush=True)

    def get(self, name):
        with self.lock:
            return self.latest.get(name)

    def send(self, name, fields):
        self.direct.send_message(MavlinkMessage(
            message_name=name, system_id=255, component_id=190, target_system_id=1,
            target_component_id=1, fields_json=json.dumps(fields)))

    def command(self, command, *params, timeout=10.0):
        p = list(params) + [0.0] * (7 - len(params))
        with self.lock:
            self.acks.clear()
        fields = {"target_system": 1, "target_component": 1, "command": command,
                  "confirmation": 0}
        fields.update({f"param{i + 1}": float(v) for i, v in enumerate(p)})
        self.send("COMMAND_LONG", fields)
        end = time.time() + timeout
        while time.time() < end:
            with self.lock:
                for a in self.acks:
                    if a.get("command") == command:
                        return a.get("result")
            time.sleep(0.05)
        return None


def position(link):
    p = link.get("LOCAL_POSITION_NED")
    return (p["x"], p["y"], p["z"]) if p else None


def reaches(link, target, what, timeout, within=0.3):
    end = time.time() + timeout
    best = math.inf
    while time.time() < end:
        p = position(link)
        if p is not None:
            best = min(best, math.dist(p, target))
            if best <= within:
                break
        time.sleep(0.05)
    expect(best <= within, f"{what}: came within {best:.3f} m of {target}")


def main():
    port = int(sys.argv[1])
    lat0, lon0 = float(sys.argv[2]), float(sys.argv[3])
    wps = [tuple(float(v) for v in a.split(",")) for a in sys.argv[4:7]]
    gn, ge, gz = (float(v) for v in sys.argv[7].split(","))
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
    system = sdk.first_autopilot(30.0)
    expect(system is not None, "MAVSDK connected to the autopilot")
    link = Link(MavlinkDirect(system))
    param, mission, action = Param(system), MissionRaw(system), Action(system)

    params = param.get_all_params()
    names = [p.name for p in params.float_params] + [p.name for p in params.int_params]
    expect(len(names) > 80 and "TRK_XY_KP" in names and "JS_GAIN_DEFAULT" in names,
           f"parameters downloaded ({len(names)})")

    items = [MissionItem(seq=i, frame=1, command=16, current=int(i == 0), autocontinue=1,
                         x=int(round(n * 1e4)), y=int(round(e * 1e4)), z=z, mission_type=0)
             for i, (n, e, z) in enumerate(wps)]
    mission.upload_mission(items)
    expect(True, "3-waypoint mission uploaded")
    back = mission.download_mission()
    expect(len(back) == 3 and all(abs(b.x - a.x) <= 1 and abs(b.z - a.z) < 1e-3
                                  for a, b in zip(items, back)),
           f"the mission downloaded as uploaded ({[(b.x, b.y, b.z) for b in back]})")

    action.arm()
    expect(True, "armed")
    print(f"MARK: auto {time.time():.3f}", flush=True)
    result = link.command(176, 1, AUTO)  # MAV_CMD_DO_SET_MODE, ArduSub's AUTO
    expect(result == 0, f"AUTO accepted ({result})")
    for i, wp in enumerate(wps):
        reaches(link, wp, f"waypoint {i}", 240.0)

    link.send("SET_GPS_GLOBAL_ORIGIN", {"target_system": 1, "latitude": int(lat0 * 1e7),
                                        "longitude": int(lon0 * 1e7), "altitude": 0})
    time.sleep(1.0)
    result = link.command(176, 1, 4)  # GUIDED: go-to is taken there
    expect(result == 0, f"GUIDED accepted ({result})")
    lat = lat0 + math.degrees(gn / 6356752.3)
    lon = lon0 + math.degrees(ge / (6378137.0 * math.cos(math.radians(lat0))))
    # MAVSDK's Action.goto_location first switches the flight mode, which MAVSDK cannot map
    # for a submarine ("Cannot translate flight mode to ArduPilot mode, for MAV_TYPE: 12"):
    # the go-to it sends, MAV_CMD_DO_REPOSITION in a COMMAND_INT, goes through MavlinkDirect.
    with link.lock:
        link.acks.clear()
    link.send("COMMAND_INT", {
        "target_system": 1, "target_component": 1, "frame": 0, "command": 192,
        "current": 0, "autocontinue": 0, "param1": -1.0, "param2": 1.0, "param3": 0.0,
        "param4": 0.0, "x": int(round(lat * 1e7)), "y": int(round(lon * 1e7)),
        "z": -gz})
    end = time.time() + 10
    result = None
    while result is None and time.time() < end:
        with link.lock:
            result = next((a.get("result") for a in link.acks if a.get("command") == 192),
                          None)
        time.sleep(0.05)
    expect(result == 0, f"DO_REPOSITION accepted ({result})")
    reaches(link, (gn, ge, gz), "the go-to point", 240.0, within=0.5)

    print(f"MARK: motor {time.time():.3f}", flush=True)
    result = link.command(209, 1, 1, 1650, 0)  # motor 1 at 1650 us, ArduSub's 0.5 s
    expect(result == 0, f"motor test accepted ({result})")
    seen = []
    end = time.time() + 1.0
    while time.time() < end:
        s = link.get("SERVO_OUTPUT_RAW")
        if s:
            seen.append((s["servo1_raw"], s["servo2_raw"], s["servo3_raw"]))
        time.sleep(0.02)
    expect(any(s[0] == 1650 and s[1] == 1500 and s[2] == 1500 for s in seen),
           "SERVO_OUTPUT_RAW: output 1 at 1650 us, the others neutral")
    time.sleep(2.0)
    hb = link.get("HEARTBEAT")
    expect(hb is not None and not (hb["base_mode"] & 128),
           "the motor test's end disarmed the vehicle (ArduSub)")
    action.arm()
    action.disarm()
    hb = None
    time.sleep(1.5)
    hb = link.get("HEARTBEAT")
    expect(hb is not None and not (hb["base_mode"] & 128), "disarmed")


if __name__ == "__main__":
    main()
