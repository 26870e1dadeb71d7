"""The vehicle API: a node with our heartbeat, the vehicles it hears, and per vehicle typed
telemetry, actions, flight modes by name, parameters, missions and files. It is the Rust
vehicle API (``ferrolink-vehicle``), the same code; blocking, with an asyncio face.

    from ferrolink import vehicle

    node = vehicle.connect("udpin:0.0.0.0:14550")
    drone = node.wait_for_system(timeout=10)
    print(drone.position(), drone.state())
    drone.arm(); drone.takeoff(10)

    async def main():
        node = vehicle.connect("udpin:0.0.0.0:14550")
        drone = await node.wait_for_system_async(timeout=10)   # an AsyncSystem
        await drone.arm(); await drone.takeoff(10)

Telemetry methods return dicts in SI units and degrees, ``None`` before the first message of
their kind; actions return ``{"result": "ACCEPTED", "accepted": True, "command": ..,
"in_progress": .., "progress": [..]}``. Waiting releases the GIL; the asyncio face runs each
call in asyncio's default thread pool, so the event loop never blocks.
"""

from __future__ import annotations

import asyncio
import functools
from typing import Any, List, Optional

from . import _native
from ._native import System

__all__ = ["AsyncSystem", "Node", "System", "connect"]


class Node:
    """Our node on a link: a ground station (255/190) that sends its heartbeat once a second,
    and the vehicles it hears."""

    def __init__(self, uri: str) -> None:
        self._native = _native.Node(uri)

    def systems(self) -> List[System]:
        """The vehicles heard in the last 5 s."""
        return self._native.systems()

    def system(self, id: int) -> Optional[System]:
        """Vehicle ``id``, if heard."""
        return self._native.system(id)

    def wait_for_system(self, timeout: float = 10.0) -> Optional[System]:
        """The first vehicle heard, waiting up to ``timeout`` seconds; ``None`` then."""
        return self._native.wait_for_system(timeout)

    async def wait_for_system_async(self, timeout: float = 10.0) -> Optional["AsyncSystem"]:
        """``wait_for_system`` for asyncio: the vehicle as an ``AsyncSystem``."""
        found = await asyncio.to_thread(self._native.wait_for_system, timeout)
        return None if found is None else AsyncSystem(found)


def connect(uri: str) -> Node:
    """Opens ``uri`` (our URIs and pymavlink's spellings) as a ground station."""
    return Node(uri)


_CALLS = (
    "arm disarm takeoff land return_to_launch hold goto set_mode reboot set_rate wait_position "
    "params param set_param download_mission upload_mission ftp_list ftp_get"
).split()


class AsyncSystem:
    """A vehicle for asyncio (``AsyncSystem(system)``): every call that waits on the vehicle is
    a coroutine; telemetry (the latest values, which never wait) is read as on ``System``."""

    def __init__(self, system: System) -> None:
        self.blocking = system

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self.blocking, name)
        if name not in _CALLS:
            return attr

        @functools.wraps(attr)
        async def call(*args: Any, **kwargs: Any) -> Any:
            return await asyncio.to_thread(attr, *args, **kwargs)

        return call
