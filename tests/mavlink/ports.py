"""Loopback ports for the test scripts, free for UDP and TCP, from below the ephemeral range.

A port found by binding port 0 and closing the socket can be handed, a moment later, to any
other socket on the machine as its source port: MAVSDK's, pymavlink's, another test's. A busy
test run opens thousands. Below the kernel's ephemeral range nothing is handed out unasked, so
only our own tests compete there. Each process starts at its own place (by process id) and
walks forward, and a port is handed out only once a UDP and a TCP socket could both bind it.
The Rust tests do the same (tests/support/src/lib.rs), with the same layout.
"""

import os
import socket
import threading

HOST = "127.0.0.1"
LOW = 12000
STRIDE = 40


def _ephemeral_low():
    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range") as f:
            low = int(f.read().split()[0])
        return low if low > LOW + 1000 else 32768
    except (OSError, ValueError, IndexError):
        return 32768


_SPAN = _ephemeral_low() - LOW
_handed = 0
_lock = threading.Lock()


def _bindable(port):
    for kind in (socket.SOCK_DGRAM, socket.SOCK_STREAM):
        with socket.socket(socket.AF_INET, kind) as s:
            try:
                s.bind((HOST, port))
            except OSError:
                return False
    return True


def free_ports(n):
    """n consecutive free loopback ports, as a list."""
    global _handed
    start = (os.getpid() * STRIDE) % _SPAN
    for _ in range(_SPAN):
        with _lock:
            offset = (start + _handed) % _SPAN
            _handed += n
        if offset + n > _SPAN:
            continue
        first = LOW + offset
        if all(_bindable(p) for p in range(first, first + n)):
            return list(range(first, first + n))
    raise RuntimeError("no %d free loopback ports below the ephemeral range" % n)


def free_port():
    """One free loopback port, for UDP and TCP both."""
    return free_ports(1)[0]
