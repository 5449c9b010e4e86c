"""MAVProxy (PyPI, unmodified, its default settings) flies missions in the local and the
global frame and its go-to commands, against `rov-topside --tcp` in front of `host-sim
vehicle`.

Usage: mavproxy_gcs.py PORT WATCH WORKDIR LAT LON WP... MAVProxy on udpin:127.0.0.1:PORT;
a silent pymavlink observer on udpin:127.0.0.1:WATCH (a second station of the surface)
follows the vehicle's position and status texts. Each WP is `L,NORTH,EAST,DEPTH` (a local
waypoint) or `G,LAT,LON,DEPTH` (a global one, relative altitude -DEPTH); the origin is LAT,
LON, set through MAVProxy's `message` module. Prints PASS lines and every status text as
`TEXT: ...`; exits 0 or raises.
"""
import math
import os
import subprocess
import sys
import threading
import time

from pymavlink import mavutil

from gcs import expect


class Watch:
    """The observer: the latest position and heading, every status text."""

    def __init__(self, port):
        self.m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=254)
        self.pos, self.yaw, self.texts = None, None, []
        threading.Thread(target=self.run, daemon=True).start()

    def run(self):
        while True:
            msg = self.m.recv_match(blocking=True, timeout=1)
            if msg is None:
                continue
            t = msg.get_type()
            if t == "LOCAL_POSITION_NED":
                self.pos = (msg.x, msg.y, msg.z)
            elif t == "ATTITUDE":
                self.yaw = msg.yaw
            elif t == "STATUSTEXT":
                self.texts.append(msg.text)
                print(f"TEXT: {msg.text}", flush=True)

    def reaches(self, target, what, timeout=150.0, within=0.3):
        end = time.time() + timeout
        since = None
        while time.time() < end:
            if self.pos is not None and math.dist(self.pos, target) <= within:
                since = since or time.time()
                if time.time() - since >= 2.0:
                    p = self.pos
                    expect(True, f"{what}: at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}), "
                                 f"{math.dist(p, target):.3f} m from {target}")
                    return p
            else:
                since = None
            time.sleep(0.05)
        expect(False, f"{what}: not within {within} m of {target} (at {self.pos})")


def local_of(origin, lat, lon):
    """North and east (m) of LAT, LON from the origin (WGS-84 radii, as the surface)."""
    a, e2 = 6378137.0, 6.69437999014e-3
    la = math.radians(origin[0])
    s = 1 - e2 * math.sin(la) ** 2
    rn, re_ = a * (1 - e2) / s ** 1.5, a / math.sqrt(s)
    return (math.radians(lat - origin[0]) * rn, math.radians(lon - origin[1]) * re_ * math.cos(la))


def write_wpl(path, items):
    """QGC WPL 110: index, current, frame, command, param1-4, x, y, z, autocontinue."""
    with open(path, "w") as f:
        f.write("QGC WPL 110\n")
        for i, (frame, x, y, z) in enumerate(items):
            f.write(f"{i}\t0\t{frame}\t16\t0\t0.5\t0\t0\t{x:.8f}\t{y:.8f}\t{z:.4f}\t1\n")


def read_wpl(path):
    with open(path) as f:
        rows = [line.split("\t") for line in f.read().splitlines()[1:] if line.strip()]
    return [(int(r[2]), float(r[8]), float(r[9]), float(r[10])) for r in rows]


