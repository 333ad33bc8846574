"""Implementations under test: one Python interface, three adapters (F-PROTOCOL).

``--impl reference``                 :class:`ReferenceImpl`, the built-in interpreter, in process;
``--impl python:pkg.module:factory`` :class:`PythonImpl`; ``factory()`` returns an object with
                                     ``handle(msg) -> reply`` taking and returning the protocol's
                                     messages as dicts (``pkg.module`` may also be a ``.py`` path);
``--impl "CMD ARGS"``                :class:`SubprocessImpl`, a process speaking JSON Lines on
                                     stdin/stdout (``shlex.split``, never a shell).

Every adapter offers ``start() -> info``, ``load(instance)``, ``reset(seed) -> reply``,
``step(actions) -> reply`` and ``close()``; a reply is a dict with ``t``, ``state``, ``events`` and,
as declared by the capabilities, ``observations``, ``masks``, ``done`` and ``applied``.  Failures
raise :class:`~agspec.conform.protocol.ProtocolError` (category ``crash``, ``timeout`` or
``protocol``; F-PROTOCOL-ERRORS).  After a failure the adapter restarts on next use and replays its
session commands (``start``, then ``load`` of the current instance), as Bowtie does, so one crashing
or hanging case never takes the following ones down.
"""

from __future__ import annotations

import collections
import copy
import importlib
import importlib.util
import json
import os
import queue
import shlex
import signal
import subprocess
import sys
import threading
import time
import traceback
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from agspec.conform import protocol, teardown
from agspec.conform.protocol import ProtocolError
from agspec.conform.pipeline import Pipeline
from agspec.conform.serve import Server
from agspec.conform.session import Budget, RequestLog
from agspec.formats import golden as golden_format
from agspec.formats import jsonl
from agspec.formats import reply as reply_format

Reply = dict[str, Any]
# F-GOLDEN: a reply line that is byte for byte the golden one (returned instead of the decoded reply)
MATCHED: Any = type("Matched", (), {"__repr__": lambda self: "MATCHED", "__slots__": ()})()
# on_message(direction "->" or "<-", cmd, message) — for --validate-protocol and transcripts
MessageHook = Callable[[str, str, Any], None]


class ImplSpecError(ValueError):
    """``--impl`` names nothing that can be run (usage error, exit 2)."""


