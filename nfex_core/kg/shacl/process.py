"""pySHACL in a process of its own, so that validating a write does not hold the service's interpreter lock.

pySHACL is pure Python. In the service, a commit's validation (``validation.validate_change``: the focus
nodes' neighbourhood read from the store, then pySHACL on it) shares one interpreter lock with the event loop
answering selections and with the background compile; with three threads wanting it, each gets about a third,
so a report batch waited about three times its validation's CPU time (``bench/bench_fleet.py`` with the
validation skipped, a probe: reports/s doubled). ``ShaclProcess`` runs the pySHACL part in one worker process:

    parent: neighbourhood read from the store (validation.py) ─► worker: pySHACL on those triples, with the
            shapes graph it keeps by token ─► parent: the results and the report text, as in-process

The worker keeps pySHACL's shapes graph (``Shapes.pyshacl_graph``) of the shapes it was last sent, by
``Shapes.token``; a commit sends only its data triples and focus nodes (a few hundred triples pickled), and
the shapes once per new ``Shapes`` (the first validation after an edit of the shapes, or ``warm``). The
verdict is the in-process one: the same function (``validation.run_pyshacl``) runs on the same triples;
``tests/nfex_core/kg/shacl/test_process.py`` compares the two on random changes.

The worker is a Python process running ``main`` here, spoken to over its stdin and stdout (length-prefixed
pickles; it is this process's own child). Not ``multiprocessing``: its spawn re-imports the parent's main
module, which breaks a user's script without a ``__main__`` guard.

A worker that cannot start or dies is not an outage: the validation under way runs in this process, with a
warning, and the next one starts a new worker. The CLI's one-shot writes validate in process (a worker's
start, ~1 s of imports, would cost more than it saves); the service starts one (``NFEX_SHACL_PROCESS``).
"""
from __future__ import annotations

import logging
import os
import pickle
import struct
import subprocess
import sys
import threading
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from ...errors import BadInput, ValidationResult
from ..rdf.terms import Triple

if TYPE_CHECKING:
    from rdflib.term import Node

    from .validation import Shapes

log = logging.getLogger("nfex.kg")

_KEEP = 2  # shapes graphs a worker keeps (the current one, and the one before an edit of the shapes)
_kept: dict[str, Shapes] = {}  # in the worker: token → Shapes, oldest first
_FRAME = struct.Struct("!Q")


def _send(stream: IO[bytes], message: object) -> None:
    data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_FRAME.pack(len(data)) + data)
    stream.flush()


def _receive(stream: IO[bytes]) -> Any:
    """The next message, or EOFError when the other side has gone."""
    head = stream.read(_FRAME.size)
    if len(head) < _FRAME.size:
        raise EOFError("the other side closed the pipe")
    size = _FRAME.unpack(head)[0]
    data = stream.read(size)
    if len(data) < size:
        raise EOFError("the other side closed the pipe mid-message")
    return pickle.loads(data)


Sent = tuple[Sequence[tuple[str, str]], Sequence[Triple]]  # a shapes graph as sent: its prefixes and its triples


def _sent(shapes: Shapes) -> Sent:
    """The prefixes go too: pySHACL writes a result's message with the shapes graph's (``nfex:Parameter``)."""
    return [(p, str(ns)) for p, ns in shapes.graph.namespaces()], list(shapes.graph)


def _in_worker(token: str, shapes: Sent | None, data: Sequence[Triple], focus: Collection[Node]) -> tuple[str, Any]:
    """The worker's side: ("shapes", None) when it lacks the shapes of ``token`` and was not sent them,
    ("error", message) where pySHACL cannot validate with them, else ("ok", (results, text))."""
    import rdflib

    from .validation import Shapes, run_pyshacl

    found = _kept.get(token)
    if found is None:
        if shapes is None:
            return "shapes", None
        g = rdflib.Graph(bind_namespaces="none")
        prefixes, triples = shapes
        for prefix, ns in prefixes:
            g.bind(prefix, ns, override=True, replace=True)
        for t in triples:
            g.add(t)
        found = _kept[token] = Shapes(g, frozenset())
        while len(_kept) > _KEEP:
            del _kept[next(iter(_kept))]
    try:
        return "ok", run_pyshacl(data, found, set(focus))
    except BadInput as e:
        return "error", str(e)
    except Exception as e:  # the parent runs it again in its own process, which raises what pySHACL raises
        return "failed", f"{type(e).__name__}: {e}"


