"""MAVProxy (PyPI), a ground station we did not write, flies a served vehicle through `rov-topside --tcp`.

Usage: mavproxy_session.py PORT WORKDIR. Runs `mavproxy.py --master=udpin:127.0.0.1:PORT`
and types into its console what an operator would: ALT_HOLD, `wp load` of a QGC WPL 110 file
(three waypoints in the local NED frame), arm, AUTO, disarm. Checks MAVProxy's own console
output for each step. Exits 0 and prints PASS lines, or raises.
"""
import os
import subprocess
import sys
import threading
import time

from gcs import expect


def main():
    port, work = int(sys.argv[1]), sys.argv[2]
    wp = os.path.join(work, "mission.waypoints")
    # QGC WPL 110: index, current, frame (1 = MAV_FRAME_LOCAL_NED), command (16 = waypoint),
    # param1-4, x (north, m), y (east, m), z (depth, m), autocontinue.
    with open(wp, "w") as f:
        f.write("QGC WPL 110\n")
        for i, (n, e, d) in enumerate([(4, 0, 2), (4, 4, 2), (0, 4, 2.5)]):
            f.write(f"{i}\t{int(i == 0)}\t1\t16\t0\t0.5\t0\t0\t{n}\t{e}\t{d}\t1\n")
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
            if any(text in line for line in out[since:]):
                return True
            time.sleep(0.1)
        return False

    def type_in(cmd):
        n = len(out)
        proc.stdin.write(cmd + "\n")
        proc.stdin.flush()
        return n

    try:
        expect(saw("online system"), "MAVProxy sees the vehicle")
        n = type_in("mode ALT_HOLD")
        expect(saw("ALT_HOLD", 15, n), "`mode ALT_HOLD`: MAVProxy shows ALT_HOLD")
        # MAVProxy scales MISSION_ITEM_INT's x and y by 1e7 in every frame (ArduPilot reads
        # them so), where the MAVLink spec has metres x 1e4 for local frames; the float
        # MISSION_ITEM carries metres either way.
        type_in("set wp_use_mission_int 0")
        n = type_in(f"wp load {wp}")
        expect(saw("Mission of 3 waypoints accepted", 30, n),
               "`wp load`: the vehicle accepts MAVProxy's 3 waypoints")
        n = type_in("arm throttle")
        expect(saw("ARMED", 15, n), "`arm throttle`: ARMED")
        n = type_in("mode AUTO")
        expect(saw("AUTO", 15, n), "`mode AUTO`: MAVProxy shows AUTO")
        expect(saw("Reached command #2", 90, n), "the vehicle reports the last waypoint reached")
        n = type_in("disarm")
        expect(saw("DISARMED", 15, n), "`disarm`: DISARMED")
    finally:
        try:
            type_in("exit")
            proc.wait(timeout=10)
        except Exception:
            proc.kill()


if __name__ == "__main__":
    main()
