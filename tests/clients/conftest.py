"""The client tests reuse the service fixtures; nfex_client is imported from clients/python when not installed."""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent.parent
try:
    import nfex_client  # noqa: F401
except ModuleNotFoundError:
    sys.path.insert(0, str(ROOT / "clients" / "python"))

from tests.service.conftest import remote_service, service, sparql_store  # noqa: E402,F401
