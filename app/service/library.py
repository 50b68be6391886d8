"""The service's library: the file it started with plus the shapes learned since, stored in
the database; each learned shape makes a new version, which every later mission runs on.

The file (by default the bundled one) is never written. Learned entries live in their own table
(``learned_primitives``, with provenance) and join the file's entries in the order they were
stored, so the same entries give the same version (the SHA-256 of the library's JSON) after a
restart, in every worker, and in the ``learned`` event of the mission that learned them. A shape
is stored once: a second learner of it (two missions at once, or a job) finds it there, and
learned the same entries anyway (its seed comes from the shape).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Sequence
from typing import Any

from app.store.repo import Store
from primitives.build import code_version
from primitives.library import Library, Primitive

log = logging.getLogger("screwsnake.library")

Learned = tuple[tuple[str, str], ...]  # (shape, its entries as JSON), in the stored order


class SharedLibrary:
    """The current library, its version, and the learned shapes a worker needs to know."""

    def __init__(self, store: Store, base: Library, source: str) -> None:
        self.store, self.base = store, base
        self.lock = threading.Lock()
        self.shapes: dict[str, tuple[Primitive, ...]] = {}
        for row in store.learned():
            self.shapes.setdefault(row.shape, ())
            self.shapes[row.shape] += (Primitive.model_validate(row.entry),)
        self.library = self._compose(list(self.shapes))
        store.record_library(self.library.to_json(), code_version(), len(self.library), source)
        self._payload = self._encode()

    @property
    def version(self) -> str:
        """The current version as the service reports it (the first 12 hex digits)."""
        return self.library.version[:12]

    def learned(self) -> Learned:
        """Every learned shape's entries, for a worker's next job (it parses each shape once)."""
        return self._payload

    def add(
        self, shape: str, entries: Sequence[Primitive], provenance: dict[str, Any]
    ) -> tuple[bool, Library]:
        """Store a learned shape (once) and make the new version current; whether this call
        stored it, and the library now current."""
        with self.lock:
            if shape in self.shapes:
                return False, self.library
            grown = self.library.with_entries(entries)
            stored = self.store.add_learned(
                shape, [e.model_dump(mode="json") for e in entries], provenance, grown.version
            )
            if not stored:  # another writer of this database was first: read what it stored
                entries = [Primitive.model_validate(r.entry) for r in self.store.learned(shape)]
                grown = self.library.with_entries(entries)
            who = provenance.get("mission_id") or provenance.get("job_id") or "offline"
            self.store.record_library(
                grown.to_json(), code_version(), len(grown), f"learned {shape} ({who})"
            )
            self.shapes[shape] = tuple(entries)
            self.library = grown
            self._payload = self._encode()
            log.info("library %s: learned %s (%d primitives)", self.version, shape, len(entries))
            return stored, grown

    def record(self, shapes: Sequence[str]) -> str:
        """Record the version made of the file and the stored ``shapes`` in this order (what a
        worker that learned concurrently with another runs on); its short version."""
        library = self._compose([s for s in shapes if s in self.shapes])
        self.store.record_library(
            library.to_json(), code_version(), len(library), f"learned {', '.join(shapes)}"
        )
        return library.version[:12]

    def _compose(self, shapes: Sequence[str]) -> Library:
        return self.base.with_entries(e for s in shapes for e in self.shapes[s])

    def _encode(self) -> Learned:
        return tuple(
            (shape, "[" + ",".join(e.model_dump_json() for e in entries) + "]")
            for shape, entries in self.shapes.items()
        )
