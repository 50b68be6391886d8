"""Content-addressed, compressed storage of large texts and JSON (PDDL, actions, trajectories).

A plan's PDDL domain is the same text for every version of a mission (and across missions):
stored once. Problems and trajectories are long and repetitive: LZMA keeps a tenth or less.
"""

from __future__ import annotations

import hashlib
import json
import lzma
from typing import Any

from sqlalchemy.orm import Session

from app.store.models import BlobRow

CODEC = "lzma2"  # raw LZMA2, no container: ~250 bytes less per blob than .xz
FILTERS = [{"id": lzma.FILTER_LZMA2, "preset": 9}]


def pack(raw: bytes) -> bytes:
    return lzma.compress(raw, format=lzma.FORMAT_RAW, filters=FILTERS)


def put_text(session: Session, text: str) -> str:
    """Store ``text`` (once) and return its SHA-256; the caller commits."""
    raw = text.encode("utf-8")
    digest = hashlib.sha256(raw).hexdigest()
    if session.get(BlobRow, digest) is None:
        session.add(BlobRow(sha256=digest, codec=CODEC, size=len(raw), data=pack(raw)))
        session.flush()  # a second put of the same text in this session finds it
    return digest


def put_json(session: Session, value: Any) -> str:
    return put_text(session, json.dumps(value, separators=(",", ":")))


def get_text(session: Session, digest: str) -> str:
    row = session.get(BlobRow, digest)
    if row is None:
        raise KeyError(f"blob {digest} is missing")
    if row.codec != CODEC:
        raise ValueError(f"blob {digest}: unknown codec {row.codec!r}")
    return lzma.decompress(row.data, format=lzma.FORMAT_RAW, filters=FILTERS).decode("utf-8")


def get_json(session: Session, digest: str) -> Any:
    return json.loads(get_text(session, digest))
