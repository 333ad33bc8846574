"""What a conformance worker process was doing when it died (CAMP-FAULTS, F-PROTOCOL-ERRORS).

With ``-j N`` each worker runs items against its own simulator.  A worker that dies mid-item (killed,
``os._exit``) leaves no result; the executor reports the item as failed.  Whose fault it was, the
harness can tell in one case: the worker died while it was running an item against a simulator it
had started — a simulator process that is its child (and may signal its parent or its parent's
process group) or an in-process adapter whose code runs inside the worker.  Each worker therefore
keeps a marker file, ``{pid}.json`` in a directory of the run, naming the item and the simulator
while the item runs; a marker left by a dead worker is the evidence (:func:`blame`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from agspec.formats import output

CODE = "harness_killed"  # F-PROTOCOL-ERRORS, category crash


def mark(directory: str, item_id: str, impl: Any) -> Path:
    """Record that this process now runs ``item_id`` against ``impl`` (one small file per worker)."""
    proc = getattr(impl, "proc", None)
    kind = type(impl).__name__
    record = {"item": item_id, "worker": os.getpid(), "spec": getattr(impl, "spec", ""),
              "simulator": "process" if kind == "SubprocessImpl" else "adapter" if kind == "PythonImpl" else None,
              "simulator_pid": proc.pid if proc is not None else None}
    return output.write_text(Path(directory) / f"{os.getpid()}.json", json.dumps(record))  # F-OUTPUT-FAILURES


def clear(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def blame(directory: str | None, item_id: str) -> dict[str, Any] | None:
    """The failure to report for ``item_id`` whose worker died, when the worker died while running it
    against a simulator it had started (None: the harness cannot tell, a ``harness/worker`` error)."""
    if not directory:
        return None
    for path in sorted(Path(directory).glob("*.json")):
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if record.get("item") != item_id or _alive(int(record.get("worker") or 0)):
            continue
        if record.get("simulator") is None:  # the reference: agspec's own code ran
            continue
        pid = record.get("simulator_pid")
        what = ("its in-process adapter" if record["simulator"] == "adapter"
                else "the simulator process it started" + (f" (pid {pid})" if pid else ""))
        message = (f"the harness worker (pid {record['worker']}) running {item_id} died while {what} was running "
                   f"`{record.get('spec', '')}`: a simulator must not signal or exit the harness")
        return {"type": "crash", "code": CODE, "message": message, "tick": None}
    return None


__all__ = ["CODE", "mark", "clear", "blame"]