class Implementation:
    """Common protocol session logic: seq numbering, reply checks, schema validation, restart."""

    spec: str = ""
    # replies built by agspec itself (the reference interpreter in process): not decoded, their shape
    # not checked (F-PROTOCOL-SHAPE; a test holds the reference's replies to it)
    trusted: bool = False

    def __init__(self, *, validate: bool = False, on_message: MessageHook | None = None):
        self.validate = validate
        self.on_message = on_message
        self.info: dict[str, Any] = {}
        self.capabilities: dict[str, bool] = {}
        self._seq = 0
        self._instance: Mapping[str, Any] | None = None
        self._alive = False
        self.last_reply: Reply | None = None
        self.restarts = 0
        self.start_timeout: float | None = None  # the start request may take longer (process start-up)
        self.budget = Budget()  # RES-GIVE-UP-SCOPE (max_restarts None: never give up)
        self.requests = RequestLog()  # F-REPRO: the requests of the current process

    # ---------------------------------------------------------------- transport (subclasses)

    def _open(self) -> None:
        """Make the transport ready (spawn a process, build the adapter)."""

    def _exchange(self, msg: dict[str, Any], timeout: float | None) -> Any:
        """Send ``msg`` and return the reply: its line (a process) or its object (in process); raise
        ProtocolError when there is none."""
        raise NotImplementedError

    def _shutdown(self) -> None:
        """Release the transport."""

    def stderr_tail(self) -> str:
        return ""

    # ---------------------------------------------------------------- requests

    def _next_seq(self) -> int:
        self._seq += 1
        return self._seq

    def _request(self, cmd: str, golden: tuple[str, str] | None = None, **fields: Any) -> Reply:
        """One request and its checked reply.  With ``golden`` (the F-GOLDEN digests of the reply the
        reference gave), a reply line whose exact text has the golden digest is :data:`MATCHED`
        without being decoded — it is the golden reply byte for byte; any other reply is decoded
        and checked as always."""
        msg = protocol.request(cmd, self._next_seq(), **fields)
        self.requests.record(cmd, fields)
        if self.on_message:
            self.on_message("->", cmd, msg)
        if self.validate:
            problems = protocol.validate_request(msg)
            if problems:  # a request we built is wrong: an agspec bug, reported loudly
                raise ProtocolError("schema", f"the harness's own {cmd} request violates its schema: {problems[0]}")
        # start and load may build a whole model (interpreter start-up, instance compilation)
        return self._finish(msg, lambda: self._exchange(msg, self.start_timeout if cmd in ("start", "load") else None),
                            golden)

    @property
    def max_restarts(self) -> int | None:
        return self.budget.limit

    @max_restarts.setter
    def max_restarts(self, limit: int | None) -> None:
        self.budget.limit = limit

    def _finish(self, msg: dict[str, Any], receive: Callable[[], Any], golden: tuple[str, str] | None) -> Reply:
        """The reply to ``msg`` (``receive()`` waits for it): MATCHED, or decoded and checked; a failure
        ends the session (the next request restarts it)."""
        cmd = msg["cmd"]
        try:
            raw = receive()
            # F-GOLDEN: only a line the one decoder accepts can have the golden text digest
            # (RES-GOLDEN-IDENTITY: the golden line itself passed decode_line and check_reply)
            if golden is not None and _golden_text(raw, msg["seq"]) == golden[0]:
                return MATCHED
            reply = self._decoded(msg, raw)
            if self.on_message:
                self.on_message("<-", cmd, reply)
            if self.validate:
                problems = protocol.validate_reply(cmd, reply)
                if problems:
                    raise ProtocolError("schema", f"the {cmd} reply violates schemas/protocol/{cmd}.reply.schema.json: "
                                        + "; ".join(str(p) for p in problems[:3]), detail=[str(p) for p in problems],
                                        pointer=problems[0].pointer)
            if self.trusted:
                protocol.check_outcome(cmd, reply, self.capabilities if cmd != "start" else None)
            else:
                protocol.check_reply(cmd, reply, self.capabilities if cmd != "start" else None)
        except ProtocolError as exc:
            if not exc.stderr:
                exc.stderr = self.stderr_tail()
            # an `ok: false` answer to load or reset leaves the session in step (nothing else is in
            # flight): the simulator answered, so it keeps running (F-PROTOCOL, timing and isolation)
            if not (exc.code == "error_reply" and cmd in ("load", "reset")):
                self.budget.failed(cmd, exc)
                self._fail()
            raise
        except protocol.Unsupported:  # a declined instance: the session goes on (F-PROTOCOL-UNSUPPORTED)
            raise
        except BaseException:  # never leave a session whose replies are out of step with its requests
            self._fail()
            raise
        self.last_reply = reply  # what a resumed run mirrors (F-GOLDEN)
        return reply

    def pipeline(self, steps: Sequence[tuple[Mapping[str, int], tuple[str, str]]]) -> Pipeline:
        """F-GOLDEN: ``step`` requests (actions, golden digests) answered in order; in process one at a time."""
        self._ensure()
        return Pipeline(self, steps, window=1)

    def exchange(self, msg: dict[str, Any], timeout: float | None) -> Reply:
        """Send one message and return its decoded reply (seq checked, nesting bounded), without the
        protocol's reply checks — for peers that speak another message set over the same transport
        (F-POLICY-PROTOCOL)."""
        reply = self._decoded(msg, self._exchange(msg, timeout))
        if jsonl.depth(reply) > jsonl.MAX_DEPTH:
            raise ProtocolError("too_deep", f"the {msg['cmd']} reply nests deeper than {jsonl.MAX_DEPTH} levels",
                                stderr=self.stderr_tail())
        return reply

    def _decoded(self, msg: Mapping[str, Any], raw: Any) -> Reply:
        """The reply object of what ``_exchange`` returned: a line (bytes; text is encoded first) goes
        through the one decoder (:func:`agspec.formats.reply.decode_line`); either must be an object
        echoing the request's seq.  Its nesting is bounded by the shape check that follows."""
        if isinstance(raw, str):
            raw = _line_of(raw, msg["cmd"], self.stderr_tail)
        if isinstance(raw, bytes):
            raw = _decode(raw, msg["cmd"], self.stderr_tail)
        if not isinstance(raw, dict):
            raise ProtocolError("malformed_json", f"the {msg['cmd']} reply is not a JSON object but "
                                                  f"{protocol.json_type(raw)}", stderr=self.stderr_tail())
        _check_seq(msg, raw, self._seq)
        return raw

    def _fail(self) -> None:
        """Forget the session after a failure: the next request restarts it."""
        if self._alive:
            self._alive = False
            try:
                self._shutdown()
            except Exception:
                pass

    # ---------------------------------------------------------------- session

    def start(self) -> dict[str, Any]:
        """Open the transport and hand-shake (``start``); returns the start reply (``info``)."""
        if self._alive:
            return self.info
        self.budget.check_start(self.spec)
        if self.info:
            self.restarts += 1
        self.requests.clear()  # a new process (or adapter) has no history
        try:
            self._open()
        except ProtocolError as exc:
            self.budget.failed("start", exc)
            raise
        self._alive = True
        reply = self._request("start", protocol=protocol.PROTOCOL)
        self.budget.started()
        self.info = {k: v for k, v in reply.items() if k not in ("seq", "ok")}
        self.capabilities = protocol.normalize_capabilities(reply.get("capabilities"))
        return self.info

    def _ensure(self) -> None:
        if not self._alive:
            self.start()
            if self._instance is not None:  # replay the session after a restart
                self._request("load", instance=self._instance)

    def load(self, instance: Mapping[str, Any]) -> None:
        self.budget.check_instance(instance, self.spec)
        if not self._alive:
            self.start()
        self._instance = None
        self._request("load", instance=instance)
        self._instance = instance

    def reset(self, execution_seed: int | None, golden: tuple[str, str] | None = None) -> Reply:
        self._ensure()
        return self._request("reset", golden, execution_seed=execution_seed)

    def step(self, actions: Mapping[str, int], golden: tuple[str, str] | None = None) -> Reply:
        self._ensure()
        return self._request("step", golden, actions=dict(actions))

    def close(self) -> None:
        if self._alive:
            try:
                self._request("stop")
            except ProtocolError:
                pass
        self._alive = False
        try:
            self._shutdown()
        except Exception:
            pass

    def describe(self) -> dict[str, Any]:
        """For reports: the spec, and what the implementation said about itself."""
        return {"spec": self.spec, **{k: v for k, v in self.info.items() if k in ("implementation", "capabilities", "protocol")}}

    def __enter__(self) -> "Implementation":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


