"""Is there a Dask scheduler at an address? Asked over a plain socket in Dask's own wire format
before any Client is made, so a stranger at the address can neither make us unpickle what it
sends (Dask's reader deserialises whatever the peer declares) nor make us allocate what its
first eight bytes claim: replies are read up to ``MAX_REPLY`` bytes and decoded as msgpack
only, whose extension types stay opaque bytes.

The exchange a Dask client makes on connecting: each side writes a handshake, then the client
asks ``{"op": "identity"}`` and a scheduler answers ``{"type": "Scheduler", ...}``. A message
on the wire: the byte count of what follows (uint64), the frame count and each frame's length
(uint64s), the frames; the first frame is the msgpack of the message."""

import socket
import struct
import sys
import time
from urllib.parse import urlsplit

MAX_REPLY = 16 << 20  # a scheduler's identity lists its workers: about 1 kB each


class _NotDask(Exception):
    """What came back is not a Dask message."""


def _frame(message: dict) -> bytes:
    import msgpack

    body = msgpack.packb(message, use_bin_type=True)
    prelude = struct.pack("QQ", 1, len(body))
    return struct.pack("Q", len(prelude) + len(body)) + prelude + body


def _read_exactly(sock, n: int, deadline: float) -> bytes:
    out = bytearray()
    while len(out) < n:
        sock.settimeout(max(deadline - time.monotonic(), 1e-3))
        chunk = sock.recv(min(n - len(out), 1 << 16))
        if not chunk:
            raise _NotDask("the peer closed the connection")
        out += chunk
    return bytes(out)


def _read_message(sock, deadline: float) -> dict:
    import msgpack

    (inline,) = struct.unpack("Q", _read_exactly(sock, 8, deadline))
    if not 16 <= inline <= MAX_REPLY:
        raise _NotDask(f"a message of {inline} bytes")
    data = _read_exactly(sock, inline, deadline)
    (count,) = struct.unpack_from("Q", data)
    if not 1 <= count <= (inline - 8) // 8:
        raise _NotDask(f"{count} frames")
    lengths = struct.unpack_from(f"{count}Q", data, 8)
    start = 8 + 8 * count
    if start + lengths[0] > len(data):  # the first frame always comes inline
        raise _NotDask("a first frame longer than its message")
    try:
        message = msgpack.unpackb(data[start:start + lengths[0]], raw=False, strict_map_key=False)
    except (ValueError, msgpack.UnpackException) as err:
        raise _NotDask(f"not msgpack ({type(err).__name__})") from None
    if not isinstance(message, dict):
        raise _NotDask("not a mapping")
    return message


def _host_port(address: str) -> tuple[str, int]:
    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    if parts.scheme != "tcp" or not parts.hostname or parts.port is None:
        raise ValueError(f"a scheduler address is tcp://host:port, got {address!r}")
    return parts.hostname, parts.port


def ask_scheduler(address: str, timeout: float) -> None:
    """Raise a clear RuntimeError unless a Dask scheduler answers at ``address`` (tcp://host:port)
    within ``timeout`` seconds; ValueError for an address or timeout that cannot be one."""
    if not (isinstance(timeout, (int, float)) and 0 < timeout < float("inf")):
        raise ValueError(f"connect_timeout must be a number of seconds > 0, got {timeout}")
    host, port = _host_port(address)
    deadline = time.monotonic() + timeout
    try:
        with socket.create_connection((host, port), timeout=timeout) as sock:
            handshake = {"compression": None, "python": tuple(sys.version_info)[:3], "pickle-protocol": 5}
            sock.sendall(_frame(handshake) + _frame({"op": "identity", "reply": True}))
            _read_message(sock, deadline)  # the scheduler's handshake
            identity = _read_message(sock, deadline)
    except (TimeoutError, OSError) as err:
        raise RuntimeError(f"no Dask scheduler answered at {address} within {timeout:g} s ({type(err).__name__}"
                           f"{': ' + str(err) if str(err) else ''}): start one ('dask scheduler') or check the "
                           "address") from None
    except (_NotDask, struct.error) as err:
        raise RuntimeError(f"{address} answered but is not a Dask scheduler ({err}): check the address") from None
    if identity.get("type") != "Scheduler":
        raise RuntimeError(f"{address} answered but is not a Dask scheduler: check the address")
