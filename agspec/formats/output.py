"""Every result agspec writes goes through here (spec/09-formats.md, F-OUTPUT-FAILURES).

* A whole file (``-o`` files, reproducers, golden traces, pages, run-directory files) is written to a
  temporary file in the target's directory and moved over the target with ``os.replace`` only once
  it is complete; on any failure the temporary file is removed. A reader never finds half a file
  under the target's name. A target that exists and is not a regular file (``/dev/stdout``, a FIFO)
  is written in place: it cannot be replaced.
* A stream (the JSON Lines reports, traces and results bundles written record by record, so an
  interrupted run keeps what it finished, CAMP-CANCEL) is written in place; each of those formats
  marks its own completeness (a footer, ``complete: true``), which a cut stream lacks.
* Standard output is wrapped (:func:`guard_stdout`) so a failed write names ``<stdout>``.

Every failure becomes one :class:`OutputError` naming the path and the operating system's reason;
``agspec.cli.main`` turns it into ``error: cannot write PATH: REASON`` and exit 2 (F-EXIT-CODES), or
exit 0 when standard output is a closed pipe (``| head``), as Unix tools do.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import stat
import sys
import tempfile
from pathlib import Path
from typing import IO, Any, Iterator

from agspec.campaign.task import RunFatal

STDOUT = "<stdout>"


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_MODE = 0o666 & ~_umask()  # what open(path, "w") would have given the file


class OutputError(RunFatal):
    """A result that cannot be written: ``path`` and the operating system's ``reason``; it ends the run
    (CAMP-FAULTS), from whichever worker met it."""

    def __init__(self, path: str | Path, exc: BaseException | str, errno_: int | None = None):
        self.path = str(path)
        self.errno = getattr(exc, "errno", None) if errno_ is None else errno_
        self.reason = (getattr(exc, "strerror", None) or str(exc)) if not isinstance(exc, str) else exc
        super().__init__(f"cannot write {self.path}: {self.reason}")

    def __reduce__(self):
        return OutputError, (self.path, self.reason, self.errno)

    @property
    def closed_pipe(self) -> bool:
        """Standard output's reader went away (``| head -1``): not an error (F-OUTPUT-FAILURES)."""
        return self.path == STDOUT and self.errno == errno.EPIPE


def _in_place(path: Path) -> bool:
    """A target that exists and is neither a regular file nor a directory (a device, a FIFO)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return False
    return not (stat.S_ISREG(mode) or stat.S_ISDIR(mode))


def _remove(tmp: str | None) -> None:
    if tmp is not None:
        with contextlib.suppress(OSError):
            os.unlink(tmp)


@contextlib.contextmanager
def atomic_path(path: str | Path, stable: bool = False) -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix) to write to; moved over ``path`` when the block
    ends normally, removed otherwise. An OSError inside the block or in the move is an OutputError.
    ``stable``: the temporary name is ``NAME.tmp``, for writers whose bytes depend on the file name
    (torch.save names its archive after it, and a policy file's digest must not vary)."""
    path = Path(path)
    if path.is_symlink():  # the link's target is replaced, the link stays
        path = Path(os.path.realpath(path))
    if path.is_dir():
        raise OutputError(path, OSError(errno.EISDIR, os.strerror(errno.EISDIR)))
    if _in_place(path):
        try:
            yield path
        except OSError as exc:
            raise OutputError(path, exc) from None
        return
    tmp = None
    try:
        if stable:
            tmp = str(path.with_name(path.name + ".tmp"))
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600))
        else:
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=f".tmp{path.suffix}")
            os.close(fd)
        yield Path(tmp)
        os.chmod(tmp, _MODE)
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        raise OutputError(path, exc) from None
    finally:
        _remove(tmp)


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w") -> Iterator[IO[Any]]:
    """A file opened for writing that appears under ``path`` complete, or not at all."""
    with atomic_path(path) as tmp:
        with open(tmp, mode, **({} if "b" in mode else {"encoding": "utf-8"})) as fh:
            yield fh


