"""The ``nfex`` command line: one thin module per command group over nfex_core, beside the service.

Errors print one line on stderr and exit with the kind's code (nfex_core.errors); ``--debug`` adds the
traceback. This package and the service are the edges: nfex_core imports neither, nor typer
(pyproject.toml's import contracts).
"""
