"""py_trees behaviours and composites whose own per-tick work is small: ticked every control tick.

``py_trees.behaviour.Behaviour.tick`` and ``stop`` format a debug message on every call (even
with debug logging off) and list every status to validate the one returned; a mission ticks
its tree four times a model second, thousands of times, so that is a fair share of a tick.
``LightBehaviour`` does the same steps in the same order without the message; ``Sequence`` and
``Selector`` do what py_trees' composites do, and pass up only their own node.
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


class Sequence(py_trees.composites.Sequence):
    """py_trees' ``Sequence`` (its name too: the tree's snapshots show it so), ticked as py_trees
    ticks it, without the debug messages, and yielding only itself: its children's nodes are not
    passed up the tree (a tree ticked by ``tick_once`` has no visitor to read them), where each
    was yielded once per ancestor."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        index = 0
        if self.status != Status.RUNNING:
            self.current_child = self.children[0] if self.children else None
            for child in self.children:
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
            self.initialise()
        elif self.memory and self.current_child is not None:
            index = self.children.index(self.current_child)
        else:
            self.current_child = self.children[0] if self.children else None
        if not self.children:
            self.current_child = None
            self.stop(Status.SUCCESS)
            yield self
            return
        for child in self.children[index:]:
            for node in child.tick():
                if node is child and node.status != Status.SUCCESS:
                    if not self.memory:  # invalidate the rest: kill dangling runners
                        for later in self.children[index + 1 :]:
                            if later.status != Status.INVALID:
                                later.stop(Status.INVALID)
                    if node.status != Status.RUNNING:
                        self.stop(node.status)
                    else:
                        self.status = node.status
                    yield self
                    return
            if index + 1 < len(self.children):
                self.current_child = self.children[index + 1]
                index += 1
        self.stop(Status.SUCCESS)
        yield self

    def stop(self, new_status: Status = Status.INVALID) -> None:
        py_trees.composites.Composite.stop(self, new_status)


class Selector(py_trees.composites.Selector):
    """py_trees' ``Selector``, ticked as py_trees ticks it, without the debug messages, yielding
    only itself (see ``Sequence``)."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        if self.status != Status.RUNNING:
            self.current_child = self.children[0] if self.children else None
            self.initialise()
        if not self.children:
            self.current_child = None
            self.stop(Status.FAILURE)
            yield self
            return
        index = 0
        if self.memory:
            assert self.current_child is not None
            index = self.children.index(self.current_child)
            for child in self.children[:index]:
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
        previous = self.current_child
        for child in self.children[index:]:
            for node in child.tick():
                if node is child and node.status in (Status.RUNNING, Status.SUCCESS):
                    self.current_child = child
                    if previous is None or previous != self.current_child:
                        # an interrupt: invalidate everything at a lower priority
                        passed = False
                        for other in self.children:
                            if passed and other.status != Status.INVALID:
                                other.stop(Status.INVALID)
                            passed = passed or other == self.current_child
                    if node.status == Status.SUCCESS:
                        self.stop(node.status)
                    else:
                        self.status = node.status
                    yield self
                    return
        self.stop(Status.FAILURE)
        self.current_child = self.children[-1]
        yield self

    def stop(self, new_status: Status = Status.INVALID) -> None:
        py_trees.composites.Composite.stop(self, new_status)
