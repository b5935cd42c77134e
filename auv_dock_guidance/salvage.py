"""The messages of a ROS 2 bag cut short (power lost while recording), read without its index.

rosbags opens a bag from its summary: an MCAP file needs its footer and end magic, a
rosbag2 folder its metadata.yaml. A recording cut short has neither. Here the MCAP records
are read in file order (schemas, channels, messages, and the records inside chunks, also
from a chunk the cut went through, as far as it is intact), and a sqlite3 file row by row
until its first missing page. The python ``mcap`` library reads records in order too, but
takes a chunk only whole: a bag cut in its last (or only) chunk gives it nothing.

``SalvagedBag`` offers what replay uses of rosbags' AnyReader.
"""

from __future__ import annotations

import sqlite3
import struct
import tempfile
from collections import Counter
from collections.abc import Generator, Iterable, Iterator
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from lz4.frame import LZ4FrameDecompressor
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

try:  # as rosbags does: the standard library from Python 3.14, the backport before
    from compression import zstd
except ImportError:
    from backports import zstd

MCAP_MAGIC = b"\x89MCAP0\r\n"
SQLITE_MAGIC = b"SQLite format 3\x00"
OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x02, 0x03, 0x04, 0x05, 0x06


@dataclass(frozen=True)
class SalvagedConnection:
    id: int
    topic: str
    msgtype: str
    msgcount: int


@dataclass(frozen=True)
class _Record:
    op: int
    body: bytes


class SalvagedBag:
    """Every intact message of a bag that cannot be opened, in file order; ``account`` says what was lost."""

    is2 = True

    def __init__(self, path: Path) -> None:
        self.path = path
        self.typestore = get_typestore(Stores.ROS2_JAZZY)
        self.connections: list[SalvagedConnection] = []
        self.account = ""
        self._file_size = path.stat().st_size
        self._copy: Path | None = None  # sqlite3: the readable pages, in a file of our own
        with path.open("rb") as f:
            magic = f.read(16)
        if magic.startswith(MCAP_MAGIC):
            self._kind = "mcap"
            self._scan_mcap()
        elif magic == SQLITE_MAGIC:
            self._kind = "sqlite3"
            self._scan_sqlite()
        else:
            raise ValueError(f"{path} is neither an MCAP nor an SQLite file")

    # What replay uses of AnyReader.
    def messages(self, connections: Iterable[Any] | None = None) -> Iterator[tuple[SalvagedConnection, int, bytes]]:
        wanted = {c.id for c in (connections if connections is not None else self.connections)}
        by_id = {c.id: c for c in self.connections}
        source = self._mcap_messages() if self._kind == "mcap" else self._sqlite_messages()
        for cid, timestamp, raw in source:
            if cid in wanted:
                yield by_id[cid], timestamp, raw

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        return self.typestore.deserialize_cdr(raw, msgtype)

    def close(self) -> None:
        if self._copy is not None:
            self._copy.unlink(missing_ok=True)
            self._copy = None

    def _register(self, msgtype: str, definition: str) -> None:
        """Types the bag defines and the Jazzy store does not know (its own messages)."""
        if msgtype in self.typestore.fielddefs or not definition:
            return
        try:
            self.typestore.register(get_types_from_msg(definition, msgtype))
        except Exception:  # an IDL or broken definition: its messages are copied, never decoded
            pass

    def _finish(self, counts: Counter[int], channels: dict[int, tuple[str, str]], how: str) -> None:
        self.connections = [SalvagedConnection(cid, topic, msgtype, counts[cid])
                            for cid, (topic, msgtype) in sorted(channels.items())]
        self.account = f"{how}: {sum(counts.values())} messages recovered, what was recorded after them is lost"

    # MCAP
    def _scan_mcap(self) -> None:
        schemas: dict[int, str] = {}
        channels: dict[int, tuple[str, str]] = {}
        counts: Counter[int] = Counter()
        end = _McapEnd()
        for record in _mcap_records(self.path, end):
            if record.op == OP_SCHEMA:
                sid, rest = struct.unpack_from("<H", record.body)[0], memoryview(record.body)[2:]
                name, rest = _string(rest)
                _encoding, rest = _string(rest)
                data, _ = _string(rest)
                schemas[sid] = name
                self._register(name, data)
            elif record.op == OP_CHANNEL:
                cid, sid = struct.unpack_from("<HH", record.body)
                topic, _ = _string(memoryview(record.body)[4:])
                channels[cid] = (topic, schemas.get(sid, ""))
            elif record.op == OP_MESSAGE and len(record.body) >= 22:
                counts[struct.unpack_from("<H", record.body)[0]] += 1
        share = 100.0 * end.position / self._file_size if self._file_size else 0.0
        self._finish(counts, channels, f"{self.path.name} read record by record: its index is unusable"
                     if end.why == "complete" else f"the bag was cut short ({end.why}; intact records in the "
                     f"first {end.position} of {self._file_size} bytes, {share:.0f} %)")

    def _mcap_messages(self) -> Iterator[tuple[int, int, bytes]]:
        for record in _mcap_records(self.path, _McapEnd()):
            if record.op == OP_MESSAGE and len(record.body) >= 22:
                cid, _seq, log_time = struct.unpack_from("<HIQ", record.body)
                yield cid, log_time, record.body[22:]

    # sqlite3 (rosbag2's schema: topics, messages)
    def _scan_sqlite(self) -> None:
        """SQLite refuses a file that ends inside a page, or short of the size its header declares:
        the whole pages are read from a private copy whose header declares what is there."""
        copy = tempfile.NamedTemporaryFile(prefix="auv-dock-salvage-", suffix=".db3", delete=False)
        self._copy = Path(copy.name)
        with copy, self.path.open("rb") as source:
            header = bytearray(source.read(100))
            size = struct.unpack_from(">H", header, 16)[0]
            page_size = 65536 if size == 1 else size
            declared = page_size * struct.unpack_from(">I", header, 28)[0]
            whole = self._file_size // page_size
            struct.pack_into(">I", header, 28, whole)
            copy.write(header)
            left = whole * page_size - len(header)
            while left > 0 and (block := source.read(min(left, 1 << 24))):
                copy.write(block)
                left -= len(block)
        channels: dict[int, tuple[str, str]] = {}
        try:
            with closing(self._connect()) as db:
                for tid, name, msgtype in db.execute("SELECT id, name, type FROM topics"):
                    channels[tid] = (name, msgtype)
        except sqlite3.DatabaseError as exc:
            self.close()
            raise ValueError(f"{self.path}: its list of topics is lost ({exc})") from exc
        counts = Counter(cid for cid, _, _ in self._sqlite_messages())
        self._finish(counts, channels, f"the bag was cut short (the file holds {self._file_size} of the {declared} "
                                       f"bytes its header declares; rows read up to the first missing page)"
                     if declared > self._file_size else "rows unreadable after the last one recovered")

    def _connect(self) -> sqlite3.Connection:
        return sqlite3.connect(f"file:{self._copy}?mode=ro", uri=True)

    def _sqlite_messages(self) -> Iterator[tuple[int, int, bytes]]:
        """Rows in insertion order until the first page SQLite cannot read."""
        with closing(self._connect()) as db:
            try:
                for cid, timestamp, data in db.execute("SELECT topic_id, timestamp, data FROM messages ORDER BY id"):
                    yield cid, timestamp, bytes(data)
            except sqlite3.DatabaseError:
                return


