"""Training ParamNet and SelectorNet (§IV-B): the sweep table read as windows (``dataset``), the training loop
(``train``), leave-one-sequence-out validation (``validation``) and the torch twins of the NumPy nets
(``torch_nets``). torch is imported inside the functions that train, never on import.

Serving never imports this package: ``neural/`` above it holds what a selection runs (``serve``, ``artifacts``,
``encoding`` and the nets' NumPy inference), and pyproject.toml's import contracts keep it that way.
"""
