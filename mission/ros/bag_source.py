"""Recorded bags as replay reads them: ROS 1 ``.bag``, rosbag2 (sqlite3, mcap), complete or damaged.

``rosbags`` reads complete bags (:class:`_AnyReaderBag`). Bags a robot left behind are often not complete,
and each case here is read as far as it goes, with a note saying what was missing:

* a rosbag2 directory **without metadata.yaml** (the recorder was killed before it closed the bag): its
  data files are read directly, like ``ros2 bag reindex`` does;
* a **truncated mcap** ("File end magic is invalid": no footer or summary) or **sqlite3** file, and a
  ROS 1 bag whose index at the end is missing (cut off or never closed): the records are scanned from
  the start and replay stops at the first one that is damaged, with a warning (:attr:`BagSource.damage`).

Messages come back as (topic, msgtype, timestamp ns, raw bytes) in the order they were written (which is
time order for anything a recorder wrote); :meth:`BagSource.deserialize` turns raw bytes into a message
of the bag's own type definitions (ROS 2 CDR or ROS 1 serialization).
"""

from __future__ import annotations

import bz2
import os
import sqlite3
import struct
import tempfile
from collections.abc import Iterator
from contextlib import suppress
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any, BinaryIO

from rosbags.highlevel import AnyReader
from rosbags.rosbag2.storage_mcap import McapReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from mission.core.errors import MissionError

ROS1_MAGIC = b"#ROSBAG V2.0\n"
MCAP_MAGIC = b"\x89MCAP0\r\n"


@dataclass(frozen=True)
class BagConnection:
    topic: str
    msgtype: str  # "pkg/msg/Name"


@dataclass
class BagSource:
    """An open bag: its connections, its messages in file order, and how to deserialize them."""

    path: Path
    kind: str  # "rosbag1" | "rosbag2 (mcap)" | "rosbag2 (sqlite3)"
    connections: list[BagConnection] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what was unusual about opening it (one line each)
    damage: str | None = None  # set when reading stopped early at a damaged record

    def topics(self, msgtypes: tuple[str, ...] | None = None) -> list[str]:
        return sorted({c.topic for c in self.connections if msgtypes is None or c.msgtype in msgtypes})

    def messages(self, topics: set[str]) -> Iterator[tuple[str, str, int, bytes]]:
        raise NotImplementedError

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        raise NotImplementedError

    def close(self) -> None:
        """Release the files (idempotent)."""

    def _damaged(self, err: BaseException, where: str) -> None:
        why = " ".join(str(err).split()) or type(err).__name__
        self.damage = f"{self.path}: the bag is damaged {where} ({why}); replayed what came before"


# --------------------------------------------------------------------------------------------------
# complete bags: rosbags' AnyReader
# --------------------------------------------------------------------------------------------------


class _AnyReaderBag(BagSource):
    def __init__(self, path: Path, reader: AnyReader, kind: str) -> None:
        super().__init__(path, kind, [BagConnection(c.topic, c.msgtype) for c in reader.connections])
        self._reader = reader

    def messages(self, topics: set[str]) -> Iterator[tuple[str, str, int, bytes]]:
        conns = [c for c in self._reader.connections if c.topic in topics]
        if not conns:
            return
        try:
            for conn, timestamp, raw in self._reader.messages(connections=conns):
                yield conn.topic, conn.msgtype, timestamp, raw
        except Exception as err:  # rosbags raises several unrelated types on a damaged file
            self._damaged(err, "while reading")

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        return self._reader.deserialize(raw, msgtype)

    def close(self) -> None:
        with suppress(Exception):
            self._reader.close()


# --------------------------------------------------------------------------------------------------
# rosbag2 data files read directly (no metadata.yaml, or damaged)
# --------------------------------------------------------------------------------------------------


