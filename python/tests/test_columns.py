"""load_log, save_parquet and the CLI's export against pymavlink 2.4.50, through pandas,
pyarrow and DuckDB."""

import json
import math
import os
import shutil
import subprocess
from collections import Counter, defaultdict

import pytest
from conftest import ROOT, pymavlink_messages, same

from ferrolink import mavlink

pa = pytest.importorskip("pyarrow")
pd = pytest.importorskip("pandas")
duckdb = pytest.importorskip("duckdb")


def by_type(messages):
    out = defaultdict(list)
    for m in messages:
        if m.get_type() != "BAD_DATA" and not m.get_type().startswith("UNKNOWN_"):
            out[m.get_type()].append(m)
    return out


def cell(value):
    """A table cell as pymavlink's to_dict() value: lists for arrays, floats widened exactly."""
    if hasattr(value, "tolist"):
        value = value.tolist()
    if isinstance(value, list):
        return [cell(v) for v in value]
    return value


def check_rows(table, messages):
    """Every row of an Arrow table equals pymavlink's message, field for field."""
    rows = table.to_pylist()
    assert len(rows) == len(messages)
    for row, m in zip(rows, messages):
        # A field called timestamp keeps its name; ours is then _timestamp.
        assert row["_timestamp" if "timestamp" in m.get_fieldnames() else "timestamp"] == m._timestamp
        assert (row["sysid"], row["compid"]) == (m.get_srcSystem(), m.get_srcComponent())
        for key, want in m.to_dict().items():
            if key == "mavpackettype":
                continue
            got = cell(row[key])
            if isinstance(want, float):
                assert (math.isnan(want) and math.isnan(got)) or got == want, (key, got, want)
            else:
                assert same(got, want), (m.get_type(), key, got, want)


def test_load_log_as_arrow_equals_pymavlink(generated_tlog):
    tables = mavlink.load_log(generated_tlog, to="arrow")
    theirs = by_type(pymavlink_messages(generated_tlog))
    assert set(tables) == set(theirs)
    for name, table in tables.items():
        check_rows(table, theirs[name])
    gps = tables["GPS_RAW_INT"].schema
    assert str(gps.field("lat").type) == "int32" and str(gps.field("eph").type) == "uint16"
    servo = tables["SERVO_OUTPUT_RAW"].schema.field("servo1_raw").type
    assert str(servo) == "uint16"
    rc = tables["GPS_INJECT_DATA"].schema.field("data").type
    assert pa.types.is_fixed_size_list(rc) and rc.list_size == 110


def test_load_log_into_pandas_numpy_and_by_type(generated_tlog):
    frames = mavlink.load_log(generated_tlog, types=["ATTITUDE", "PARAM_VALUE"])
    assert set(frames) == {"ATTITUDE", "PARAM_VALUE"}
    attitude = frames["ATTITUDE"]
    theirs = by_type(pymavlink_messages(generated_tlog))
    assert list(attitude.columns[:3]) == ["timestamp", "sysid", "compid"]
    for got, m in zip(attitude["roll"], theirs["ATTITUDE"]):
        assert (math.isnan(got) and math.isnan(m.roll)) or float(got) == m.roll
    assert list(frames["PARAM_VALUE"]["param_id"]) == [m.param_id for m in theirs["PARAM_VALUE"]]
    arrays = mavlink.load_log(generated_tlog, types="ATTITUDE", to="numpy")["ATTITUDE"]
    assert arrays["time_boot_ms"].dtype.name == "uint32"
    assert list(arrays["time_boot_ms"]) == [m.time_boot_ms for m in theirs["ATTITUDE"]]


def test_load_log_into_polars(generated_tlog):
    pl = pytest.importorskip("polars")
    frames = mavlink.load_log(generated_tlog, types=["GPS_RAW_INT"], to="polars")
    gps = frames["GPS_RAW_INT"]
    assert isinstance(gps, pl.DataFrame)
    theirs = by_type(pymavlink_messages(generated_tlog))["GPS_RAW_INT"]
    assert gps["lat"].to_list() == [m.lat for m in theirs]


def test_load_log_errors(tmp_path, generated_tlog):
    with pytest.raises(FileNotFoundError):
        mavlink.load_log(tmp_path / "nope.tlog")
    with pytest.raises(ValueError, match="to='excel'"):
        mavlink.load_log(generated_tlog, to="excel")
    with pytest.raises(ValueError, match="unknown message type"):
        mavlink.load_log(generated_tlog, types=["NOPE"])
    # A missing log, even after one that is there: nothing is written.
    with pytest.raises(FileNotFoundError, match="nope.tlog"):
        mavlink.save_parquet([generated_tlog, tmp_path / "nope.tlog"], tmp_path / "out")
    assert not (tmp_path / "out").exists()


