"""The one file digest (F-POLICY-BUNDLE ``file_sha256``, T-RUN-DIR ``policy.sha256``).

A policy's module or script, a checkpoint and a run directory's policy file are identified by the
SHA-256 of their bytes, hex-encoded; every reader and writer of those fields computes it here.
"""

from __future__ import annotations

import hashlib
import os


def file_sha256(path: str | os.PathLike) -> str:
    """The SHA-256 of a file's bytes, read in chunks, as lowercase hex."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()
