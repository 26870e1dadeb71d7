"""open_log against pymavlink 2.4.50: the same messages, key for key and value for value."""

import struct

import pytest
from conftest import apm1, apm2, pymavlink_messages, same, write_tlog

import ferrolink
from ferrolink import mavlink


def test_version():
    assert ferrolink.__version__.count(".") == 2


def check_same(ours, theirs):
    assert len(ours) == len(theirs)
    for i, (a, b) in enumerate(zip(ours, theirs)):
        assert same(a.to_dict(), b.to_dict()), (i, a.to_dict(), b.to_dict())
        assert a._timestamp == b._timestamp, i
        assert a.get_type() == b.get_type()
        assert a.get_msgId() == b.get_msgId()
        assert (a.get_srcSystem(), a.get_srcComponent(), a.get_seq()) == (
            b.get_srcSystem(), b.get_srcComponent(), b.get_seq())
        ha, hb = a.get_header(), b.get_header()
        for key in ("msgId", "incompat_flags", "compat_flags", "mlen", "seq", "srcSystem",
                    "srcComponent"):
            assert getattr(ha, key) == getattr(hb, key), (i, key)
        assert bytes(a.get_msgbuf()) == bytes(b.get_msgbuf())


def test_every_ardupilotmega_message_decodes_as_pymavlink_decodes_it(generated_tlog):
    theirs = pymavlink_messages(generated_tlog)
    ours = list(mavlink.open_log(generated_tlog))
    assert len({m.get_type() for m in ours}) == len(apm2.mavlink_map)
    check_same(ours, theirs)


def test_with_common_the_other_messages_come_as_pymavlink_unknowns(generated_tlog):
    from conftest import mavutil

    conn = mavutil.mavlink_connection(str(generated_tlog), dialect="common")
    theirs = []
    while (m := conn.recv_match()) is not None:
        theirs.append(m)
    ours = list(mavlink.open_log(generated_tlog, dialect="common"))
    assert any(m.get_type().startswith("UNKNOWN_") for m in ours)
    check_same(ours, theirs)


def test_fields_are_attributes_as_pymavlink_has_them(generated_tlog):
    for a, b in zip(mavlink.open_log(generated_tlog), pymavlink_messages(generated_tlog)):
        for name in b.get_fieldnames():
            assert same(a.format_attr(name) if hasattr(a, "format_attr") else getattr(a, name),
                        b.format_attr(name)), name
        assert a.get_fieldnames() == b.get_fieldnames()
        assert str(a).split(" ")[0] == str(b).split(" ")[0]


def test_types_filter_before_decoding(generated_tlog):
    ours = list(mavlink.open_log(generated_tlog, types=["ATTITUDE", "heartbeat"]))
    theirs = [m for m in pymavlink_messages(generated_tlog)
              if m.get_type() in ("ATTITUDE", "HEARTBEAT")]
    assert {m.get_type() for m in ours} == {"ATTITUDE", "HEARTBEAT"}
    check_same(ours, theirs)
    assert [m.get_type() for m in mavlink.open_log(generated_tlog, types="ATTITUDE")] == [
        "ATTITUDE"] * 3


def test_unknown_ids_come_as_pymavlink_unknown_messages(tmp_path):
    mav = apm2.MAVLink(None, srcSystem=7, srcComponent=8)
    attitude = apm2.MAVLink_attitude_message(1, 2, 3, 4, 5, 6, 7).pack(mav)
    # An id ardupilotmega lacks, as a whole MAVLink 2 frame (its checksum cannot be checked).
    alien = bytes([0xFD, 3, 0, 0, 5, 7, 8, 0x10, 0x27, 0]) + b"abc" + b"\x12\x34"
    path = write_tlog(tmp_path / "alien.tlog", [attitude, alien, attitude])
    ours = list(mavlink.open_log(path))
    theirs = pymavlink_messages(path)
    assert [m.get_type() for m in ours] == ["ATTITUDE", "UNKNOWN_10000", "ATTITUDE"]
    check_same(ours, theirs)
    only = list(mavlink.open_log(path, types=["UNKNOWN_10000"]))
    assert [m.get_type() for m in only] == ["UNKNOWN_10000"]
    assert only[0].data == bytearray(alien)


