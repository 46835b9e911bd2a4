"""RDF's ground, below everything else in ``kg``: the namespaces (``namespaces.py``), every IRI nFEX mints
(``identity.py``), terms converted across pyoxigraph, SPARQL results and text (``terms.py``), and rdflib's
SPARQL parser taken one caller at a time (``rdflib_sparql.py``)."""
