"""What the pymavlink sessions share: a checked step, waiting for a message, arming into AUTO."""
import time


def expect(cond, what):
    """Print PASS for a check that holds; stop with FAIL otherwise."""
    if not cond:
        raise SystemExit(f"FAIL: {what}")
    print(f"PASS: {what}", flush=True)


def wait(m, kind, timeout=10.0, cond=lambda msg: True):
    """The next message of type `kind` for which `cond` holds, or None after `timeout` s."""
    end = time.time() + timeout
    while time.time() < end:
        msg = m.recv_match(type=kind, blocking=True, timeout=max(0.05, end - time.time()))
        if msg is not None and cond(msg):
            return msg
    return None


def arm_and_auto(m):
    """Arm, then AUTO (ArduSub's custom mode 3), each acknowledged as accepted."""
    from pymavlink import mavutil
    mav = mavutil.mavlink
    m.mav.command_long_send(m.target_system, m.target_component,
                            mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    a = wait(m, "COMMAND_ACK", 10, lambda a: a.command == mav.MAV_CMD_COMPONENT_ARM_DISARM)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "arming accepted")
    m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_DO_SET_MODE, 0,
                            mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 3, 0, 0, 0, 0, 0)
    a = wait(m, "COMMAND_ACK", 10, lambda a: a.command == mav.MAV_CMD_DO_SET_MODE)
    expect(a is not None and a.result == mav.MAV_RESULT_ACCEPTED, "AUTO accepted")
