"""``python -m nfex_slam …``: the replay client (same as the ``nfex-slam-replay`` script)."""
from __future__ import annotations

import sys

from .replay import main

sys.exit(main())