# ============================================================================================ in process


class PythonImpl(Implementation):
    """An in-process adapter: ``factory()`` returns an object with ``handle(msg) -> reply``.

    Messages are passed as dicts; each request is a deep copy and each reply goes through a JSON
    round trip (``isolate``), so an adapter cannot alias harness data and must answer plain JSON.
    """

    def __init__(self, factory: Callable[[], Any], spec: str = "python", *, isolate: bool = True, **kw: Any):
        super().__init__(**kw)
        self.factory = factory
        self.spec = spec
        self.isolate = isolate
        self.adapter: Any = None
        self._errors: list[str] = []

    def _open(self) -> None:
        try:
            self.adapter = self.factory()
        except Exception as exc:
            raise ProtocolError("exception", f"the adapter factory raised {type(exc).__name__}: {exc}",
                                stderr=traceback.format_exc())
        if not callable(getattr(self.adapter, "handle", None)):
            raise ProtocolError("exception", f"the adapter {type(self.adapter).__name__} has no handle(msg) method")

    def _exchange(self, msg: dict[str, Any], timeout: float | None) -> Any:
        try:
            reply = self.adapter.handle(copy.deepcopy(msg) if self.isolate else msg)
        except Exception as exc:
            tb = traceback.format_exc()
            self._errors.append(tb)
            raise ProtocolError("exception", f"the adapter raised {type(exc).__name__}: {exc}", stderr=tb)
        if self.isolate:  # the line a process would have sent, decoded as any other (F-PROTOCOL-LINES)
            try:
                return reply_format.encode_in_process(reply)
            except reply_format.LineError as exc:
                raise ProtocolError(exc.code, f"the {msg['cmd']} reply is not plain JSON: {exc.message}")
        return reply

    def _shutdown(self) -> None:
        self.adapter = None

    def stderr_tail(self) -> str:
        return self._errors[-1] if self._errors else ""


