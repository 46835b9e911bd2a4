"""SHACL validation of a write on the nodes it touches: the candidate state read around them
(``candidate.py``), the shapes graph and its footprint (``shapes.py``), pySHACL on the focus nodes
(``pyshacl_focus.py``), in a worker process (``process.py``), and the validation of a change or of the whole
graph (``validation.py``)."""
