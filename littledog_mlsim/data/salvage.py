"""What a killed recorder left: an MCAP file cut short, read as far as it is whole.

A recorder killed mid-bag (SIGKILL, a power cut) leaves an MCAP file without its summary
section and footer, usually cut inside a chunk. rosbags refuses such a file (it starts from the
footer). :func:`salvage_mcap` walks the file from its start instead and keeps every whole
schema, channel and message record: those at the top level, those of whole chunks (checked
against their CRC), and those of an uncompressed chunk up to the record the cut falls in. It
writes them, in file order, into a new MCAP file without chunks that ends in a proper footer
(no summary: readers scan it), so that the import reads the salvaged copy like any other bag.
What it could not keep is said in one line (:attr:`Salvage.dropped`).
"""
from __future__ import annotations

import io
import struct
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Salvage", "SalvageError", "salvage_mcap"]

MAGIC = b"\x89MCAP0\r\n"
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
OP_DATA_END = 0x0F
KEPT_OPS = (OP_SCHEMA, OP_CHANNEL, OP_MESSAGE)
_U64 = struct.Struct("<Q")
_U32 = struct.Struct("<I")


class SalvageError(ValueError):
    """Nothing can be salvaged (not an MCAP file, or no whole message); one line."""


@dataclass
class Salvage:
    """What :func:`salvage_mcap` kept and dropped."""

    source: Path
    out: Path
    size: int                    # bytes of the source file
    messages: int                # message records kept
    chunks_whole: int            # whole chunks read
    dropped: str                 # one line: what was left out and why ("" if nothing)


def _records(buf: bytes, pos: int, end: int):
    """(op, start, content start, content end) of the whole records in ``buf[pos:end]``, then
    (None, where the first incomplete record starts, ...)."""
    while pos + 9 <= end:
        op = buf[pos]
        (n,) = _U64.unpack_from(buf, pos + 1)
        if pos + 9 + n > end:
            break
        yield op, pos, pos + 9, pos + 9 + n
        pos += 9 + n
    yield None, pos, pos, end


def _chunk_records(buf: bytes, start: int, end: int, whole: bool) -> tuple[bytes, int, str]:
    """The records inside a chunk record's content ``buf[start:end]``: (records bytes, bytes of
    records cut off, problem). ``whole``: the chunk record is complete."""
    from rosbags.rosbag2.storage_mcap import decompress

    if end - start < 40:
        return b"", 0, "a chunk header cut short"
    (usize,) = _U64.unpack_from(buf, start + 16)
    (crc,) = _U32.unpack_from(buf, start + 24)
    (clen,) = _U32.unpack_from(buf, start + 28)
    compression = buf[start + 32:start + 32 + clen].decode("utf-8", "replace")
    p = start + 32 + clen
    if p + 8 > end:
        return b"", usize, "a chunk header cut short"
    (csize,) = _U64.unpack_from(buf, p)
    data = buf[p + 8:min(p + 8 + csize, end)]
    if whole and len(data) == csize:
        try:
            return decompress(data, compression, usize, crc), 0, ""
        except Exception as exc:   # a CRC mismatch or a corrupt stream
            return b"", usize, f"a chunk that does not check out ({exc})"
    if compression:
        return b"", usize, f"a {compression}-compressed chunk cut short"
    return data, usize - len(data), ""


def salvage_mcap(src: str | Path, out: str | Path) -> Salvage:
    """Copy every whole record of the MCAP file ``src`` that a reader needs into ``out``.

    SalvageError if ``src`` is not an MCAP file or holds no whole message."""
    src, out = Path(src), Path(out)
    buf = src.read_bytes()
    if not buf.startswith(MAGIC) or len(buf) < len(MAGIC) + 9 or buf[len(MAGIC)] != OP_HEADER:
        raise SalvageError("not an MCAP file (no MCAP magic and header at its start)")
    kept: list[bytes] = []
    n_msg = n_chunks = 0
    lost_in_chunks = 0
    problems: list[str] = []
    tail = 0
    for op, at, c0, c1 in _records(buf, len(MAGIC), len(buf)):
        if op is None:                        # the record the file was cut in
            tail = len(buf) - at
            if tail and buf[at] == OP_CHUNK and at + 9 <= len(buf):
                inner, lost, problem = _chunk_records(buf, at + 9, len(buf), whole=False)
                lost_in_chunks += lost
                problems += [problem] if problem else []
                n_msg += _keep(inner, kept)
                tail = 0 if not problem else tail
            break
        if op == OP_DATA_END:                 # the data section is whole; the summary follows
            break
        if op in KEPT_OPS:
            kept.append(buf[at:c1])
            n_msg += op == OP_MESSAGE
        elif op == OP_CHUNK:
            inner, lost, problem = _chunk_records(buf, c0, c1, whole=True)
            lost_in_chunks += lost
            problems += [problem] if problem else []
            n_msg += _keep(inner, kept)
            n_chunks += not problem
    if not n_msg:
        raise SalvageError(f"no whole message in its {len(buf)} bytes")
    _write(out, kept)
    return Salvage(src, out, len(buf), n_msg, n_chunks,
                   _dropped(len(buf), tail, lost_in_chunks, problems))


def _keep(records: bytes, kept: list[bytes]) -> int:
    """Append the whole schema/channel/message records of ``records``; returns messages kept."""
    n = 0
    for op, at, _, c1 in _records(records, 0, len(records)):
        if op is None:
            break
        if op in KEPT_OPS:
            kept.append(records[at:c1])
            n += op == OP_MESSAGE
    return n


def _dropped(size: int, tail: int, lost: int, problems: list[str]) -> str:
    parts = []
    if lost:
        parts.append(f"{lost} bytes of records after the cut inside its last chunk (the "
                     "messages recorded after them are lost with them)")
    if tail:
        parts.append(f"an unfinished record at its end ({tail} bytes)")
    parts += problems
    summary = "no summary section or footer (the recorder did not close the file)"
    return f"{summary}; dropped {'; '.join(parts)}" if parts else summary


def _write(out: Path, records: list[bytes]) -> None:
    """An MCAP file of ``records`` (top level, no chunks), a data end and a footer."""
    f = io.BytesIO()
    f.write(MAGIC)
    profile, library = b"ros2", b"littledog_mlsim salvage"
    header = _U32.pack(len(profile)) + profile + _U32.pack(len(library)) + library
    f.write(bytes([OP_HEADER]) + _U64.pack(len(header)) + header)
    for r in records:
        f.write(r)
    f.write(bytes([OP_DATA_END]) + _U64.pack(4) + _U32.pack(0))
    f.write(bytes([OP_FOOTER]) + _U64.pack(20) + _U64.pack(0) + _U64.pack(0) + _U32.pack(0))
    f.write(MAGIC)
    out.write_bytes(f.getvalue())
