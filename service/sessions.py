"""Frame streams: a session keeps the previous frame's state (scoring image and features per candidate).

Temporal metrics (m3 motion, m4 stability, repeatability) and motion estimation need the previous
frame, so ``Advisor.select(…, previous=state)`` gets the state the last frame of the same session left.
Bounded three ways: sessions idle for ``ttl_s`` expire; at most ``max_sessions`` exist (a new one is
refused with 429 once expired ones are swept); the states of all sessions together hold at most
``memory_bytes`` — past that, the least recently used sessions drop their state (their next frame
is scored without temporal metrics, as a first frame would be).
"""
from __future__ import annotations

import threading
import time
import uuid
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nfex_core.errors import NfexError, NotFound
from nfex_core.verification import PairJudge


class TooManySessions(NfexError):
    status = 429
    type = "too-many-sessions"
    title = "Too many sessions"
    exit_code = 2

    def __init__(self, detail: str, *, retry_after_s: float, **extra: Any) -> None:
        super().__init__(detail, retry_after_s=round(retry_after_s, 3), **extra)
        self.headers = {"Retry-After": str(max(1, int(retry_after_s + 0.999)))}


def state_bytes(state: Any) -> int:
    """Approximate memory a FrameState holds: its images and every numpy array in its features."""
    if state is None:
        return 0
    total = int(getattr(state, "image", np.empty(0)).nbytes)
    analysis = getattr(state, "analysis", None)
    total += int(analysis.nbytes) if isinstance(analysis, np.ndarray) else 0
    for feats in getattr(state, "features", {}).values():
        for value in vars(feats).values() if hasattr(feats, "__dict__") else ():
            if isinstance(value, np.ndarray):
                total += int(value.nbytes)
    return total


@dataclass
class Session:
    id: str
    context: dict[str, str]
    client: str | None
    created: float
    last_used: float
    owner: str = ""  # who opened it (a token's name, else the client's address): the per-owner limit
    frames: int = 0
    state: Any = None
    state_bytes: int = 0
    # the stream's verification (nfex_core.verification.PairJudge): the pair awaiting a verdict, the motion prior, the
    # budget window, and whether the last verdict held α* (advisor/reuse.py)
    verification: PairJudge = field(default_factory=PairJudge, repr=False)
    lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def as_dict(self, ttl_s: float, now: float | None = None) -> dict[str, Any]:
        return {
            "id": self.id,
            "context": self.context,
            "client": self.client,
            "frames": self.frames,
            "has_previous": self.state is not None,
            "state_bytes": self.state_bytes,
            "expires_in_s": round(max(0.0, self.last_used + ttl_s - (time.monotonic() if now is None else now)), 3),
        }


class SessionStore:
    """The open sessions. ``clock`` (seconds, monotonic) is injectable, so expiry is tested without sleeping."""

    def __init__(self, *, ttl_s: float, max_sessions: int, memory_bytes: int, max_per_owner: int | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self.ttl_s = ttl_s
        self.max_sessions = max_sessions
        self.max_per_owner = max_per_owner if max_per_owner is not None else max_sessions
        self.memory_bytes = memory_bytes
        self._sessions: OrderedDict[str, Session] = OrderedDict()  # least recently used first
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._sessions)

    @property
    def bytes_held(self) -> int:
        return sum(s.state_bytes for s in self._sessions.values())

    def sweep(self) -> int:
        """Drop expired sessions; returns how many."""
        now = self.clock()
        with self._lock:
            dead = [k for k, s in self._sessions.items() if now - s.last_used > self.ttl_s]
            for k in dead:
                del self._sessions[k]
        return len(dead)

    def create(self, context: dict[str, str], client: str | None = None, owner: str = "",
               verification: PairJudge | None = None) -> Session:
        """A new session (``verification``: its pair judge, with the graph's budget terms); 429 with ``Retry-After`` (when the first session in the way expires, if it stays idle)
        past ``max_sessions`` in all or ``max_per_owner`` for ``owner``."""
        self.sweep()
        now = self.clock()
        with self._lock:
            mine = [x for x in self._sessions.values() if x.owner == owner]
            if len(mine) >= self.max_per_owner:
                raise TooManySessions(
                    f"{owner or 'this client'} has {len(mine)} sessions open (limit {self.max_per_owner} a client); close "
                    f"one (DELETE /v1/sessions/{{id}}) or wait for an idle one to expire after {self.ttl_s:g} s",
                    retry_after_s=self._first_expiry(mine, now), limit=self.max_per_owner)
            if len(self._sessions) >= self.max_sessions:
                raise TooManySessions(
                    f"{len(self._sessions)} sessions are open (limit {self.max_sessions}); close one "
                    f"(DELETE /v1/sessions/{{id}}) or wait for idle ones to expire after {self.ttl_s:g} s",
                    retry_after_s=self._first_expiry(list(self._sessions.values()), now), limit=self.max_sessions,
                )
            s = Session(uuid.uuid4().hex, dict(context), client, now, now, owner=owner,
                        verification=verification or PairJudge())
            self._sessions[s.id] = s
            return s

    def _first_expiry(self, sessions: list[Session], now: float) -> float:
        return max(0.0, min(x.last_used for x in sessions) + self.ttl_s - now) if sessions else self.ttl_s

    def get(self, sid: str) -> Session:
        now = self.clock()
        with self._lock:
            s = self._sessions.get(sid)
            if s is None or now - s.last_used > self.ttl_s:
                self._sessions.pop(sid, None)
                raise NotFound(f"no session {sid!r} (never created, deleted, or expired after {self.ttl_s:g} s idle)")
            s.last_used = now
            self._sessions.move_to_end(sid)
            return s

    def delete(self, sid: str) -> None:
        with self._lock:
            if self._sessions.pop(sid, None) is None:
                raise NotFound(f"no session {sid!r}")

    def keep(self, session: Session, state: Any) -> None:
        """Store ``state`` as the session's previous frame, evicting LRU states past the memory bound."""
        size = state_bytes(state)
        with self._lock:
            session.state, session.state_bytes = state, size
            session.frames += 1
            if size > self.memory_bytes:
                session.state, session.state_bytes = None, 0
            total = sum(s.state_bytes for s in self._sessions.values())
            for other in list(self._sessions.values()):
                if total <= self.memory_bytes:
                    break
                if other is session or other.state is None:
                    continue
                total -= other.state_bytes
                other.state, other.state_bytes = None, 0
