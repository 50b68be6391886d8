"""The websocket hub: one bounded, latest-wins channel per client.

State frames replace each other (a slow client gets the newest state, never a backlog);
event, plan and end frames queue in order. A client whose queue of such frames overflows is
dropped: it never slows the simulation or the other clients.
"""

from __future__ import annotations

import asyncio
from collections import deque
from typing import Any

from app.service.frames import EndFrame, StateFrame, StreamFrame

Frame = StreamFrame
TRAIL_SECONDS = 0.25  # model seconds between a running mission's trail rows at least
TRAIL_ROWS = 4000  # at most; beyond, every other row goes (the trail stays evenly thinned)


def extend_trail(trail: list[list[float]], frame: StateFrame) -> None:
    """Append a state frame's pose as a trajectory row ``[t, x, y, ψ, φ1, φ2, φ3]``."""
    if trail and frame.t - trail[-1][0] < TRAIL_SECONDS:
        return
    p = frame.pose
    trail.append([frame.t, p.x, p.y, p.psi, *p.joints])
    if len(trail) > TRAIL_ROWS:
        del trail[1:-1:2]


class Channel:
    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.state: Frame | None = None
        self.frames: deque[Frame] = deque()
        self.wake = asyncio.Event()
        self.dropped = 0  # state frames superseded before delivery
        self.overflowed = False
        self.delivered = 0

    def offer(self, frame: Frame) -> None:
        if self.overflowed:
            return
        if isinstance(frame, StateFrame):
            if self.state is not None:
                self.dropped += 1
            self.state = frame
        elif len(self.frames) >= self.limit:
            self.overflowed = True  # too slow: the connection gets closed
        else:
            self.frames.append(frame)
        self.wake.set()

    async def next(self) -> Frame | None:
        """The next frame to send (ordered frames first, then the latest state); None if dropped."""
        while True:
            if self.overflowed:
                return None
            if self.frames:
                self.delivered += 1
                return self.frames.popleft()
            if self.state is not None:
                frame, self.state = self.state, None
                self.delivered += 1
                return frame
            self.wake.clear()
            await self.wake.wait()


class Hub:
    def __init__(self, limit: int = 256) -> None:
        self.limit = limit
        self.channels: dict[str, set[Channel]] = {}
        self.last_tree: dict[str, dict[str, Any]] = {}  # mission -> its latest tree snapshot
        # A running mission's path as its state frames told it (the store has the trajectory
        # only once it ends): a viewer opened midway draws the trail from the start.
        self.trails: dict[str, list[list[float]]] = {}

    def subscribe(self, mission_id: str) -> Channel:
        channel = Channel(self.limit)
        self.channels.setdefault(mission_id, set()).add(channel)
        return channel

    def unsubscribe(self, mission_id: str, channel: Channel) -> None:
        group = self.channels.get(mission_id)
        if group is not None:
            group.discard(channel)
            if not group:
                del self.channels[mission_id]

    def publish(self, mission_id: str, frame: Frame) -> None:
        if isinstance(frame, StateFrame):
            self.last_tree[mission_id] = frame.tree
            extend_trail(self.trails.setdefault(mission_id, []), frame)
        elif isinstance(frame, EndFrame):  # the store keeps the last tree and the path now
            self.last_tree.pop(mission_id, None)
            self.trails.pop(mission_id, None)
        for channel in list(self.channels.get(mission_id, ())):
            channel.offer(frame)

    @property
    def clients(self) -> int:
        return sum(len(c) for c in self.channels.values())
