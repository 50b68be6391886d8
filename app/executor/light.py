"""A py_trees behaviour whose own per-tick work is small: ticked every control tick.

``py_trees.behaviour.Behaviour.tick`` and ``stop`` format a debug message on every call (even
with debug logging off) and list every status to validate the one returned; a mission ticks
its tree four times a model second, thousands of times, so that is a fair share of a tick.
``LightBehaviour`` does the same steps in the same order without the message.
"""

from __future__ import annotations

from collections.abc import Iterator

import py_trees
from py_trees.common import Status


class LightBehaviour(py_trees.behaviour.Behaviour):
    """``Behaviour`` with ``tick`` and ``stop`` that skip the debug message."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """Initialise unless running, update, stop on a status other than running, keep the
        status, yield self (as ``Behaviour.tick``)."""
        if self.status != Status.RUNNING:
            self.initialise()
        new_status = self.update()
        if not isinstance(new_status, Status):
            self.logger.error(f"invalid status {new_status!r}, setting INVALID [{self.name}]")
            new_status = Status.INVALID
        if new_status != Status.RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self

    def stop(self, new_status: Status) -> None:
        """Terminate, take the new status, and a fresh tick iterator (as ``Behaviour.stop``)."""
        self.terminate(new_status)
        self.status = new_status
        self.iterator = self.tick()