class _Cdr(BagSource):
    """rosbag2 messages deserialized with the Jazzy type store plus the types the file defines."""

    def _typestore(self, definitions: dict[str, str]) -> None:
        self._store = get_typestore(Stores.ROS2_JAZZY)
        for msgtype, text in definitions.items():
            if msgtype not in self._store.types and text:
                with suppress(Exception):
                    self._store.register(get_types_from_msg(text, msgtype))

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        return self._store.deserialize_cdr(raw, msgtype)


class _McapFile(_Cdr):
    """One .mcap file: through its summary when it has one, else scanned record by record to the damage."""

    def __init__(self, path: Path, note: str | None) -> None:
        super().__init__(path, "rosbag2 (mcap)")
        self._reader: McapReader | None = McapReader(path)
        self._scan: _McapScan | None = None
        try:
            self._reader.open()
            conns = [(c.topic, c.msgtype, c.msgdef.data) for c in self._reader.connections]
        except Exception as err:  # no footer or summary (cut off, or never closed): scan it
            with suppress(Exception):
                self._reader.close()
            self._reader = None
            self._scan = _McapScan(path)
            self.notes.append(f"{path}: {' '.join(str(err).split())}: reading the records from the start")
            conns = [(t, m, d) for t, m, d in self._scan.channels.values()]
            self.damage = self._scan.damage
        if note:
            self.notes.append(note)
        self.connections = [BagConnection(t, m) for t, m, _ in conns]
        self._typestore({m: d for _, m, d in conns})

    def messages(self, topics: set[str]) -> Iterator[tuple[str, str, int, bytes]]:
        if self._scan is not None:
            self.damage = None
            yield from self._scan.messages(topics)
            self.damage = self._scan.damage
            return
        assert self._reader is not None
        conns = [c for c in self._reader.connections if c.topic in topics]
        if not conns:
            return
        try:
            for conn, timestamp, raw in self._reader.messages(conns):
                yield conn.topic, conn.msgtype, timestamp, raw
        except Exception as err:
            self._damaged(err, "while reading")

    def close(self) -> None:
        if self._reader is not None:
            with suppress(Exception):
                self._reader.close()
        if self._scan is not None:
            self._scan.close()


class _Cut(Exception):
    """The file ends inside a record."""


def _take(buf: memoryview, pos: int, n: int) -> tuple[memoryview, int]:
    if pos + n > len(buf):
        raise _Cut(f"a record is cut off at byte {len(buf)}")
    return buf[pos : pos + n], pos + n


def _string(buf: memoryview, pos: int) -> tuple[str, int]:
    raw, pos = _take(buf, pos, 4)
    (n,) = struct.unpack("<I", raw)
    text, pos = _take(buf, pos, n)
    return bytes(text).decode("utf-8", errors="replace"), pos


