"""What both pymavlink sessions share: a checked step, and waiting for a message."""
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
