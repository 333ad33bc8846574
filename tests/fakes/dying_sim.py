"""An in-process simulator (``--impl python:tests/fakes/dying_sim.py:make``) that kills the process
running it when it loads a chosen instance — the campaign worker dies mid-item (CAMP-RETRY).

``AGSPEC_TEST_DIE_ONCE=<instance id>``: dies on the first load of that instance in any process (a
marker file in ``AGSPEC_TEST_DIE_MARKERS`` remembers); ``AGSPEC_TEST_DIE_ALWAYS=<instance id>``:
dies on every load of it.  Otherwise it is the reference behind the protocol.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from agspec.conform.impl.serve import Server


class DyingServer(Server):
    def handle(self, msg: Any) -> dict[str, Any]:
        if isinstance(msg, dict) and msg.get("cmd") == "load":
            ident = (msg.get("instance") or {}).get("id")
            if ident == os.environ.get("AGSPEC_TEST_DIE_ALWAYS"):
                os._exit(17)
            if ident == os.environ.get("AGSPEC_TEST_DIE_ONCE"):
                marker = Path(os.environ["AGSPEC_TEST_DIE_MARKERS"]) / f"died-{ident}"
                if not marker.exists():
                    marker.write_text("x")
                    os._exit(17)
        return super().handle(msg)


def make() -> DyingServer:
    return DyingServer()
