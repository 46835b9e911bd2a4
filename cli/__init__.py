"""The ``nfex`` command line: one thin module per command group over nfex_core.

Errors print one line on stderr and exit with the kind's code (nfex_core.errors); ``--debug`` adds the
traceback. This package is the only place in nfex_core that imports typer; library modules never
import it.
"""
