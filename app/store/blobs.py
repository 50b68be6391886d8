"""Content-addressed, compressed storage of large texts and JSON (PDDL, actions, trajectories).

A plan's PDDL domain is the same text for every version of a mission (and across missions):
stored once. Problems and trajectories are long and repetitive: LZMA keeps a tenth or less.
What a worker compressed itself (a plan version's PDDL source) is kept as it came (``STORED``).

Writing is two steps so that the store's write lock is never held while compressing:
``prepare`` (hash, and compress what the database lacks; no lock, a read at most), then
``put`` (insert, inside the write transaction).
"""

from __future__ import annotations

import hashlib
import json
import lzma
from dataclasses import dataclass
from typing import Any

from sqlalchemy.orm import Session

from app.store.models import BlobRow

CODEC = "lzma2"  # raw LZMA2, no container: ~250 bytes less per blob than .xz
STORED = "stored"  # bytes kept as they came: their writer compressed them (PDDL sources)
PRESET = 9  # the decoder's: its 64 MiB dictionary reads any blob written
FILTERS = [{"id": lzma.FILTER_LZMA2, "preset": PRESET}]  # decoding: 64 MiB covers any blob
# The encoder's preset: the fastest. A mission's trajectory (85 kB of JSON) packs in 1.3 ms to
# 8.5 kB, against 33 ms to 7.2 kB at preset 9: the store's writes are on the way from a
# mission's last tick to its stored end.
PACK_PRESET = 0
MIN_DICT = 4096  # LZMA2's smallest dictionary


def dictionary_size(raw: bytes) -> int:
    """The smallest power-of-two dictionary (at least 4 KiB, at most the preset's 64 MiB) that
    holds ``raw``: the same stream as the preset's, without setting up 64 MiB of match tables
    (~40 ms) for a few kilobytes. The decoder's larger dictionary reads it unchanged."""
    size = MIN_DICT
    while size < len(raw) and size < 64 << 20:
        size *= 2
    return size


def pack(raw: bytes) -> bytes:
    dict_size = dictionary_size(raw)
    filters = [{"id": lzma.FILTER_LZMA2, "preset": PACK_PRESET, "dict_size": dict_size}]
    return lzma.compress(raw, format=lzma.FORMAT_RAW, filters=filters)


@dataclass(frozen=True)
class Blob:
    """A text ready to store: its SHA-256, its bytes, and their compressed form (None when the
    database already had it); ``codec`` says how ``data`` holds them."""

    digest: str
    raw: bytes
    data: bytes | None
    codec: str = CODEC


def prepare(session: Session, text: str) -> Blob:
    """Hash ``text`` and compress it unless the database has it already (a read, no lock)."""
    raw = text.encode("utf-8")
    digest = hashlib.sha256(raw).hexdigest()
    known = session.get(BlobRow, digest) is not None
    return Blob(digest, raw, None if known else pack(raw))


def prepare_json(session: Session, value: Any) -> Blob:
    return prepare(session, json.dumps(value, separators=(",", ":")))


def prepare_bytes(session: Session, data: bytes) -> Blob:
    """Hash bytes that come compressed (``STORED``: kept as they are, never compressed
    again); a read, no lock."""
    digest = hashlib.sha256(data).hexdigest()
    known = session.get(BlobRow, digest) is not None
    return Blob(digest, data, None if known else data, STORED)


def put(session: Session, blob: Blob) -> str:
    """Store a prepared blob (once) and return its SHA-256; the caller commits. One that was
    there when prepared but deleted since is compressed here (rare: a retention sweep)."""
    if session.get(BlobRow, blob.digest) is None:
        data = blob.data
        if data is None:
            data = blob.raw if blob.codec == STORED else pack(blob.raw)
        session.add(BlobRow(sha256=blob.digest, codec=blob.codec, size=len(blob.raw), data=data))
        session.flush()  # a second put of the same text in this session finds it
    return blob.digest


def get_bytes(session: Session, digest: str) -> bytes:
    """A blob's bytes as they were put (decompressed, unless ``STORED``)."""
    row = session.get(BlobRow, digest)
    if row is None:
        raise KeyError(f"blob {digest} is missing")
    if row.codec == STORED:
        return bytes(row.data)
    if row.codec != CODEC:
        raise ValueError(f"blob {digest}: unknown codec {row.codec!r}")
    return lzma.decompress(row.data, format=lzma.FORMAT_RAW, filters=FILTERS)


def get_text(session: Session, digest: str) -> str:
    return get_bytes(session, digest).decode("utf-8")


def get_json(session: Session, digest: str) -> Any:
    return json.loads(get_text(session, digest))
