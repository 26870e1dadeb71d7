"""connect() against pymavlink 2.4.50 over UDP and TCP: a pymavlink vehicle on the other side,
and a pymavlink ground station given the same datagrams, whose recv_match we must match."""

import socket
import threading
import time

import pytest
from conftest import apm2, mavutil, same

from ferrolink import mavlink


def encoder(sysid=1, compid=1):
    return apm2.MAVLink(None, srcSystem=sysid, srcComponent=compid)


class Twin:
    """Sends the same datagrams to our connection and to a pymavlink ground station."""

    def __init__(self):
        self.ours = mavlink.connect("udpin:127.0.0.1:0")
        self.theirs = mavutil.mavlink_connection("udpin:127.0.0.1:0")
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.to = [self.ours.local_addr(), self.theirs.port.getsockname()]
        self.mav = encoder()

    def send(self, msg):
        data = bytes(msg.pack(self.mav))
        for addr in self.to:
            self.sock.sendto(data, addr)

    def both(self, **kwargs):
        return self.ours.recv_match(**kwargs), self.theirs.recv_match(**kwargs)

    def close(self):
        self.ours.close()
        self.theirs.close()
        self.sock.close()


@pytest.fixture
def twin():
    t = Twin()
    yield t
    t.close()


def check(a, b):
    assert (a is None) == (b is None), (a, b)
    if a is not None:
        assert same(a.to_dict(), b.to_dict())
        assert (a.get_srcSystem(), a.get_srcComponent(), a.get_seq()) == (
            b.get_srcSystem(), b.get_srcComponent(), b.get_seq())


def test_recv_match_returns_what_pymavlink_returns(twin):
    heartbeat = apm2.MAVLink_heartbeat_message(2, 3, 81, 4, 4, 3)
    twin.send(heartbeat)
    a, b = twin.both(blocking=True, timeout=5)
    check(a, b)
    assert (twin.ours.target_system, twin.ours.target_component) == (1, 1)
    for i in range(5):
        twin.send(apm2.MAVLink_attitude_message(i, 0.1 * i, 0.2, 0.3, 0.0, 0.0, float("nan")))
        twin.send(apm2.MAVLink_vfr_hud_message(1.0, 2.0, 90, 50, 10.0 + i, 0.5))
        twin.send(apm2.MAVLink_statustext_message(6, b"hello %d" % i))
    time.sleep(0.3)
    # A type, a list of types, a condition, and nothing left: pymavlink's answers, each.
    check(*twin.both(type="VFR_HUD", blocking=True, timeout=5))
    check(*twin.both(type=["STATUSTEXT", "ATTITUDE"], blocking=True, timeout=5))
    check(*twin.both(type="ATTITUDE", condition="ATTITUDE.time_boot_ms >= 3",
                     blocking=True, timeout=5))
    check(*twin.both(type="STATUSTEXT"))
    check(*twin.both(type="ATTITUDE", blocking=False))
    check(*twin.both(type="HEARTBEAT", blocking=True, timeout=0.3))
    assert twin.ours.recv_match(type="HEARTBEAT") is None
    assert twin.ours.messages["VFR_HUD"].alt == twin.theirs.messages["VFR_HUD"].alt


def test_a_pymavlink_vehicle_receives_what_we_send(tmp_path):
    with mavlink.connect("udpin:127.0.0.1:0", source_system=42, source_component=7) as ours:
        host, port = ours.local_addr()
        vehicle = mavutil.mavlink_connection(f"udpout:{host}:{port}", source_system=1,
                                             source_component=1)
        vehicle.mav.heartbeat_send(2, 3, 81, 0, 4)
        hb = ours.wait_heartbeat(timeout=5)
        assert hb is not None and ours.target_system == 1
        ours.send("COMMAND_LONG", target_system=1, target_component=1, command=400,
                  param1=1.0)
        ours.mav.param_set_send(1, 1, b"RATE", 5.5, 9)
        got = []
        deadline = time.monotonic() + 5
        while len(got) < 2 and time.monotonic() < deadline:
            m = vehicle.recv_match(blocking=True, timeout=0.5)
            if m is not None:
                got.append(m)
        assert [m.get_type() for m in got] == ["COMMAND_LONG", "PARAM_SET"]
        assert (got[0].get_srcSystem(), got[0].get_srcComponent()) == (42, 7)
        assert (got[0].command, got[0].param1) == (400, 1.0)
        assert (got[1].param_id, got[1].param_value) == ("RATE", 5.5)
        # A message object goes back out as it is: ours, or pymavlink's.
        ours.send_message(hb)
        ours.send_message(apm2.MAVLink_system_time_message(123, 456))
        kinds = []
        while len(kinds) < 2 and time.monotonic() < deadline:
            m = vehicle.recv_match(blocking=True, timeout=0.5)
            if m is not None:
                kinds.append((m.get_type(), m.to_dict()))
        assert kinds[0] == ("HEARTBEAT", hb.to_dict())
        assert kinds[1][1]["time_unix_usec"] == 123
        vehicle.close()


def test_tcp_with_pymavlink_spelling():
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    port = server.getsockname()[1]
    server.close()
    vehicle = mavutil.mavlink_connection(f"tcpin:127.0.0.1:{port}", source_system=3)
    with mavlink.connect(f"tcp:127.0.0.1:{port}") as ours:
        deadline = time.monotonic() + 10
        hb = None
        while hb is None and time.monotonic() < deadline:
            vehicle.recv_msg()  # pymavlink's tcpin accepts its client here
            vehicle.mav.heartbeat_send(1, 3, 0, 0, 0)
            hb = ours.wait_heartbeat(timeout=0.5)
        assert hb is not None and hb.get_srcSystem() == 3
    vehicle.close()


def test_waiting_releases_the_gil(twin):
    """A Python thread sends while the main thread waits in recv_match: with the GIL held it
    could not run, and the wait would time out."""
    def later():
        time.sleep(0.3)
        twin.send(apm2.MAVLink_system_time_message(1, 2))

    t = threading.Thread(target=later)
    t.start()
    m = twin.ours.recv_match(type="SYSTEM_TIME", blocking=True, timeout=10)
    t.join()
    assert m is not None and m.time_boot_ms == 2


def test_bad_uris_and_fields_are_python_exceptions(twin):
    with pytest.raises(ValueError, match="unknown scheme"):
        mavlink.connect("bogus://x")
    with pytest.raises(ValueError, match="dialect"):
        mavlink.connect("udpin:127.0.0.1:0", dialect="nope")
    with pytest.raises(ValueError, match="NOPE"):
        twin.ours.send("NOPE")
    with pytest.raises(ValueError, match="roll"):
        twin.ours.send("ATTITUDE", roll="fast")
    twin.ours.close()
    with pytest.raises(ValueError, match="closed"):
        twin.ours.send("HEARTBEAT")
