"""Ferrolink for Python: MAVLink logs and connections at native speed.

- ``ferrolink.mavlink.open_log``: a log's messages, one by one, as pymavlink hands them out;
- ``ferrolink.mavlink.load_log``: a log as one table per message type (pandas, polars, Arrow, numpy);
- ``ferrolink.mavlink.save_parquet``: many logs into one Parquet file per message type;
- ``ferrolink.mavlink.connect``: a live connection with pymavlink's ``recv_match``;
- ``ferrolink.vehicle``: the vehicle API (telemetry, actions, parameters, missions, files),
  blocking and asyncio.
"""

from . import mavlink, vehicle
from ._native import __version__

__all__ = ["mavlink", "vehicle", "__version__"]