class _McapScan:
    """The records of an mcap file from its start (MCAP spec: opcode u8, length u64, content), inside
    chunks too (uncompressed, zstd, lz4), stopping where the file is cut off: a chunk cut off in the middle
    still gives the records it holds up to the cut (what a stream decompressor recovers of it)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.data = path.read_bytes()
        if not self.data:
            raise MissionError(f"{path}: empty: the recording was cut off before anything was written to it")
        if self.data[:8] != MCAP_MAGIC:
            raise MissionError(f"{path}: not an mcap file (no MCAP magic at its start)")
        self.channels: dict[int, tuple[str, str, str]] = {}  # id → (topic, msgtype, definition)
        self._schemas: dict[int, tuple[str, str]] = {}  # id → (msgtype, definition)
        self.damage: str | None = None
        for _ in self._walk(want_messages=False, topics=set()):
            pass

    def _walk(self, *, want_messages: bool, topics: set[str]) -> Iterator[tuple[str, str, int, bytes]]:
        self.damage = None
        try:
            yield from self._records(memoryview(self.data), 8, want_messages, topics, top=True)
        except _Cut as err:
            self.damage = f"{self.path}: the bag is damaged ({err}); replayed what came before"
        except Exception as err:  # a chunk that does not decompress, a malformed record
            self.damage = f"{self.path}: the bag is damaged ({' '.join(str(err).split())}); replayed what came before"

    def _records(
        self, buf: memoryview, pos: int, want_messages: bool, topics: set[str], *, top: bool
    ) -> Iterator[tuple[str, str, int, bytes]]:
        while pos < len(buf):
            head, pos = _take(buf, pos, 9)
            op = head[0]
            (length,) = struct.unpack("<Q", head[1:9])
            if op == 0x06 and top:  # a chunk: its records, as far as they are there
                end = min(len(buf), pos + length)
                yield from self._chunk(buf[pos:end], want_messages, topics)
                if pos + length > len(buf):
                    raise _Cut(f"a chunk is cut off at byte {len(buf)}")
                pos += length
                continue
            content, pos = _take(buf, pos, length)
            if op == 0x03:  # schema: id u16, name, encoding, data
                (sid,) = struct.unpack("<H", content[:2])
                name, p = _string(content, 2)
                _, p = _string(content, p)
                text, _ = _string(content, p)
                self._schemas[sid] = (name, text)
            elif op == 0x04:  # channel: id u16, schema id u16, topic, message encoding, metadata
                cid, sid = struct.unpack("<HH", content[:4])
                topic, _ = _string(content, 4)
                msgtype, text = self._schemas.get(sid, ("", ""))
                self.channels.setdefault(cid, (topic, msgtype, text))
            elif op == 0x05 and want_messages:  # message: channel u16, sequence u32, log time u64, publish time u64
                cid, _, log_time, _ = struct.unpack("<HIQQ", content[:22])
                channel = self.channels.get(cid)
                if channel is not None and channel[0] in topics:
                    yield channel[0], channel[1], int(log_time), bytes(content[22:])
            elif op in (0x02, 0x0A, 0x0B, 0x0E):  # footer, summary offsets, statistics, data end: data is over
                return

    def _chunk(self, raw: memoryview, want_messages: bool, topics: set[str]) -> Iterator[tuple[str, str, int, bytes]]:
        pos = 8 + 8 + 8 + 4  # message start and end time, uncompressed size, crc
        compression, pos = _string(raw, pos)
        sized, pos = _take(raw, pos, 8)
        (size,) = struct.unpack("<Q", sized)
        body = bytes(raw[pos : pos + size])
        if compression == "zstd":
            from backports import zstd

            body = zstd.ZstdDecompressor().decompress(body)  # a stream decompressor: a cut chunk gives its start
        elif compression == "lz4":
            import lz4.frame

            body = lz4.frame.LZ4FrameDecompressor().decompress(body)
        elif compression:
            raise ValueError(f"unknown chunk compression {compression!r}")
        yield from self._records(memoryview(body), 0, want_messages, topics, top=False)

    def messages(self, topics: set[str]) -> Iterator[tuple[str, str, int, bytes]]:
        yield from self._walk(want_messages=True, topics=topics)

    def close(self) -> None:
        self.data = b""


class _Sqlite3File(_Cdr):
    """One rosbag2 .db3 file read with sqlite3: its topics table, then its messages in insertion order."""

    def __init__(self, path: Path, note: str | None) -> None:
        super().__init__(path, "rosbag2 (sqlite3)")
        self._copy: Path | None = None
        try:
            self._db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
            rows = self._db.execute("SELECT id, name, type FROM topics").fetchall()
        except sqlite3.DatabaseError as err:
            rows = self._open_cut(err)
        self._topic_ids = {int(i): (str(n), str(t)) for i, n, t in rows}
        self.connections = [BagConnection(n, t) for n, t in self._topic_ids.values()]
        if note:
            self.notes.append(note)
        self._typestore({})

    def _open_cut(self, err: sqlite3.DatabaseError) -> list[Any]:
        """A file cut off mid-write: its header still counts the pages it was meant to have, so SQLite calls
        it malformed. A copy with the whole pages that are there, and the header saying so, reads up to the
        first page that is missing."""
        with suppress(Exception):
            self._db.close()
        data = bytearray(self.path.read_bytes())
        if data[:16] != b"SQLite format 3\x00":
            raise MissionError(f"{self.path}: not a readable rosbag2 sqlite3 file ({err})") from None
        (page,) = struct.unpack(">H", data[16:18])
        page = 65536 if page == 1 else page
        pages = len(data) // page
        del data[pages * page :]
        data[28:32] = struct.pack(">I", pages)
        handle, name = tempfile.mkstemp(suffix=".db3", prefix="mission-replay-")
        with os.fdopen(handle, "wb") as f:
            f.write(data)
        self._copy = Path(name)
        try:
            self._db = sqlite3.connect(f"file:{self._copy}?mode=ro", uri=True)
            rows = self._db.execute("SELECT id, name, type FROM topics").fetchall()
        except sqlite3.Error as again:
            self.close()
            raise MissionError(f"{self.path}: not a readable rosbag2 sqlite3 file ({again})") from None
        self.notes.append(f"{self.path}: {err} (cut off after {pages} pages?): reading the pages that are there")
        return rows

    def messages(self, topics: set[str]) -> Iterator[tuple[str, str, int, bytes]]:
        ids = [i for i, (n, _) in self._topic_ids.items() if n in topics]
        if not ids:
            return
        marks = ",".join("?" * len(ids))
        query = f"SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN ({marks}) ORDER BY id"
        try:
            for topic_id, timestamp, data in self._db.execute(query, ids):
                name, msgtype = self._topic_ids[int(topic_id)]
                yield name, msgtype, int(timestamp), bytes(data)
        except sqlite3.Error as err:
            self._damaged(err, "while reading")

    def close(self) -> None:
        with suppress(Exception):
            self._db.close()
        if self._copy is not None:
            self._copy.unlink(missing_ok=True)
            self._copy = None


class _Concatenated(BagSource):
    """Several data files of one rosbag2 directory, one after the other."""

    def __init__(self, path: Path, parts: list[BagSource]) -> None:
        super().__init__(path, parts[0].kind, notes=[n for p in parts for n in p.notes])
        self._parts = parts
        seen: dict[tuple[str, str], None] = {}
        for p in parts:
            for c in p.connections:
                seen.setdefault((c.topic, c.msgtype), None)
        self.connections = [BagConnection(t, m) for t, m in seen]

    def messages(self, topics: set[str]) -> Iterator[tuple[str, str, int, bytes]]:
        for p in self._parts:
            yield from p.messages(topics)
            if p.damage is not None:
                self.damage = p.damage
                return

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        return self._parts[0].deserialize(raw, msgtype)

    def close(self) -> None:
        for p in self._parts:
            p.close()


# --------------------------------------------------------------------------------------------------
# ROS 1 bags whose index is missing
# --------------------------------------------------------------------------------------------------


def _ros1_fields(header: bytes) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    pos = 0
    while pos + 4 <= len(header):
        (n,) = struct.unpack_from("<I", header, pos)
        name, _, value = header[pos + 4 : pos + 4 + n].partition(b"=")
        out[name.decode("latin-1")] = value
        pos += 4 + n
    return out


def _ros1_msgtype(name: str) -> str:
    pkg, _, typ = name.partition("/")
    return f"{pkg}/msg/{typ}" if "/msg/" not in name else name


class _Ros1Scan(BagSource):
    """A ROS 1 bag read record by record from the start (connections, chunks, messages), to the damage."""

    def __init__(self, path: Path, why: str) -> None:
        super().__init__(path, "rosbag1")
        self._file = path.open("rb")
        if self._file.read(len(ROS1_MAGIC)) != ROS1_MAGIC:
            self._file.close()
            raise MissionError(f"{path}: not a ROS 1 bag (no '#ROSBAG V2.0' header)")
        self.notes.append(f"{path}: {why}: reading the records from the start")
        self._store = get_typestore(Stores.EMPTY)
        self._conns: dict[int, BagConnection] = {}
        self._defined: set[str] = set()
        self._start = self._file.tell()
        # One pass for the connections (they are what replay chooses topics by); messages are read in a second.
        for _ in self._records(want_messages=False):
            pass
        self.connections = list({(c.topic, c.msgtype): c for c in self._conns.values()}.values())

    def _read_record(self, bio: BinaryIO) -> tuple[dict[str, bytes], bytes, str | None] | None:
        """(header fields, data, why the data is incomplete or None); None at the end."""
        head = bio.read(4)
        if not head:
            return None
        if len(head) < 4:
            raise EOFError("a record header is cut off")
        (hlen,) = struct.unpack("<I", head)
        header = bio.read(hlen)
        size = bio.read(4)
        if len(header) < hlen or len(size) < 4:
            raise EOFError("a record header is cut off")
        (dlen,) = struct.unpack("<I", size)
        data = bio.read(dlen)
        cut = None if len(data) == dlen else f"a record's data is cut off ({len(data)} of {dlen} bytes)"
        return _ros1_fields(header), data, cut

    def _connection(self, fields: dict[str, bytes], data: bytes) -> None:
        (cid,) = struct.unpack("<I", fields["conn"])
        info = _ros1_fields(data)
        msgtype = _ros1_msgtype(info.get("type", b"").decode())
        topic = fields.get("topic", b"").decode()
        if cid not in self._conns:
            self._conns[cid] = BagConnection(topic, msgtype)
        if msgtype not in self._defined:
            self._defined.add(msgtype)
            with suppress(Exception):
                self._store.register(get_types_from_msg(info.get("message_definition", b"").decode(), msgtype))

    def _records(self, want_messages: bool, topics: set[str] | None = None) -> Iterator[tuple[str, str, int, bytes]]:
        self._file.seek(self._start)
        stack: list[BinaryIO] = [self._file]
        try:
            while stack:
                if isinstance(stack[-1], _CutAfter):
                    raise EOFError(stack[-1].why)
                rec = self._read_record(stack[-1])
                if rec is None:
                    stack.pop()
                    continue
                fields, data, cut = rec
                op = fields.get("op", b"\x00")[:1]
                if cut is not None and op != b"\x05":
                    raise EOFError(cut)
                if op == b"\x07":
                    self._connection(fields, data)
                elif op == b"\x05":  # a chunk: the records in it (of a cut-off one, those that are there)
                    compression = fields.get("compression", b"none").decode()
                    stack.append(BytesIO(_decompress(compression, data, partial=cut is not None)))
                    if cut is not None:
                        stack.insert(0, _CutAfter(cut))
                elif op == b"\x02" and want_messages:
                    (cid,) = struct.unpack("<I", fields["conn"])
                    secs, nsecs = struct.unpack("<II", fields["time"])
                    conn = self._conns.get(cid)
                    if conn is not None and (topics is None or conn.topic in topics):
                        yield conn.topic, conn.msgtype, secs * 1_000_000_000 + nsecs, data
        except Exception as err:  # a cut-off record, a chunk that does not decompress
            if self.damage is None:
                self._damaged(err, "at its last record")

    def messages(self, topics: set[str]) -> Iterator[tuple[str, str, int, bytes]]:
        damage, self.damage = self.damage, None
        yield from self._records(want_messages=True, topics=topics)
        self.damage = self.damage or damage

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        return self._store.deserialize_ros1(raw, msgtype)

    def close(self) -> None:
        with suppress(Exception):
            self._file.close()


class _CutAfter(BytesIO):
    """On the record stack below a cut-off chunk's records: the bag ends there."""

    def __init__(self, why: str) -> None:
        super().__init__(b"")
        self.why = why


