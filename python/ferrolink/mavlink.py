"""MAVLink logs and connections, as pymavlink's users know them, at native speed.

Dialects are the standard ones built in, by name (``"ardupilotmega"``, the default, as
mavlogdump's), or a dialect XML file's path.
"""

from __future__ import annotations

import os
import time
from typing import Any, Dict, Iterable, Iterator, List, Optional, Sequence, Union

from . import _native
from ._native import MAVLink_header, MAVLink_message, MAVLink_unknown

__all__ = [
    "DEFAULT_DIALECT",
    "MAVLink_header",
    "MAVLink_message",
    "MAVLink_unknown",
    "Connection",
    "connect",
    "dialects",
    "load_log",
    "open_log",
    "save_parquet",
]

DEFAULT_DIALECT = "ardupilotmega"

Types = Optional[Union[str, Iterable[str]]]


def _types(types: Types) -> Optional[List[str]]:
    if types is None:
        return None
    if isinstance(types, str):
        return [types]
    return list(types)


def dialects() -> List[str]:
    """The names of the built-in dialects."""
    return list(_native.dialects())


def _path(path: Union[str, os.PathLike]) -> str:
    return os.fspath(path)


def open_log(
    path: Union[str, os.PathLike],
    dialect: str = DEFAULT_DIALECT,
    types: Types = None,
    raw: bool = False,
) -> "_native.LogIter":
    """Iterates over the messages of a ``.tlog`` (or of a raw capture, with ``raw=True``).

    Each message behaves like pymavlink's: ``get_type()``, ``to_dict()``, ``get_srcSystem()``,
    ``get_srcComponent()``, ``get_seq()``, ``get_msgId()``, ``get_header()``, ``_timestamp``
    (the tlog's seconds), and the fields as attributes. Ids the dialect lacks come as
    ``MAVLink_unknown`` (``get_type() == "UNKNOWN_<id>"``), as pymavlink yields them.

    ``types`` (a name or names) filters before decoding; ``"UNKNOWN_<id>"`` asks for an id the
    dialect lacks. Damage is skipped, never yielded (pymavlink yields it as ``BAD_DATA``). The
    file is read a chunk at a time (files larger than memory too), and damage is
    resynchronised: every intact frame after it is found. ``stats()`` on the iterator tells what
    was skipped.
    """
    return _native.LogIter(_path(path), dialect, _types(types), raw)


_TO = ("pandas", "arrow", "polars", "numpy")


def load_log(
    path: Union[str, os.PathLike],
    types: Types = None,
    dialect: str = DEFAULT_DIALECT,
    to: str = "pandas",
    raw: bool = False,
) -> Dict[str, Any]:
    """Reads a log into one table per message type: ``{name: table}``.

    Each table has a ``timestamp`` column (tlog seconds), ``sysid``, ``compid``, then one column
    per field: numbers in their wire type, arrays as fixed-size lists, ``char`` arrays as
    strings. The tables are built in Rust straight into Arrow buffers, with no Python object per
    message, and handed over without a copy.

    ``to`` is ``"pandas"`` (DataFrames), ``"arrow"`` (pyarrow Tables), ``"polars"`` (DataFrames)
    or ``"numpy"`` (``{column: ndarray}``). All need pyarrow; pandas and polars need themselves.
    """
    if to not in _TO:
        raise ValueError(f"to={to!r}: expected one of {', '.join(_TO)}")
    import pyarrow as pa

    tables = _native.load_tables(_path(path), dialect, _types(types), raw)
    out: Dict[str, Any] = {}
    for name, stream in tables:
        table = pa.table(stream)
        if to == "pandas":
            out[name] = table.to_pandas()
        elif to == "polars":
            import polars as pl

            out[name] = pl.from_arrow(table)
        elif to == "numpy":
            out[name] = {
                column: table.column(column).to_numpy() for column in table.column_names
            }
        else:
            out[name] = table
    return out


def save_parquet(
    paths: Union[str, os.PathLike, Sequence[Union[str, os.PathLike]]],
    out_dir: Union[str, os.PathLike],
    types: Types = None,
    dialect: str = DEFAULT_DIALECT,
    raw: bool = False,
) -> Dict[str, str]:
    """Writes logs into ``out_dir``, one Parquet file per message type (``NAME.parquet``), with a
    ``log`` column naming each row's file: ``{name: path}``. DuckDB, polars, pandas and Spark
    read them as they are, a directory of them as one dataset per type."""
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    written = _native.save_parquet(
        [_path(p) for p in paths], _path(out_dir), dialect, _types(types), raw
    )
    return {name: path for name, path, _rows in written}


_GCS = 6  # MAV_TYPE_GCS
_INVALID = 8  # MAV_AUTOPILOT_INVALID


