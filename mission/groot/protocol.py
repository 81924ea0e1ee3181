"""Groot2's monitoring protocol (BehaviorTree.CPP 4.x, ``loggers/groot2_protocol.h``), as bytes.

Written from the protocol's definition, not from BT.CPP's code. Every message is a ZeroMQ multipart
request/reply on a REP socket at PORT (a PUB socket at PORT + 1 carries breakpoint notifications):

* request, first part, 6 bytes: ``uint8 protocol`` (2), ``uint8 type`` (an ASCII letter, below),
  ``uint32 request id``, little endian; some types carry a second part (BLACKBOARD: ``"name;name"``);
* reply, first part, 22 bytes: the request's 6 bytes (protocol set to 2) + the tree's 16-byte UUID
  (random per publisher, so Groot2 notices a restarted executor); then the payload part, if any;
* a request that cannot be served gets a two-part ``["error", why]`` reply instead.

Node statuses are BT.CPP's ``NodeStatus`` numbers; a node that went back to IDLE is sent as
``10 + the status it had`` in STATUS replies (Groot2 draws it faded), never in logs.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass

PROTOCOL_ID = 2

# request types: the ASCII codes of BT.CPP's Monitor::RequestType
FULLTREE = ord("T")  # the tree as XML, every node with its _uid
STATUS = ord("S")  # 3 bytes per node: uint16 uid, uint8 status
BLACKBOARD = ord("B")  # second part "name;name": msgpack of {name: {key: value}}
HOOK_INSERT = ord("I")
HOOK_REMOVE = ord("R")
BREAKPOINT_REACHED = ord("N")  # sent by the executor on the PUB socket
BREAKPOINT_UNLOCK = ord("U")
HOOKS_DUMP = ord("D")
REMOVE_ALL_HOOKS = ord("A")
DISABLE_ALL_HOOKS = ord("X")
TOGGLE_RECORDING = ord("r")  # second part "start" | "stop"
GET_TRANSITIONS = ord("t")  # 9 bytes per transition: 6-byte µs timestamp, uint16 uid, uint8 status

# BT.CPP NodeStatus
IDLE, RUNNING, SUCCESS, FAILURE, SKIPPED = 0, 1, 2, 3, 4
IDLE_FROM = 10  # + the status a node had before it went back to IDLE (STATUS replies only)

REQUEST_HEADER = struct.Struct("<BBI")  # protocol, type, request id
REQUEST_HEADER_SIZE = REQUEST_HEADER.size  # 6
UUID_SIZE = 16
REPLY_HEADER_SIZE = REQUEST_HEADER_SIZE + UUID_SIZE  # 22
STATUS_ENTRY = struct.Struct("<HB")  # uid, status
TRANSITION_SIZE = 9  # 6-byte timestamp (µs, the low 6 bytes of a uint64 LE), uint16 uid, uint8 status


@dataclass(frozen=True)
class RequestHeader:
    protocol: int
    type: int
    request_id: int


def parse_request_header(data: bytes) -> RequestHeader:
    """The first part of a request; ValueError when it is not 6 bytes."""
    if len(data) != REQUEST_HEADER_SIZE:
        raise ValueError(f"wrong request header: {len(data)} bytes, expected {REQUEST_HEADER_SIZE}")
    protocol, kind, request_id = REQUEST_HEADER.unpack(data)
    return RequestHeader(protocol, kind, request_id)


def reply_header(request: RequestHeader, tree_uuid: bytes) -> bytes:
    """The first part of a reply: the request echoed with protocol 2, then the tree's UUID."""
    if len(tree_uuid) != UUID_SIZE:
        raise ValueError(f"tree UUID must be {UUID_SIZE} bytes, got {len(tree_uuid)}")
    return REQUEST_HEADER.pack(PROTOCOL_ID, request.type, request.request_id) + tree_uuid


def new_tree_uuid() -> bytes:
    """16 random bytes shaped as an RFC 4122 version-4 UUID, as the executor sends once per start."""
    raw = bytearray(os.urandom(UUID_SIZE))
    raw[6] = (raw[6] & 0x4F) | 0x40  # version 0100
    raw[8] = (raw[8] & 0xBF) | 0x80  # variant 10
    return bytes(raw)


def pack_transition(timestamp_us: int, uid: int, status: int) -> bytes:
    """One transition as FileLogger2 and GET_TRANSITIONS write it (timestamp clipped to 48 bits)."""
    return struct.pack("<Q", timestamp_us & 0xFFFF_FFFF_FFFF)[:6] + STATUS_ENTRY.pack(uid, status)


def unpack_transition(data: bytes, offset: int = 0) -> tuple[int, int, int]:
    """(timestamp µs, uid, status) of the 9 bytes at `offset`."""
    timestamp = int.from_bytes(data[offset : offset + 6], "little")
    uid, status = STATUS_ENTRY.unpack_from(data, offset + 6)
    return timestamp, uid, status
