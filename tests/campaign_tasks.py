"""Tasks for the executor tests (spec chapter 14): module-level so that workers can run them.

``slow_square`` finishes the items in reverse order of their index; ``dies`` kills its worker
process (once per marker file, or always); ``holds_a_child`` starts a child process per worker, like
a simulator under test, and ``stop_child`` stops it when the worker closes.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path


def slow_square(context, item):
    time.sleep(0.02 * (8 - item % 8))  # later items finish first
    return {"item": item, "square": item * item, "context": context}


def dies(context, item):
    """Items named 'die-once' kill their worker the first time (a marker file remembers), items
    named 'die' always; 'raise' raises; others return."""
    name, marker_dir = item
    if name == "die-once":
        marker = Path(marker_dir) / "died"
        if not marker.exists():
            marker.write_text("x")
            os._exit(17)
    if name == "die":
        time.sleep(0.2)
        os._exit(17)
    if name == "raise":
        raise ValueError("bad item")
    time.sleep(0.05)
    return name


def holds_a_child(shared):
    """Per worker: a long-running child in its own session (as the subprocess adapter starts a
    simulator); its pid is written where the test can see it."""
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"], start_new_session=True)
    Path(shared, f"child-{child.pid}").write_text(str(os.getpid()))
    return child


def stop_child(child):
    child.kill()
    child.wait()


def sleeps(child, item):
    time.sleep(item)
    return item
