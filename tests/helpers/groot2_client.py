"""The Groot2 side of the monitoring protocol, byte for byte, for tests: a ZeroMQ REQ client on loopback.

Written from the protocol's definition (BT.CPP 4.x ``groot2_protocol.h``), independently of
mission.groot.protocol, so a mistake shared by both ends cannot pass: every header is packed and
checked here with its own ``struct`` formats.
"""

from __future__ import annotations

import random
import struct
from dataclasses import dataclass

import msgpack
import zmq

PROTOCOL = 2
HEADER = "<BBI"  # uint8 protocol, uint8 request type, uint32 request id
UUID_BYTES = 16


class ProtocolError(AssertionError):
    """The executor answered something the protocol does not allow."""


@dataclass
class Reply:
    request_type: str
    request_id: int
    tree_uuid: bytes
    parts: list[bytes]  # the parts after the 22-byte header


class Groot2Client:
    """One REQ socket to an executor's REP port (PORT); `timeout_s` bounds every request."""

    def __init__(self, port: int, host: str = "127.0.0.1", timeout_s: float = 5.0) -> None:
        self.ctx = zmq.Context()
        self.sock = self.ctx.socket(zmq.REQ)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.setsockopt(zmq.RCVTIMEO, int(timeout_s * 1000))
        self.sock.setsockopt(zmq.SNDTIMEO, int(timeout_s * 1000))
        self.sock.connect(f"tcp://{host}:{port}")
        self.rng = random.Random(7)

    def close(self) -> None:
        self.sock.close(linger=0)
        self.ctx.term()

    def raw(self, parts: list[bytes]) -> list[bytes]:
        """Send `parts` as they are; the reply's parts."""
        self.sock.send_multipart(parts)
        return self.sock.recv_multipart()

    def request(self, kind: str, *payload: bytes) -> Reply:
        """A request of type `kind` ('T', 'S', 'B', …); the reply checked against the request's header."""
        request_id = self.rng.getrandbits(32)
        header = struct.pack(HEADER, PROTOCOL, ord(kind), request_id)
        assert len(header) == 6
        parts = self.raw([header, *payload])
        if parts[0] == b"error":
            raise ProtocolError(f"error reply to {kind!r}: {parts[1:]!r}")
        if len(parts[0]) != 6 + UUID_BYTES:
            raise ProtocolError(f"reply header is {len(parts[0])} bytes, expected 22")
        protocol, echoed_type, echoed_id = struct.unpack(HEADER, parts[0][:6])
        if (protocol, echoed_type, echoed_id) != (PROTOCOL, ord(kind), request_id):
            raise ProtocolError(
                f"reply header {(protocol, echoed_type, echoed_id)} does not echo {(PROTOCOL, ord(kind), request_id)}"
            )
        return Reply(chr(echoed_type), echoed_id, parts[0][6:], parts[1:])

    # -- what Groot2 asks -------------------------------------------------------------------------
    def full_tree(self) -> str:
        return self.request("T").parts[0].decode("utf-8")

    def statuses(self) -> dict[int, int]:
        """uid → status byte (10 + s: IDLE after s)."""
        data = self.request("S").parts[0]
        if len(data) % 3:
            raise ProtocolError(f"STATUS payload of {len(data)} bytes is not 3 per node")
        out: dict[int, int] = {}
        for i in range(0, len(data), 3):
            (uid,) = struct.unpack("<H", data[i : i + 2])
            if uid in out:
                raise ProtocolError(f"uid {uid} twice in one STATUS reply")
            out[uid] = data[i + 2]
        return out

    def blackboards(self, *names: str) -> dict[str, dict]:
        data = self.request("B", ";".join(names).encode("utf-8")).parts[0]
        return msgpack.unpackb(data, raw=False)

    def start_recording(self) -> int:
        return int(self.request("r", b"start").parts[0])

    def transitions(self) -> list[tuple[int, int, int]]:
        data = self.request("t").parts[0]
        if len(data) % 9:
            raise ProtocolError(f"GET_TRANSITIONS payload of {len(data)} bytes is not 9 per transition")
        return [
            (int.from_bytes(data[i : i + 6], "little"), *struct.unpack("<HB", data[i + 6 : i + 9]))
            for i in range(0, len(data), 9)
        ]