class ReferenceImpl(PythonImpl):
    """The built-in reference interpreter (:class:`agspec.conform.serve.Server`), in process."""

    def __init__(self, *, observations: bool = True, masks: bool = True, **kw: Any):

        kw.setdefault("isolate", False)  # fresh dicts on every reply: nothing to isolate
        super().__init__(lambda: Server(observations=observations, masks=masks), spec="reference", **kw)
        self.trusted = not self.isolate

    @property
    def simulator(self):
        """The interpreter behind the server (what a ``global`` policy reads), or None before ``load``."""
        return self.adapter.sim if self.adapter is not None else None


def _decode(line: bytes, cmd: str, stderr: str | Callable[[], str]) -> Any:
    """One reply line through the one decoder (F-PROTOCOL-LINES); every malformation is the simulator's
    protocol error, shown with the start of the line."""
    try:
        return reply_format.decode_line(line)
    except reply_format.LineError as exc:
        shown = line[:117].decode("utf-8", "backslashreplace") + ("..." if len(line) > 117 else "")
        raise ProtocolError(exc.code, f"the {cmd} reply is malformed: {exc.message}: {shown!r}",
                            stderr=stderr() if callable(stderr) else stderr) from None


def _line_of(text: str, cmd: str, stderr: str | Callable[[], str]) -> bytes:
    """A reply given as text: its UTF-8 line (a lone surrogate has none)."""
    try:
        return text.encode("utf-8")
    except UnicodeEncodeError:
        raise ProtocolError("bad_encoding", f"the {cmd} reply holds a lone surrogate, which is not Unicode text",
                            stderr=stderr() if callable(stderr) else stderr) from None


def _golden_text(raw: Any, seq: int) -> str | None:
    """F-GOLDEN: the text digest of what ``_exchange`` returned — of the line itself, or of an in-process
    reply's compact line when the ``fast`` encoder makes that cheaper than its value digest."""
    if isinstance(raw, (str, bytes)):
        return golden_format.line_digest(raw, seq)
    if isinstance(raw, dict) and jsonl.orjson is not None and raw.get("seq") == seq:
        try:
            return golden_format.text_digest(raw)
        except (TypeError, ValueError):
            return None
    return None


def _check_seq(msg: Mapping[str, Any], reply: Mapping[str, Any], current: int) -> None:
    """F-PROTOCOL: the reply echoes the request's seq; an earlier one is out of order."""
    if "seq" not in reply:
        raise ProtocolError("missing_field", f"the {msg['cmd']} reply has no `seq`")
    got, sent = reply["seq"], msg["seq"]
    if got == sent and isinstance(got, bool) == isinstance(sent, bool):  # F-VALUES: 4.0 echoes 4
        return
    if isinstance(got, (int, float)) and not isinstance(got, bool) and 0 < got < current:
        raise ProtocolError("out_of_order", f"the reply to {msg['cmd']} (seq {msg['seq']}) echoes seq {got} "
                                            "of an earlier request")
    raise ProtocolError("wrong_seq", f"the reply to {msg['cmd']} (seq {msg['seq']}) echoes seq {json.dumps(got)[:80]}")


