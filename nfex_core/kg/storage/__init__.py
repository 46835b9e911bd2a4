"""Where the triples live and how a version is written: the backends (``backend_api.py``, ``backends.py``:
embedded Oxigraph; ``remote.py``, ``protocol.py``: a SPARQL 1.1 server), change sets (``changes.py``), the
version history and the writers' claims on it (``history.py``, ``claims.py``, ``batch.py``), and SPARQL before
and beside a store: the gate (``sparql_gate.py``, ``sparql_query.py``), an update's change set and reach
(``sparql_update.py``, ``update_reach.py``), and what a query can read (``footprint.py``)."""