def write_text(path: str | Path, text: str) -> Path:
    with atomic_open(path) as fh:
        fh.write(text)
    return Path(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def make_dir(path: str | Path) -> Path:
    """``mkdir -p`` of an output directory, then a probe that a file can be created in it (a missing
    parent is created; a file in the way, a read-only or a full file system is an OutputError)."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path) as probe:
            probe.write(b"\n")
            probe.flush()
    except OSError as exc:
        raise OutputError(path, exc) from None
    return path


class Stream:
    """A file written record by record in place (flushed each time), for formats that mark their own
    completeness; an OSError on open, write or close is an OutputError naming the path."""

    def __init__(self, path: str | Path, mode: str = "w"):
        self.path = Path(path)
        if self.path.is_dir():
            raise OutputError(self.path, OSError(errno.EISDIR, os.strerror(errno.EISDIR)))
        try:
            self._fh: IO[str] | None = open(self.path, mode, encoding="utf-8")
        except OSError as exc:
            raise OutputError(self.path, exc) from None

    def write(self, text: str) -> None:
        if self._fh is None:
            raise OutputError(self.path, "the stream is closed")
        try:
            self._fh.write(text)
            self._fh.flush()
        except OSError as exc:
            self.abandon()
            raise OutputError(self.path, exc) from None

    def flush(self) -> None:
        pass  # every write is flushed

    def close(self) -> None:
        fh, self._fh = self._fh, None
        if fh is not None:
            try:
                fh.close()
            except OSError as exc:
                raise OutputError(self.path, exc) from None

    def abandon(self) -> None:
        """Close without raising (after a failure, or on an interrupted run)."""
        fh, self._fh = self._fh, None
        if fh is not None:
            with contextlib.suppress(OSError):
                fh.close()


class _GuardedStdout(io.TextIOBase):
    """sys.stdout whose write and flush failures are OutputErrors naming ``<stdout>``; with standard
    output closed (Python leaves ``sys.stdout`` None) every write fails with EBADF."""

    def __init__(self, raw: IO[str] | None):
        self._raw = raw

    def _fail(self, exc: OSError) -> OutputError:
        return OutputError(STDOUT, exc)

    def write(self, text: str) -> int:
        if self._raw is None:
            raise self._fail(OSError(errno.EBADF, os.strerror(errno.EBADF)))
        try:
            return self._raw.write(text)
        except OSError as exc:
            raise self._fail(exc) from None
        except ValueError as exc:  # "I/O operation on closed file"
            raise OutputError(STDOUT, str(exc)) from None

    def flush(self) -> None:
        if self._raw is None:
            return
        try:
            self._raw.flush()
        except OSError as exc:
            raise self._fail(exc) from None

    def writable(self) -> bool:
        return True

    def isatty(self) -> bool:
        return self._raw is not None and self._raw.isatty()

    def fileno(self) -> int:
        if self._raw is None:
            raise io.UnsupportedOperation("standard output is closed")
        return self._raw.fileno()

    @property
    def encoding(self) -> str:  # type: ignore[override]
        return getattr(self._raw, "encoding", None) or "utf-8"

    @property
    def errors(self) -> str | None:  # type: ignore[override]
        return getattr(self._raw, "errors", None)

    @property
    def buffer(self) -> Any:
        if self._raw is None:
            raise AttributeError("buffer")
        return self._raw.buffer

    def __getattr__(self, name: str) -> Any:
        return getattr(self._raw, name)


def guard_stdout() -> None:
    """Route sys.stdout through :class:`_GuardedStdout` (idempotent)."""
    if not isinstance(sys.stdout, _GuardedStdout):
        sys.stdout = _GuardedStdout(sys.stdout)


def silence_stdout() -> None:
    """After a failed write on standard output: point file descriptor 1 at /dev/null, so what Python
    still holds in its buffer cannot fail again at exit."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.close(devnull)


__all__ = ["OutputError", "STDOUT", "atomic_path", "atomic_open", "write_text", "write_bytes", "make_dir", "Stream",
           "guard_stdout", "silence_stdout"]