# ============================================================================================ subprocess


class SubprocessImpl(Implementation):
    """A simulator process speaking F-PROTOCOL on stdin/stdout (no shell).

    A reader thread turns stdout into lines on a queue, so every request waits at most ``timeout``
    seconds; another thread keeps the last 64 KiB of stderr.  On a timeout the process group is
    killed; on any failure the process is dropped and the next request restarts it.
    """

    STDERR_KEEP = 65536
    PIPELINE = 8  # F-GOLDEN: step requests a golden replay keeps in flight
    PIPE_BYTES = 1 << 20  # pipe and read-buffer size (Linux default pipe-max-size)
    TEARDOWN_GRACE = 0.3  # seconds for the output to end once the process group is killed

    def __init__(self, command: str | list[str], timeout: float = 5.0, *, max_restarts: int = 10,
                 cwd: str | None = None, env: Mapping[str, str] | None = None, **kw: Any):
        super().__init__(**kw)
        self.argv = shlex.split(command) if isinstance(command, str) else list(command)
        if not self.argv:
            raise ImplSpecError("empty --impl command")
        self.spec = command if isinstance(command, str) else shlex.join(command)
        self.timeout = float(timeout)
        self.start_timeout = max(self.timeout, 10.0)  # interpreter / JIT start-up is not a hang
        self.max_restarts = max_restarts  # RES-GIVE-UP-SCOPE: failed starts in a row, or failures on one instance
        self.cwd, self.env = cwd, dict(env) if env is not None else None
        self.proc: subprocess.Popen | None = None
        self._lines: queue.Queue = queue.Queue()
        self._stderr: collections.deque = collections.deque()
        self._stderr_size = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._readers: list[threading.Thread] = []

    # ---------------------------------------------------------------- process

    def _open(self) -> None:
        # Replies with every observation run to ~100 KB: a 1 MiB pipe and read buffer let the simulator
        # write several pipelined replies ahead instead of blocking on a 64 KiB pipe (F-GOLDEN).  Where
        # the pipe size cannot be set (another OS, a per-user limit) the default pipe serves.
        for pipes in ({"pipesize": self.PIPE_BYTES, "bufsize": self.PIPE_BYTES}, {}):
            try:
                self.proc = subprocess.Popen(self.argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                             stderr=subprocess.PIPE, cwd=self.cwd, env=self.env,
                                             start_new_session=True, **pipes)
                break
            except (OSError, ValueError) as exc:
                if not pipes:
                    raise ProtocolError("spawn", f"cannot start `{self.spec}`: {exc}")
        self._lines = queue.Queue()
        with self._lock:
            self._stderr.clear()
            self._stderr_size = 0
        # F-PROTOCOL-TEARDOWN: readers that a teardown can always stop (teardown.pump)
        self._stop = threading.Event()
        self._readers = [threading.Thread(target=self._read_stdout, args=(self.proc, self._lines, self._stop),
                                          daemon=True),
                         threading.Thread(target=self._read_stderr, args=(self.proc, self._stop), daemon=True)]
        for reader in self._readers:
            reader.start()

    def _read_stdout(self, proc: subprocess.Popen, lines: queue.Queue, stop: threading.Event) -> None:
        sink = teardown.LineSink(lines)
        teardown.pump(proc.stdout.fileno(), sink, stop, self.PIPE_BYTES)
        sink.finish()

    def _read_stderr(self, proc: subprocess.Popen, stop: threading.Event) -> None:
        def keep(chunk: bytes) -> None:
            with self._lock:
                self._stderr.append(chunk)
                self._stderr_size += len(chunk)
                while self._stderr_size > self.STDERR_KEEP and len(self._stderr) > 1:
                    self._stderr_size -= len(self._stderr.popleft())

        teardown.pump(proc.stderr.fileno(), keep, stop, 65536)

    def stderr_tail(self, limit: int = 4000) -> str:
        with self._lock:
            data = b"".join(self._stderr)
        text = data.decode("utf-8", "replace")
        return text[-limit:]

    def _exit_error(self, what: str) -> ProtocolError:
        proc = self.proc
        code = None
        if proc is not None:
            try:
                code = proc.wait(timeout=1.0)
            except subprocess.TimeoutExpired:
                code = None
        time.sleep(0.05)  # let the stderr reader drain
        if code is None or code == 0:
            return ProtocolError("eof", f"the simulator closed its stdout {what}"
                                        + (" (exit status 0)" if code == 0 else ""), stderr=self.stderr_tail())
        how = f"signal {-code}" if code < 0 else f"status {code}"
        return ProtocolError("exit", f"the simulator exited with {how} {what}", stderr=self.stderr_tail())

    def _exchange(self, msg: dict[str, Any], timeout: float | None) -> Any:
        self._send(msg)
        return self._receive(msg, timeout)

    def _send(self, msg: dict[str, Any]) -> None:
        proc = self.proc
        if proc is None:
            raise ProtocolError("eof", "the simulator is not running")
        line = protocol.encode(msg) + "\n"
        try:
            proc.stdin.write(line.encode("utf-8"))
            proc.stdin.flush()
        except (BrokenPipeError, OSError, ValueError):
            raise self._exit_error(f"before the {msg['cmd']} request could be sent")

    def _receive(self, msg: dict[str, Any], timeout: float | None) -> str:
        limit = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise ProtocolError("timeout", f"no reply to {msg['cmd']} (seq {msg['seq']}) within {limit:g} s",
                                    stderr=self.stderr_tail())
            try:
                raw = self._lines.get(timeout=remaining)
            except queue.Empty:
                continue
            if raw is None:
                self._lines.put(None)
                raise self._exit_error(f"while the harness waited for the {msg['cmd']} reply")
            # F-PROTOCOL-LINES: every line is a reply, a blank one too (refused by the decoder); bytes,
            # decoded and checked by _finish (F-GOLDEN may match it undecoded)
            return raw[:-1] if raw.endswith(b"\n") else raw

    def pipeline(self, steps: Sequence[tuple[Mapping[str, int], tuple[str, str]]]) -> Pipeline:
        """F-GOLDEN: up to PIPELINE step requests in flight (one reply per request, in request order,
        F-PROTOCOL), so the simulator computes the next reply while the harness checks this one."""
        self._ensure()
        return Pipeline(self, steps, window=self.PIPELINE)

    def _shutdown(self) -> None:
        proc, self.proc = self.proc, None
        if proc is None:
            return
        readers, stop = self._readers, self._stop
        try:
            if proc.poll() is None:
                try:
                    proc.stdin.close()
                except OSError:
                    pass
                try:
                    proc.wait(timeout=0.5)
                except subprocess.TimeoutExpired:
                    pass
            # F-PROTOCOL-TEARDOWN: the whole process group goes, also children the simulator left behind
            self._kill(proc)
            # a reader still without end of file: a process in a session of its own holds the pipe
            for reader in readers:
                reader.join(self.TEARDOWN_GRACE)
            if any(r.is_alive() for r in readers):
                teardown.kill_pipe_writers(proc.stdout.fileno(), proc.stderr.fileno())
        finally:
            stop.set()  # the readers end within teardown.POLL_S whatever holds the pipes
            for reader in readers:
                reader.join(2 * teardown.POLL_S + 1.0)
            for stream in (proc.stdin, proc.stdout, proc.stderr):
                if stream is proc.stdin or not any(r.is_alive() for r in readers):
                    try:
                        stream.close()
                    except (OSError, ValueError):
                        pass

    @staticmethod
    def _kill(proc: subprocess.Popen) -> None:
        """Kill the process group this adapter started (start_new_session) and reap its leader.

        The group id is the leader's pid and stays reserved while any member lives, so this also
        reaches children of a leader that has already exited.
        """
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError, OSError):
            if proc.poll() is None:
                try:
                    proc.kill()
                except OSError:
                    pass
        try:
            proc.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            pass

    def _fail(self) -> None:
        proc = self.proc
        if proc is not None and proc.poll() is None:
            self._kill(proc)
        super()._fail()

    def close(self) -> None:
        if self._alive and self.proc is not None and self.proc.poll() is None:
            try:
                self._request_quiet_stop()
            except ProtocolError:
                pass
        self._alive = False
        self._shutdown()

    def _request_quiet_stop(self) -> None:
        msg = protocol.stop(self._next_seq())
        if self.on_message:
            self.on_message("->", "stop", msg)
        reply = self._decoded(msg, self._exchange(msg, min(self.timeout, 2.0)))
        if self.on_message:
            self.on_message("<-", "stop", reply)
        if self.validate:
            problems = protocol.validate_reply("stop", reply)
            if problems:
                raise ProtocolError("schema", f"the stop reply violates its schema: {problems[0]}")


