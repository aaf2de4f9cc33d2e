"""The feed from the console's network thread to its Tk thread, and what travels on it.

The network thread (`console.live.link`) offers every decoded manager message
(`fleet_common.control` RunSetup, State, Notice, Proposal, ...) and a few items
of its own: `LinkStatus` (connecting, connected, lost), `Reply` (the manager's
answer to one of our requests, or the link's own refusal when there is no
manager) and `Trouble` (a frame that was not a valid message). Each item is
stamped with the monotonic time it arrived.

The Tk thread drains a bounded batch per frame (thonny's rule: one `after()`
poll, Tk never touched from elsewhere). `offer` never blocks the network
thread: when the Tk thread lags and the feed is full, the oldest State is
dropped, since a newer one supersedes it; other items are never dropped.
"""
from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Deque, Dict, List, Tuple

from fleet_common.control import State

__all__ = ["CONNECTING", "CONNECTED", "LOST", "LinkStatus", "Reply", "Trouble", "LiveFeed"]

CONNECTING, CONNECTED, LOST = "connecting", "connected", "lost"


@dataclass(frozen=True)
class LinkStatus:
    """The link's view of the manager: CONNECTING (never heard it), CONNECTED, or LOST."""

    status: str
    text: str


@dataclass(frozen=True)
class Reply:
    """What became of one request: the manager's answer, or the link's refusal (`sent` False)."""

    action: str
    args: Dict[str, Any] = field(default_factory=dict)
    ok: bool = False
    reason: str = ""
    sent: bool = True


@dataclass(frozen=True)
class Trouble:
    """A frame from the manager that was not a valid message (said, then ignored)."""

    text: str


Item = Tuple[Any, float]


class LiveFeed:
    """A bounded, never-blocking queue of (item, arrival time), drained in batches."""

    def __init__(self, limit: int = 2000) -> None:
        self.limit = limit
        self.dropped = 0  # states dropped because the Tk thread lagged
        self._items: Deque[Item] = deque()
        self._lock = threading.Lock()

    def offer(self, item: Any, at: float) -> None:
        """Thread-safe; called by the network thread."""
        with self._lock:
            if len(self._items) >= self.limit:
                self._drop_a_state()
            self._items.append((item, at))

    def _drop_a_state(self) -> None:
        for k, (item, _) in enumerate(self._items):
            if isinstance(item, State):
                del self._items[k]
                self.dropped += 1
                return

    def drain(self, limit: int = 500) -> List[Item]:
        """Up to `limit` items, oldest first."""
        with self._lock:
            n = min(limit, len(self._items))
            return [self._items.popleft() for _ in range(n)]

    def __len__(self) -> int:
        return len(self._items)