class _McapEnd:
    """Where the readable records ended, and why."""

    position = 0
    why = "no footer"


def _mcap_records(path: Path, end: _McapEnd) -> Iterator[_Record]:
    """Top-level records and the records inside chunks, in file order, up to the first one cut."""
    size = path.stat().st_size
    with path.open("rb") as f:
        f.seek(len(MCAP_MAGIC))
        end.position = f.tell()
        while True:
            head = f.read(9)
            if len(head) < 9:
                end.why = "the file ends between records" if head == b"" else "the file ends in a record header"
                return
            op, length = struct.unpack("<BQ", head)
            if op == OP_FOOTER:
                end.why = "complete"
                return
            body = _read_at_most(f, length, size)
            if op == OP_CHUNK:
                complete = len(body) == length
                kept = yield from _chunk_records(body)
                if not complete:
                    end.why = "the file ends inside a chunk"
                    end.position += 9 + kept
                    return
            elif len(body) < length:
                end.why = "the file ends inside a record"
                return
            else:
                yield _Record(op, body)
            end.position = f.tell()


def _read_at_most(f: BinaryIO, length: int, size: int) -> bytes:
    """A record's body, or what the file still holds of it (a length beyond the file is a cut or damage)."""
    return f.read(max(0, min(length, size - f.tell())))


def _chunk_records(body: bytes) -> Generator[_Record, None, int]:
    """The intact records of a chunk, whole or cut; returns how many bytes of the chunk they cover."""
    if len(body) < 28:
        return 0
    offset = 28
    compression, offset = _string_at(body, offset)
    if compression is None or len(body) < offset + 8:
        return 0
    offset += 8  # the length of the records, as written; a cut chunk holds less
    data = body[offset:]
    try:
        if compression == "zstd":
            data = zstd.ZstdDecompressor().decompress(data)  # a cut frame gives what it holds
        elif compression == "lz4":
            data = LZ4FrameDecompressor().decompress(data)
        elif compression:
            return 0
    except Exception:
        return 0
    position = 0
    while position + 9 <= len(data):
        op, length = struct.unpack_from("<BQ", data, position)
        if position + 9 + length > len(data):
            break
        yield _Record(op, data[position + 9: position + 9 + length])
        position += 9 + length
    return offset + position if not compression else offset


def _string(view: memoryview) -> tuple[str, memoryview]:
    (length,) = struct.unpack_from("<I", view)
    return bytes(view[4:4 + length]).decode(errors="replace"), view[4 + length:]


def _string_at(data: bytes, offset: int) -> tuple[str | None, int]:
    if len(data) < offset + 4:
        return None, offset
    (length,) = struct.unpack_from("<I", data, offset)
    if len(data) < offset + 4 + length:
        return None, offset
    return data[offset + 4: offset + 4 + length].decode(errors="replace"), offset + 4 + length
