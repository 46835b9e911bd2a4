"""The vocabulary read from the graph (``vocab.py``, its value types ``specs.py``) and the ontology as OWL
tools and readers see it (``owl.py``: the graph without its shapes; ``docs.py``: the HTML documentation)."""