def test_mavlink1_frames_shorter_than_12_bytes_lose_pymavlink_the_next_record(tmp_path):
    """pymavlink 2.4.50's tlog reader peeks 12 bytes past a frame's start: after a MAVLink 1
    frame shorter than that it reads into the next record and loses its message (it yields
    BAD_DATA instead). We read every whole record."""
    m1 = apm1.MAVLink(None, srcSystem=1, srcComponent=1)
    m2 = apm2.MAVLink(None, srcSystem=1, srcComponent=1)
    short = bytes(apm1.MAVLink_param_request_list_message(1, 1).pack(m1))
    heartbeat = bytes(apm2.MAVLink_heartbeat_message(1, 3, 0, 0, 0, 3).pack(m2))
    assert len(short) == 10
    path = write_tlog(tmp_path / "short.tlog", [short, heartbeat, short, heartbeat])
    ours = list(mavlink.open_log(path))
    theirs = pymavlink_messages(path)
    assert [m.get_type() for m in ours] == ["PARAM_REQUEST_LIST", "HEARTBEAT"] * 2
    # pymavlink: the first HEARTBEAT is lost, BAD_DATA in its place.
    kinds = [m.get_type() for m in theirs]
    assert kinds == ["PARAM_REQUEST_LIST", "BAD_DATA", "PARAM_REQUEST_LIST", "HEARTBEAT"]
    # What we read is in the file as it stands: each frame where its record puts it.
    data = path.read_bytes()
    at = 0
    for m in ours:
        frame = bytes(m.get_msgbuf())
        assert data[at + 8:at + 8 + len(frame)] == frame
        assert struct.unpack(">Q", data[at:at + 8])[0] * 1e-6 == m._timestamp
        at += 8 + len(frame)
    assert at == len(data)
    # Everything else pymavlink decoded, we decoded the same.
    check_same([ours[0]] + ours[2:], [theirs[0]] + theirs[2:])


def test_damaged_captures_recover_at_least_what_pymavlink_does(captures):
    """On every real capture: pymavlink's messages are a subsequence of ours, and every message
    only we found is a whole frame that pymavlink itself decodes from its bytes."""
    checked = 0
    for path in captures:
        theirs = [m for m in pymavlink_messages(path) if m.get_type() != "BAD_DATA"]
        ours = list(mavlink.open_log(path))
        it = iter(ours)
        extra = []
        for b in theirs:
            for a in it:
                if same(a.to_dict(), b.to_dict()) and a._timestamp == b._timestamp:
                    break
                extra.append(a)
            else:
                pytest.fail(f"{path.name}: pymavlink's {b} is not among ours")
        extra.extend(it)
        decoder = apm2.MAVLink(None)
        for a in extra:
            if a.get_type().startswith("UNKNOWN_"):
                continue
            again = decoder.decode(bytearray(a.get_msgbuf()))
            assert same(again.to_dict(), a.to_dict()), (path.name, a)
        checked += len(ours)
    assert checked > 10_000


def test_raw_captures(captures):
    raws = sorted(captures[0].parent.glob("*.raw"))
    assert raws, "the test data has raw captures"
    for path in raws:
        ours = list(mavlink.open_log(path, raw=True))
        theirs = [m for m in pymavlink_messages(path, raw=True)
                  if m.get_type() != "BAD_DATA" and not m.get_type().startswith("UNKNOWN_")]
        got = [m.to_dict() for m in ours]
        it = iter(got)
        assert all(any(same(b.to_dict(), a) for a in it) for b in theirs), path.name
        assert all(m._timestamp is None for m in ours)


def test_stats_say_what_was_skipped(tmp_path, generated_tlog):
    data = bytearray(generated_tlog.read_bytes())
    data[100:140] = b"\x55" * 40
    path = tmp_path / "damaged.tlog"
    path.write_bytes(bytes(data) + b"\x00" * 5)
    it = mavlink.open_log(path)
    n = sum(1 for _ in it)
    stats = it.stats()
    assert stats["frames"] == n
    assert stats["recovered_after_damage"] >= 1
    assert stats["skipped_bytes"] > 0 and stats["truncated_bytes"] == 5


def test_errors_are_python_exceptions(tmp_path, generated_tlog):
    with pytest.raises(FileNotFoundError, match="nope.tlog"):
        mavlink.open_log(tmp_path / "nope.tlog")
    with pytest.raises(ValueError, match="no built-in dialect has that name"):
        mavlink.open_log(generated_tlog, dialect="ardupilot")
    with pytest.raises(ValueError, match="unknown message type \"ATTITUDEE\""):
        mavlink.open_log(generated_tlog, types=["ATTITUDEE"])
    bad = tmp_path / "bad.xml"
    bad.write_text("<mavlink><messages><message id='1' name='X'><field type='uint9_t' name='a'/>"
                   "</message></messages></mavlink>")
    with pytest.raises(ValueError, match="bad.xml:1:"):
        mavlink.open_log(generated_tlog, dialect=str(bad))
    m = next(iter(mavlink.open_log(generated_tlog)))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        m.nope


def test_a_dialect_file_decodes_as_its_built_in_twin(generated_tlog):
    from conftest import ROOT

    xml = ROOT / "definitions" / "mavlink" / "standard" / "ardupilotmega.xml"
    a = [m.to_dict() for m in mavlink.open_log(generated_tlog, dialect=str(xml))]
    b = [m.to_dict() for m in mavlink.open_log(generated_tlog)]
    assert len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
