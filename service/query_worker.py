"""A process that runs the SPARQL endpoint's queries, so that a query past its time limit can be stopped.

pyoxigraph cannot interrupt a query once it runs (a blocking operator — an aggregate, ORDER BY, GROUP BY over
a huge join — holds its thread until it ends), but a process can be killed. ``service/sparql_exec.py`` keeps a
few of these workers and kills one at its query's deadline. A worker reads a read-only *checkpoint* of the
embedded store (``Store.backup``: RocksDB hard links, made when the graph version moved): a second process may
not open the store the service writes.

The protocol, over the worker's standard input and output: a request is a 4-byte big-endian length and a JSON
object ``{"store", "query", "results", "graph", "default_graph", "max_bytes"}``; the answer a 4-byte length and
a JSON header ``{"ok": true, "kind": "solutions" | "triples", "size": n}`` followed by n bytes of serialised
results, or ``{"ok": false, "error": "syntax" | "result-size" | "store", "detail"}``. It imports pyoxigraph
alone, so a replacement for a killed worker starts in a fraction of a second.
"""
from __future__ import annotations

import json
import struct
import sys
from typing import Any, BinaryIO

import pyoxigraph as ox


class _Bounded:
    def __init__(self, max_bytes: int) -> None:
        self.chunks: list[bytes] = []
        self.size = 0
        self.max_bytes = max_bytes
        self.over = False

    def write(self, data: bytes) -> int:
        if self.size + len(data) > self.max_bytes:
            self.over = True
            raise OSError("the result exceeds its size limit")
        self.chunks.append(bytes(data))
        self.size += len(data)
        return len(data)

    def flush(self) -> None:
        pass


def read_message(stream: BinaryIO) -> bytes | None:
    head = stream.read(4)
    if len(head) < 4:
        return None
    (n,) = struct.unpack(">I", head)
    data = stream.read(n)
    return data if len(data) == n else None


def write_message(stream: BinaryIO, data: bytes) -> None:
    stream.write(struct.pack(">I", len(data)) + data)


def answer(stores: dict[str, ox.Store], request: dict[str, Any]) -> tuple[dict[str, Any], bytes]:
    path = request["store"]
    if path not in stores:
        stores.clear()  # the checkpoint moved on: drop the old one's files
        try:
            stores[path] = ox.Store.read_only(path)
        except OSError as e:
            return {"ok": False, "error": "store", "detail": f"cannot open the query checkpoint: {e}"}, b""
    options: dict[str, Any] = {}
    if request.get("default_graph"):
        options["default_graph"] = ox.NamedNode(request["default_graph"])
    sink = _Bounded(int(request["max_bytes"]))
    try:
        result = stores[path].query(request["query"], **options)
        if isinstance(result, ox.QueryTriples):
            kind = "triples"
            result.serialize(sink, format=ox.RdfFormat.from_media_type(request["graph"]))  # type: ignore[arg-type]
        elif isinstance(result, ox.QuerySolutions | ox.QueryBoolean):
            kind = "solutions"
            result.serialize(sink, format=ox.QueryResultsFormat.from_media_type(request["results"]))  # type: ignore[arg-type]
        else:  # pragma: no cover - pyoxigraph has no other result type
            raise TypeError(type(result).__name__)
    except SyntaxError as e:
        return {"ok": False, "error": "syntax", "detail": str(e)}, b""
    except OSError as e:
        if sink.over:
            return {"ok": False, "error": "result-size", "detail": ""}, b""
        return {"ok": False, "error": "store", "detail": str(e)}, b""
    body = b"".join(sink.chunks)
    return {"ok": True, "kind": kind, "size": len(body)}, body


def main() -> None:
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    stores: dict[str, ox.Store] = {}
    while True:
        message = read_message(stdin)
        if message is None:
            return
        header, body = answer(stores, json.loads(message))
        write_message(stdout, json.dumps(header).encode())
        stdout.write(body)
        stdout.flush()


if __name__ == "__main__":
    main()