def _evaluate(condition: Optional[str], messages: Dict[str, Any]) -> bool:
    """pymavlink's ``evaluate_condition``: the expression over the latest messages by name."""
    if condition is None:
        return True
    try:
        value = eval(condition, {}, messages)  # noqa: S307 (pymavlink's semantics)
    except (NameError, ZeroDivisionError, IndexError, AttributeError):
        return False
    return bool(value) if value is not None else False


class _Sender:
    """``conn.mav.NAME_send(*fields)``: pymavlink's senders, arguments in XML order."""

    def __init__(self, connection: "Connection") -> None:
        self._connection = connection

    def __getattr__(self, attr: str):
        if not attr.endswith("_send"):
            raise AttributeError(attr)
        name = attr[: -len("_send")].upper()
        fields = self._connection._native.field_names(name)

        def send(*args: Any, **kwargs: Any) -> None:
            if len(args) > len(fields):
                raise TypeError(f"{attr}() takes {len(fields)} arguments, {len(args)} given")
            values = dict(zip(fields, args))
            values.update(kwargs)
            kwargs.pop("force_mavlink1", None)
            values.pop("force_mavlink1", None)
            self._connection.send(name, **values)

        return send


class Connection:
    """A live MAVLink connection with pymavlink's ``mavfile`` interface (``recv_match``,
    ``recv_msg``, ``wait_heartbeat``, ``messages``, ``target_system``...). Waiting releases the
    GIL. Use it as a context manager, or ``close()`` it."""

    def __init__(
        self,
        uri: str,
        dialect: str = DEFAULT_DIALECT,
        source_system: int = 255,
        source_component: int = 190,
    ) -> None:
        self._native = _native.NativeConnection(uri, dialect, source_system, source_component)
        self.uri = uri
        self.source_system = source_system
        self.source_component = source_component
        self.target_system = 0
        self.target_component = 0
        self.messages: Dict[str, Any] = {}
        self.mav = _Sender(self)

    def _track(self, m: Any) -> None:
        kind = m.get_type()
        self.messages[kind] = m
        if kind == "HEARTBEAT" and m.type != _GCS and m.autopilot != _INVALID:
            if self.target_system == 0:
                self.target_system = m.get_srcSystem()
                self.target_component = m.get_srcComponent()

    def recv_msg(self) -> Optional[Any]:
        """The next message already received, or ``None``."""
        m = self._native.recv(0)
        if m is not None:
            self._track(m)
        return m

    def recv_match(
        self,
        condition: Optional[str] = None,
        type: Types = None,
        blocking: bool = False,
        timeout: Optional[float] = None,
    ) -> Optional[Any]:
        """The next message of ``type`` (a name or names) for which ``condition`` holds, with
        pymavlink's semantics: without ``blocking``, only messages already received are looked
        at; with it, waits up to ``timeout`` seconds (``None``: for ever)."""
        types = _types(type)
        start = time.monotonic()
        while True:
            wait = 0.0
            if blocking:
                wait = None if timeout is None else max(0.0, start + timeout - time.monotonic())
            m = self._native.recv(wait)
            if m is None:
                return None
            self._track(m)
            if types is not None and m.get_type() not in types:
                continue
            if not _evaluate(condition, self.messages):
                continue
            return m

    def wait_heartbeat(self, blocking: bool = True, timeout: Optional[float] = None) -> Optional[Any]:
        """The next HEARTBEAT (pymavlink's ``wait_heartbeat``); after it, ``target_system`` and
        ``target_component`` name the vehicle."""
        return self.recv_match(type="HEARTBEAT", blocking=blocking, timeout=timeout)

    def send(self, name: str, **fields: Any) -> None:
        """Sends message ``name`` with ``fields`` (left out: zero)."""
        self._native.send_dict({"mavpackettype": name.upper(), **fields})

    def send_message(self, msg: Any) -> None:
        """Sends a message object: ours, or pymavlink's (anything with ``to_dict()``)."""
        self._native.send_dict(msg.to_dict())

    def dropped(self) -> int:
        """Messages lost because they were not read in time (the queue holds 65,536)."""
        return self._native.dropped()

    def local_addr(self):
        """The bound local address, ``(host, port)``, for ``udpin``/``udpout``/``tcpin``."""
        return self._native.local_addr()

    def close(self) -> None:
        """Closes the link."""
        self._native.close()

    def __enter__(self) -> "Connection":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def connect(
    uri: str,
    dialect: str = DEFAULT_DIALECT,
    source_system: int = 255,
    source_component: int = 190,
) -> Connection:
    """Opens a connection, as ``mavutil.mavlink_connection`` does: our URIs
    (``udpin://0.0.0.0:14550``, ``tcpout://HOST:PORT``, ``serial:///dev/ttyACM0:115200``) and
    pymavlink's spellings (``udpin:0.0.0.0:14550``, ``udpout:HOST:PORT``, ``tcp:HOST:PORT``,
    ``/dev/ttyACM0,115200``)."""
    return Connection(uri, dialect, source_system, source_component)