def logs_for_fleet(captures, generated_tlog):
    return ([generated_tlog] + list(captures))[:6]


def check_duckdb(out_dir, logs):
    """Counts and values per log and type, queried with DuckDB, equal pymavlink's."""
    db = duckdb.connect()
    counts = Counter()
    for log in logs:
        for m in pymavlink_messages(log):
            if m.get_type() != "BAD_DATA" and not m.get_type().startswith("UNKNOWN_"):
                counts[(str(log), m.get_type())] += 1
    got = Counter()
    for name in {t for _, t in counts}:
        path = os.path.join(out_dir, f"{name}.parquet")
        for log, n in db.execute(f"select log, count(*) from '{path}' group by log").fetchall():
            got[(log, name)] = n
    # We may recover more than pymavlink from damaged logs, never less.
    for key, n in counts.items():
        assert got[key] >= n, key
    assert sum(got.values()) >= sum(counts.values())
    # Values: ATTITUDE of the generated log, row for row.
    theirs = by_type(pymavlink_messages(logs[0]))["ATTITUDE"]
    rows = db.execute(
        f"select timestamp, roll, yaw from '{out_dir}/ATTITUDE.parquet' where log = ? order by timestamp",
        [str(logs[0])]).fetchall()
    assert len(rows) == len(theirs)
    for (t, roll, yaw), m in zip(rows, theirs):
        assert t == m._timestamp
        for a, b in ((roll, m.roll), (yaw, m.yaw)):
            assert (a is None or math.isnan(a)) and math.isnan(b) or a == b


def test_save_parquet_of_many_logs_queried_with_duckdb(tmp_path, captures, generated_tlog):
    logs = logs_for_fleet(captures, generated_tlog)
    written = mavlink.save_parquet(logs, tmp_path / "fleet")
    assert written["ATTITUDE"] == str(tmp_path / "fleet" / "ATTITUDE.parquet")
    check_duckdb(str(tmp_path / "fleet"), logs)
    # pandas and pyarrow read them as they are.
    table = pd.read_parquet(written["HEARTBEAT"])
    assert set(table["log"].astype(str)) <= {str(p) for p in logs}


def cli():
    for candidate in (os.environ.get("FERROLINK_BIN"), ROOT / "target" / "release" / "ferrolink",
                      ROOT / "target" / "debug" / "ferrolink", shutil.which("ferrolink")):
        if candidate and os.path.exists(candidate):
            return str(candidate)
    return None


def test_the_cli_export_writes_the_same_tables(tmp_path, captures, generated_tlog):
    binary = cli()
    if binary is None:
        if os.environ.get("FERROLINK_REQUIRE_CLI"):
            pytest.fail("no ferrolink binary (FERROLINK_BIN)")
        pytest.skip("no ferrolink binary built (cargo build --release -p ferrolink-cli)")
    logs = logs_for_fleet(captures, generated_tlog)
    out = subprocess.run([binary, "mavlink", "export", *map(str, logs), "--parquet",
                          str(tmp_path / "cli")], check=True, capture_output=True, text=True)
    summary = [json.loads(line) for line in out.stdout.splitlines()]
    assert [s["log"] for s in summary if "log" in s] == [str(p) for p in logs]
    check_duckdb(str(tmp_path / "cli"), logs)
    # The same files as save_parquet's, row for row.
    mavlink.save_parquet(logs, tmp_path / "py")
    import pyarrow.parquet as pq

    assert sorted(os.listdir(tmp_path / "py")) == sorted(os.listdir(tmp_path / "cli"))
    for f in sorted(os.listdir(tmp_path / "py")):
        a = pq.read_table(tmp_path / "py" / f)
        b = pq.read_table(tmp_path / "cli" / f)
        assert a.schema.equals(b.schema), f
        assert same(a.to_pydict(), b.to_pydict()), f
    typed = subprocess.run([binary, "mavlink", "export", str(generated_tlog), "--parquet",
                            str(tmp_path / "typed"), "--types", "ATTITUDE,HEARTBEAT"],
                           check=True, capture_output=True, text=True)
    assert sorted(os.listdir(tmp_path / "typed")) == ["ATTITUDE.parquet", "HEARTBEAT.parquet"]
    assert typed.returncode == 0
    bad = subprocess.run([binary, "mavlink", "export", str(generated_tlog), "--parquet",
                          str(tmp_path / "bad"), "--types", "NOPE"], capture_output=True, text=True)
    assert bad.returncode != 0 and "unknown message type" in bad.stderr