def main():
    port, watch_port, work = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
    origin = (float(sys.argv[4]), float(sys.argv[5]))
    local, glob = [], []
    for spec in sys.argv[6:]:
        kind, a, b, depth = spec.split(",")
        (local if kind == "L" else glob).append((float(a), float(b), float(depth)))
    watch = Watch(watch_port)
    proc = subprocess.Popen(
        ["mavproxy.py", f"--master=udpin:127.0.0.1:{port}", "--nowait",
         f"--state-basedir={work}"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        text=True, cwd=work)
    out = []

    def reader():
        for line in proc.stdout:
            out.append(line)
            sys.stdout.write("  mavproxy: " + line)

    threading.Thread(target=reader, daemon=True).start()

    def saw(text, timeout=30.0, since=0):
        end = time.time() + timeout
        while time.time() < end:
            if any(text in line for line in out[since:]) or any(
                    text in t for t in watch.texts[since_texts[0]:]):
                return True
            time.sleep(0.1)
        return False

    since_texts = [0]

    def type_in(cmd):
        since_texts[0] = len(watch.texts)
        n = len(out)
        proc.stdin.write(cmd + "\n")
        proc.stdin.flush()
        return n

    try:
        expect(saw("online system", 60), "MAVProxy sees the vehicle")
        type_in("module load message")
        time.sleep(1)
        n = type_in(f"message SET_GPS_GLOBAL_ORIGIN 1 {int(origin[0] * 1e7)} "
                    f"{int(origin[1] * 1e7)} 0")
        expect(saw("Origin set", 15, n), "the origin set through MAVProxy's `message`")
        n = type_in("param set MIS_SPEED 0.35")
        time.sleep(2)

        # The local-frame file with MAVProxy's defaults (MISSION_ITEM_INT, x 1e7).
        wp = os.path.join(work, "local.waypoints")
        write_wpl(wp, [(1, n_, e, d) for n_, e, d in local])
        n = type_in(f"wp load {wp}")
        expect(saw(f"Mission of {len(local)} waypoints accepted", 30, n),
               "`wp load` of a local-frame file accepted with MAVProxy's defaults")
        n = type_in("wp list")
        time.sleep(3)
        back = os.path.join(work, "local-back.waypoints")
        n = type_in(f"wp save {back}")
        time.sleep(2)
        got = read_wpl(back) if os.path.exists(back) else []
        sent = [(1, a, b, d) for a, b, d in local]
        same = len(got) == len(sent) and all(
            g[0] == s[0] and all(abs(x - y) < 1e-3 for x, y in zip(g[1:], s[1:]))
            for g, s in zip(got, sent))
        expect(same, f"`wp list` reads the mission back as loaded: {got}")

        n = type_in("mode ALT_HOLD")
        expect(saw("ALT_HOLD", 15, n), "`mode ALT_HOLD`")
        n = type_in("arm throttle")
        expect(saw("ARMED", 15, n), "`arm throttle`: ARMED")
        n = type_in("mode AUTO")
        expect(saw(f"Reached command #{len(local) - 1}", 200, n),
               "the local mission's last waypoint reported reached")
        watch.reaches(local[-1], "local mission's end held")

        n = type_in("mode POSHOLD")
        expect(saw("POSHOLD", 15, n), "`mode POSHOLD`")
        wp = os.path.join(work, "global.waypoints")
        write_wpl(wp, [(3, lat, lon, -d) for lat, lon, d in glob])
        n = type_in(f"wp load {wp}")
        expect(saw(f"Mission of {len(glob)} waypoints accepted", 30, n),
               "`wp load` of a global-frame file accepted")
        n = type_in("mode AUTO")
        expect(saw(f"Reached command #{len(glob) - 1}", 200, n),
               "the global mission's last waypoint reported reached")
        end = glob[-1]
        ne = local_of(origin, end[0], end[1])
        watch.reaches((ne[0], ne[1], end[2]), "global mission's end held")

        # `guided LAT LON ALT`: MAV_CMD_DO_REPOSITION (MAVProxy's default), then as a guided
        # mission item.
        here = watch.pos
        n = type_in("mode GUIDED")
        expect(saw("GUIDED", 15, n), "`mode GUIDED`")
        ne = (here[0] - 1.5, here[1] - 1.0)
        lat, lon = guided_point(origin, ne)
        n = type_in(f"guided {lat:.8f} {lon:.8f} -1.5")
        watch.reaches((ne[0], ne[1], 1.5), "`guided` (DO_REPOSITION)")
        type_in("set guided_use_reposition 0")
        ne2 = (ne[0] + 1.0, ne[1] - 1.0)
        lat, lon = guided_point(origin, ne2)
        n = type_in(f"guided {lat:.8f} {lon:.8f} -2")
        watch.reaches((ne2[0], ne2[1], 2.0), "`guided` (a guided mission item)")
        here, yaw = watch.pos, watch.yaw
        n = type_in("position 1.5 0 0")
        ahead = (here[0] + 1.5 * math.cos(yaw), here[1] + 1.5 * math.sin(yaw), here[2])
        watch.reaches(ahead, "`position 1.5 0 0` (BODY_NED)", within=0.35)
        n = type_in("disarm")
        expect(saw("DISARMED", 15, n), "`disarm`: DISARMED")
    finally:
        try:
            type_in("exit")
            proc.wait(timeout=10)
        except Exception:
            proc.kill()


def guided_point(origin, ne):
    """LAT, LON of north, east (m) from the origin (the inverse of `local_of`)."""
    a, e2 = 6378137.0, 6.69437999014e-3
    la = math.radians(origin[0])
    s = 1 - e2 * math.sin(la) ** 2
    rn, re_ = a * (1 - e2) / s ** 1.5, a / math.sqrt(s)
    return (origin[0] + math.degrees(ne[0] / rn),
            origin[1] + math.degrees(ne[1] / (re_ * math.cos(la))))


if __name__ == "__main__":
    main()
