"""The vehicle API against our software vehicle (`ferrolink mavlink vehicle`), blocking and
asyncio: telemetry, actions that fly it, parameters, missions and files."""

import asyncio
import os
import subprocess
import time

import pytest
from test_columns import cli

from ferrolink import vehicle


def free_udp_port():
    import socket

    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


@pytest.fixture
def software_vehicle(tmp_path):
    binary = cli()
    if binary is None:
        if os.environ.get("FERROLINK_REQUIRE_CLI"):
            pytest.fail("no ferrolink binary (FERROLINK_BIN)")
        pytest.skip("no ferrolink binary built (cargo build --release -p ferrolink-cli)")
    params = tmp_path / "vehicle.params"
    params.write_text("1\t1\tRATE_RLL_P\t0.135\t9\n1\t1\tSYSID_THISMAV\t1\t6\n")
    files = tmp_path / "files"
    (files / "logs").mkdir(parents=True)
    (files / "logs" / "a.bin").write_bytes(bytes(range(256)) * 20)
    port = free_udp_port()
    proc = subprocess.Popen(
        [binary, "mavlink", "vehicle", "--autopilot", "ardupilotmega", "--params", str(params),
         "--ftp-root", str(files), "--run-for", "120", f"udpout://127.0.0.1:{port}"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert "ready" in proc.stdout.readline()
    yield f"udpin:127.0.0.1:{port}"
    proc.terminate()
    proc.wait(10)


def until(what, cond, seconds=30):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        value = cond()
        if value:
            return value
        time.sleep(0.05)
    pytest.fail(f"{what}: not within {seconds} s")


def test_blocking_telemetry_actions_params_missions_files(software_vehicle):
    node = vehicle.connect(software_vehicle)
    drone = node.wait_for_system(timeout=10)
    assert drone is not None and drone.id == 1 and drone.autopilot == "MAV_AUTOPILOT_ARDUPILOTMEGA"
    assert [s.id for s in node.systems()] == [1]
    assert "GUIDED" in drone.mode_names()
    home = drone.wait_position(10)
    assert home is not None and abs(home["lat"] - 47.397742) < 1e-3
    until("a state", drone.state)
    assert drone.state()["armed"] is False
    # Fly: arm, take off to 5 m, land.
    assert drone.arm()["accepted"]
    until("armed", lambda: drone.state()["armed"])
    assert drone.takeoff(5)["accepted"]
    until("5 m up", lambda: drone.position()["alt_rel"] > 4.5)
    assert drone.attitude() is not None and drone.velocity() is not None
    assert drone.land()["accepted"]
    until("down", lambda: drone.position()["alt_rel"] < 0.5)
    with pytest.raises(ValueError, match="GUIDED"):
        drone.set_mode("WARP_SPEED")
    # Parameters.
    params = drone.params()
    assert params == {"RATE_RLL_P": pytest.approx(0.135), "SYSID_THISMAV": 1}
    assert isinstance(params["SYSID_THISMAV"], int)
    assert drone.set_param("RATE_RLL_P", 0.2) == pytest.approx(0.2)
    assert drone.param("RATE_RLL_P") == pytest.approx(0.2)
    with pytest.raises(KeyError):
        drone.param("NO_SUCH_PARAM")
    # Missions.
    items = [{"command": 16, "x": 473977418 + i, "y": 85455939, "z": 20.0 + i} for i in range(5)]
    assert drone.upload_mission(items) == "MAV_MISSION_ACCEPTED"
    down = drone.download_mission()
    assert [(i["seq"], i["command"], i["x"], i["z"]) for i in down] == [
        (i, 16, 473977418 + i, 20.0 + i) for i in range(5)]
    # Files.
    assert {e["name"]: e["size"] for e in drone.ftp_list("/logs")} == {"a.bin": 5120}
    assert drone.ftp_get("/logs/a.bin") == bytes(range(256)) * 20


def test_asyncio(software_vehicle):
    async def main():
        node = vehicle.connect(software_vehicle)
        drone = await node.wait_for_system_async(timeout=10)
        assert isinstance(drone, vehicle.AsyncSystem)
        assert await drone.wait_position(10) is not None
        # Telemetry goes on while a parameter fetch and an arm run at once.
        params, armed = await asyncio.gather(drone.params(), drone.arm())
        assert "RATE_RLL_P" in params and armed["accepted"]
        assert drone.state() is not None and drone.attitude() is not None
        assert (await drone.disarm())["accepted"]

    asyncio.run(main())


def test_no_vehicle_is_none_not_a_hang():
    node = vehicle.connect(f"udpin:127.0.0.1:{free_udp_port()}")
    start = time.monotonic()
    assert node.wait_for_system(timeout=0.5) is None
    assert time.monotonic() - start < 5