def _decompress(compression: str, data: bytes, partial: bool = False) -> bytes:
    """A ROS 1 chunk's records; of a cut-off chunk (`partial`), as much as its start decompresses to."""
    if compression == "none":
        return data
    if compression == "bz2":
        return bz2.BZ2Decompressor().decompress(data) if partial else bz2.decompress(data)
    if compression == "lz4":
        import lz4.frame

        return bytes(lz4.frame.LZ4FrameDecompressor().decompress(data) if partial else lz4.frame.decompress(data))
    raise ValueError(f"unknown chunk compression {compression!r}")


# --------------------------------------------------------------------------------------------------
# opening
# --------------------------------------------------------------------------------------------------


def _starts_with(path: Path, magic: bytes) -> bool:
    try:
        with path.open("rb") as f:
            return f.read(len(magic)) == magic
    except OSError:
        return False


def _data_files(directory: Path) -> list[Path]:
    return sorted([*directory.glob("*.mcap"), *directory.glob("*.db3")])


def _file_source(path: Path, note: str | None) -> BagSource:
    if path.suffix == ".db3":
        return _Sqlite3File(path, note)
    return _McapFile(path, note)


def open_bag(path: str | Path) -> BagSource:
    """The bag at `path`: a ROS 1 ``.bag`` file, a rosbag2 directory, or one of its ``.mcap`` / ``.db3`` files.

    A MissionError naming the path when it is not a bag at all."""
    p = Path(path)
    if not p.exists():
        raise MissionError(f"{p}: bag not found")
    typestore = get_typestore(Stores.ROS2_JAZZY)
    if p.is_file() and (p.suffix == ".bag" or _starts_with(p, ROS1_MAGIC)):
        try:
            reader = AnyReader([p], default_typestore=typestore)
            reader.open()
            return _AnyReaderBag(p, reader, "rosbag1")
        except Exception as err:  # unindexed (never closed) or cut off: scan it
            return _Ros1Scan(p, " ".join(str(err).split()) or "no index")
    if p.is_file() and p.name != "metadata.yaml" and p.suffix not in (".mcap", ".db3"):
        # not its neighbours: a file that is no bag must not replay the bag beside it
        raise MissionError(
            f"{p}: not a bag: expected a ROS 1 .bag file, a rosbag2 directory, or its metadata.yaml, .mcap or .db3 file"
        )
    directory = p.parent if p.is_file() else p
    if p.is_file() and p.suffix in (".mcap", ".db3"):
        if (directory / "metadata.yaml").exists():
            p = directory
        else:
            return _file_source(p, f"{p}: a rosbag2 data file without metadata.yaml: read directly")
    if not (directory / "metadata.yaml").exists():
        files = _data_files(directory)
        if not files:
            raise MissionError(
                f"{p}: not a readable rosbag2 (mcap or sqlite3): no metadata.yaml and no .mcap or "
                ".db3 file; or a ROS 1 .bag file"
            )
        note = f"{directory}: no metadata.yaml (the recording was not closed): reading its data files directly"
        parts = [_file_source(f, note if i == 0 else None) for i, f in enumerate(files)]
        return parts[0] if len(parts) == 1 else _Concatenated(directory, parts)
    try:
        reader = AnyReader([directory], default_typestore=typestore)
        reader.open()
        kind = "rosbag2 (sqlite3)" if any(directory.glob("*.db3")) else "rosbag2 (mcap)"
        return _AnyReaderBag(directory, reader, kind)
    except Exception as err:  # a damaged data file behind a good metadata.yaml
        files = _data_files(directory)
        if not files:
            why = " ".join(str(err).split())
            raise MissionError(f"{p}: not a readable rosbag2 (mcap or sqlite3): {why}") from None
        note = f"{directory}: {' '.join(str(err).split())}: reading its data files directly"
        parts = [_file_source(f, note if i == 0 else None) for i, f in enumerate(files)]
        return parts[0] if len(parts) == 1 else _Concatenated(directory, parts)
