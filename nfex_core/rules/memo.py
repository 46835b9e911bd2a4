"""What a published rule table's requests derive per context, kept beside the table and not in it.

A context's first request aggregates the decision's evidence (``RuleTable.decide``) and ranks the measured
configurations (``RuleTable.measured``). It computes them into values of its own and then *publishes* them here
in one step under a lock: the first value published for a key is the one every later request gets (a second
thread that computed the same key meanwhile takes it and drops its own, which is equal). Requests read without
the lock; a dictionary read sees a key either absent or with its published value (CPython's ``dict.get`` is
atomic). The table's own fields (``decisions``, the observations) are never written after the compile, so
concurrent first requests for different contexts answer as sequential ones would and leave the table as it was
(tests/nfex_core/rules/test_memo.py; bench/bench_table_memo.py measures the lock against none).

``made`` keeps what was made of each group of observations per (context, extractor[, configuration]), with the
group it was made from, so that the next version's table takes over what the same (untouched) group gives
(``RuleTable.made_before``). At most ``MAX_MADE`` entries are kept: past it, what is made is not kept (memory
stays bounded, answers the same).
"""
from __future__ import annotations

import threading
from collections.abc import Hashable, Mapping
from contextlib import AbstractContextManager
from typing import Any, TypeVar

MAX_MADE = 100_000  # entries of ``ContextMemo.made``: contexts asked × extractors × measured configurations
V = TypeVar("V")


class ContextMemo:
    """Per-context values published once (module docstring). ``lock``: the guard of a publication (a
    ``threading.Lock`` unless a benchmark gives another)."""

    def __init__(self, lock: AbstractContextManager[Any] | None = None, max_made: int = MAX_MADE) -> None:
        self._lock = lock if lock is not None else threading.Lock()
        self.max_made = max_made
        self.decided: dict[Hashable, Any] = {}  # context key → Decision with its evidence
        self.measured: dict[Hashable, Any] = {}  # context key → extractor → measured configurations, best first
        self.made: dict[Hashable, tuple[object, Any]] = {}  # (context, extractor[, configuration]) → (source, value)

    def publish(self, into: dict[Hashable, Any], key: Hashable, value: V, made: Mapping[Hashable, Any]) -> V:
        """Publish ``value`` under ``key`` in ``into`` (``decided`` or ``measured``) and what was ``made`` on the way;
        returns the value published first for ``key``."""
        with self._lock:
            for k, v in made.items():
                if len(self.made) >= self.max_made:
                    break
                self.made.setdefault(k, v)
            out: V = into.setdefault(key, value)
        return out

    def __len__(self) -> int:
        return len(self.decided) + len(self.measured)

    def __reduce__(self) -> tuple[type[ContextMemo], tuple[()]]:
        """A pickled table (rules/persisted.py) carries an empty memo: what requests derive is made again."""
        return ContextMemo, ()