# ============================================================================================ factory


def _load_factory(target: str) -> Callable[[], Any]:
    """``pkg.module:factory`` or ``path/to/file.py:factory`` -> the factory callable."""
    module_name, sep, attr = target.rpartition(":")
    if not sep or not module_name or not attr:
        raise ImplSpecError(f"`python:{target}`: expected python:pkg.module:factory or python:path/file.py:factory")
    try:
        if module_name.endswith(".py") or os.sep in module_name or "/" in module_name:
            path = Path(module_name)
            if not path.is_file():
                raise ImplSpecError(f"`python:{target}`: no file {module_name}")
            name = f"agspec_impl_{abs(hash(str(path.resolve())))}"
            module = sys.modules.get(name)  # a file is executed once per process, as an import is (F-POLICY-PYTHON)
            if module is None:
                spec = importlib.util.spec_from_file_location(name, path)
                if spec is None or spec.loader is None:
                    raise ImplSpecError(f"`python:{target}`: cannot import {module_name}")
                module = importlib.util.module_from_spec(spec)
                sys.modules[name] = module
                try:
                    spec.loader.exec_module(module)
                except BaseException:
                    sys.modules.pop(name, None)  # a failed import leaves nothing half-initialised behind
                    raise
        else:
            module = importlib.import_module(module_name)
    except ImplSpecError:
        raise
    except Exception as exc:  # ImportError, or the module raising at import time
        raise ImplSpecError(f"`python:{target}`: cannot import {module_name}: {type(exc).__name__}: {exc}") from None
    factory = getattr(module, attr, None)
    if not callable(factory):
        raise ImplSpecError(f"`python:{target}`: {module_name} has no callable `{attr}`")
    return factory


def make_impl(spec: str, *, timeout: float = 5.0, validate: bool = False,
              on_message: MessageHook | None = None) -> Implementation:
    """The implementation an ``--impl`` value names (see the module docstring)."""
    spec = (spec or "").strip()
    if not spec:
        raise ImplSpecError("--impl is empty")
    if spec == "reference":
        return ReferenceImpl(validate=validate, on_message=on_message)
    if spec.startswith("python:"):
        factory = _load_factory(spec[len("python:"):])
        return PythonImpl(factory, spec=spec, validate=validate, on_message=on_message)
    try:
        argv = shlex.split(spec)
    except ValueError as exc:
        raise ImplSpecError(f"--impl {spec!r}: {exc}") from None
    if not argv:
        raise ImplSpecError("--impl is empty")
    return SubprocessImpl(spec, timeout, validate=validate, on_message=on_message)


__all__ = ["Implementation", "PythonImpl", "ReferenceImpl", "SubprocessImpl", "ImplSpecError", "make_impl", "Reply"]