def main() -> None:
    """The worker: answers each request on stdin on stdout until stdin closes."""
    requests = sys.stdin.buffer
    # the replies get a descriptor of their own; fd 1 becomes stderr's, so that nothing a library writes to
    # standard output, from Python or from C, lands among them
    replies = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    from . import validation  # noqa: F401  (pySHACL and rdflib's SPARQL, imported before the first request)

    _send(replies, ("ready", str(Path(__file__).resolve().parents[2])))  # which nfex_core it imported
    while True:
        try:
            request = _receive(requests)
        except EOFError:
            return
        _send(replies, _in_worker(*request))


class ShaclProcess:
    """pySHACL in one worker process (the module's docstring); ``run`` stands in for ``validation.run_pyshacl``."""

    def __init__(self) -> None:
        self._proc: subprocess.Popen[bytes] | None = None
        self._lock = threading.Lock()  # one request at a time: the worker answers in order
        self._closed = False
        self.fallbacks = 0  # validations that ran in this process because the worker failed (tests, logs)
        self.starts = 0
        self.worker_package: str | None = None  # the nfex_core folder the last worker imported (the parent's, by -P)

    def _worker(self) -> subprocess.Popen[bytes]:
        """The running worker, started if there is none (under ``_lock``)."""
        if self._proc is not None and self._proc.poll() is None:
            return self._proc
        self._stop()
        root = str(Path(__file__).resolve().parents[3])  # where nfex_core is importable from, installed or not
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")])))
        # -P: not the working directory first on the path, so the worker imports the nfex_core this process runs
        proc = subprocess.Popen([sys.executable, "-P", "-c", "from nfex_core.kg.shacl.process import main; main()"], stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, env=env)
        self._proc = proc
        self.starts += 1
        assert proc.stdout is not None
        _, self.worker_package = _receive(proc.stdout)  # "ready": imports done
        return proc

    def _stop(self) -> None:
        proc, self._proc = self._proc, None
        if proc is None:
            return
        for stream in (proc.stdin, proc.stdout):
            if stream is not None:
                stream.close()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()

    def _ask(self, token: str, shapes: Shapes, data: list[Triple], focus: list[Node]) -> tuple[str, Any]:
        proc = self._worker()
        assert proc.stdin is not None and proc.stdout is not None
        _send(proc.stdin, (token, None, data, focus))
        status, out = _receive(proc.stdout)
        if status == "shapes":
            _send(proc.stdin, (token, _sent(shapes), data, focus))
            status, out = _receive(proc.stdout)
        return status, out

    def warm(self, shapes: Shapes | None = None) -> None:
        """Start the worker and, given ``shapes``, hand it their shapes graph (the service's warm-up)."""
        with self._lock:
            if self._closed:
                return
            try:
                if shapes is None:
                    self._worker()
                else:
                    self._ask(shapes.token, shapes, [], [])
            except Exception as e:
                log.warning("the SHACL process did not start (%s); writes validate in this process until one does", e)
                self._stop()

    def run(self, data: Collection[Triple], shapes: Shapes, focus: Collection[Node]) -> tuple[list[ValidationResult], str]:
        """pySHACL on ``data`` with ``shapes``, judging the targets among ``focus``: in the worker, or here when it fails."""
        from .validation import run_pyshacl

        triples = list(data)
        with self._lock:
            if self._closed:
                return run_pyshacl(triples, shapes, set(focus))
            try:
                status, out = self._ask(shapes.token, shapes, triples, list(focus))
            except Exception as e:  # a worker that died, or answers what this process cannot read
                self.fallbacks += 1
                log.warning("the SHACL process failed (%s); this validation runs in this process, the next one "
                            "starts a new worker", e)
                self._stop()
                return run_pyshacl(triples, shapes, set(focus))
        if status == "error":
            raise BadInput(out)
        if status == "failed":  # pySHACL itself failed there: here it fails the same way, with its own exception
            log.warning("pySHACL failed in the SHACL process (%s); validating in this process", out)
            return run_pyshacl(triples, shapes, set(focus))
        results, text = out
        return list(results), str(text)

    def status(self) -> dict[str, Any]:
        """For /readyz: whether a worker runs, how many were started, how many validations fell back."""
        proc = self._proc
        return {"running": proc is not None and proc.poll() is None, "starts": self.starts, "fallbacks": self.fallbacks}

    def close(self) -> None:
        """No more validations in the worker; a validation under way there is cut short (it runs here instead)."""
        self._closed = True
        proc = self._proc
        if proc is not None and proc.poll() is None:
            proc.kill()  # a request waiting on it gets EOF at once, rather than holding the lock until pySHACL ends
        with self._lock:
            self._stop()

