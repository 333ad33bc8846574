"""pytest plugin: the conformance suite as pytest items (F-CONFORM).

Registered as the ``pytest11`` entry point ``agspec``, so a simulator author runs conformance inside
their own test suite::

    pytest --agspec-impl "./my_sim --agspec"                 # every suite case + catalogue episodes
    pytest --agspec-impl python:my_sim.adapter:make -k R-HANDOFF
    pytest --agspec-impl "./my_sim" --agspec-expect known-gaps.yaml --agspec-horizon 20 -m INV-CONSERVATION

Options (group "agspec"):

``--agspec-impl SPEC``      the implementation (``reference``, ``python:pkg.module:factory`` or a command
                            line, as ``agspec conform --impl``); without it the plugin does nothing;
``--agspec-horizon T``      ticks per catalogue episode (default: the whole horizon, as ``agspec conform``;
                            earlier spelling ``--agspec-ticks``);
``--agspec-episodes N``     lockstep episodes per catalogue scenario (greedy, then seeded random; default
                            2 as ``agspec conform --episodes``, 0 = suite cases only);
``--agspec-expect FILE``    expected failures (F-EXPECT): a listed case that fails as listed is xfailed,
                            one that passes fails (XPASS), an entry naming nothing fails (stale);
``--agspec-suite DIR``      another suite root (default: agspec's conformance/);
``--agspec-timeout S``      per-request timeout of a subprocess implementation (default 5 s);
``--agspec-validate``       validate every protocol message against its schema.

Items: one per case (node id = the case id ``c-…``) and per episode (``e-{scenario}-greedy``…), with
a marker per rule and invariant ID the case exercises (``-m R-HANDOFF``, ``-m "INV-CONSERVATION"``)
plus ``agspec``, ``agspec_case`` or ``agspec_episode``; ``-k`` matches ids, titles and tags.  Each
item runs in lockstep with the reference (agspec.conform.run_item.run_item, exactly what
``agspec conform`` does) and fails with the CommonMark-style divergence report.  One
implementation process serves the whole session and is restarted after a crash or a hang.

Without ``--agspec-impl`` every hook returns at once and nothing heavier than pytest is imported,
so the plugin neither slows down nor changes any other test run.
"""

from __future__ import annotations

from typing import Any

import pytest

_STATE_KEY = "_agspec_state"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("agspec", "AssemblyGrid v1 conformance (agspec)")
    group.addoption("--agspec-impl", metavar="SPEC", default=None,
                    help="run the agspec conformance suite against SPEC: reference, python:pkg.module:factory or "
                         "a command line speaking agspec-protocol/1")
    # docs/cli.md: --horizon as in agspec conform; the earlier spelling --agspec-ticks is still accepted
    group.addoption("--agspec-horizon", "--agspec-ticks", dest="agspec_horizon", metavar="T", type=int, default=None,
                    help="ticks per catalogue episode (default: the whole horizon, as agspec conform --horizon)")
    group.addoption("--agspec-episodes", metavar="N", type=int, default=2,
                    help="lockstep catalogue episodes per catalogue scenario: greedy plus N-1 seeded random "
                         "(default 2, as agspec conform; 0: suite cases only)")
    group.addoption("--agspec-expect", metavar="FILE", default=None,
                    help="expected-failures file (YAML/JSON: {case id: {outcome: fail|error, reason}})")
    group.addoption("--agspec-suite", metavar="DIR", default=None,
                    help="suite root directory holding cases/ (default: agspec's conformance suite)")
    group.addoption("--agspec-timeout", metavar="S", type=float, default=5.0,
                    help="seconds per protocol request before a subprocess implementation counts as hung")
    group.addoption("--agspec-golden-cache", metavar="DIR|off", default=None,
                    help="golden reference traces (F-GOLDEN; default $AGSPEC_GOLDEN_CACHE or ~/.cache/agspec/golden)")
    group.addoption("--agspec-validate", action="store_true", default=False,
                    help="validate every protocol message against schemas/protocol")


def _enabled(config: pytest.Config) -> bool:
    return bool(config.getoption("agspec_impl", default=None))


class _State:
    """Per-session state: the loaded items, the expectations and the (lazily started) implementation."""

    def __init__(self, config: pytest.Config):
        self.config = config
        self.spec: str = config.getoption("agspec_impl")
        self.timeout: float = config.getoption("agspec_timeout")
        self.validate: bool = config.getoption("agspec_validate")
        self.items: list[Any] = []
        self.expectations: dict[str, Any] = {}
        self.stale: list[str] = []
        self.problem: str | None = None  # a suite or expectations problem, reported by one failing item
        self.impl: Any = None
        self.opts: Any = None
        self.ran = 0  # agspec items run, and what they compared (F-CONFORM-LEVELS)
        self.compared: dict[str, int] = {}
        self.invariant_checks = 0

    def load(self) -> None:
        from agspec.conform import expect
        from agspec.conform.cases import SuiteError, load_suite
        from agspec.conform.golden import cache_dir
        from agspec.conform.impl import ImplSpecError, make_impl
        from agspec.conform.items import EPISODE_SCENARIOS, catalogue_episodes, from_case
        from agspec.conform.run_item import Options

        golden_dir = cache_dir(self.config.getoption("agspec_golden_cache"))
        self.opts = Options(impl_spec=self.spec, golden_dir=str(golden_dir) if golden_dir else None)
        cfg = self.config
        try:  # resolved now (a usage error stops the run), started by the first item
            self.impl = make_impl(self.spec, timeout=self.timeout, validate=self.validate)
        except ImplSpecError as exc:
            self.problem = f"--agspec-impl: {exc}"
            return
        try:
            cases = load_suite(cfg.getoption("agspec_suite"))
        except SuiteError as exc:
            self.problem = f"the conformance suite is malformed:\n{exc}"
            return
        self.items = [from_case(c) for c in cases]
        episodes = max(0, int(cfg.getoption("agspec_episodes")))
        ticks = cfg.getoption("agspec_horizon")
        ticks = None if ticks is None else max(1, int(ticks))
        self.items += catalogue_episodes(episodes, ticks)
        path = cfg.getoption("agspec_expect")
        if path:
            try:
                self.expectations = expect.load_expectations(path)
            except expect.ExpectError as exc:  # a usage error: nothing runs, one item reports it
                self.problem = f"--agspec-expect: {exc}"
                self.items = []
                return
            self.stale = expect.stale_entries(self.expectations, {i.id for i in self.items}, suite_loaded=True,
                                              scenarios=EPISODE_SCENARIOS)

    def implementation(self):
        if self.impl is None:  # closed after the session, or never resolved
            from agspec.conform.impl import make_impl

            self.impl = make_impl(self.spec, timeout=self.timeout, validate=self.validate)
        return self.impl

    def close(self) -> None:
        if self.impl is not None:
            try:
                self.impl.close()
            finally:
                self.impl = None


def pytest_configure(config: pytest.Config) -> None:
    if not _enabled(config):
        return
    from agspec.spec_index import spec_ids

    config.addinivalue_line("markers", "agspec: an agspec conformance item (case or catalogue episode)")
    config.addinivalue_line("markers", "agspec_case: a case of the agspec conformance suite")
    config.addinivalue_line("markers", "agspec_episode: a lockstep episode on the official catalogue")
    for ident in spec_ids(("R-", "O-", "D-", "INV-")):
        config.addinivalue_line("markers", f"{ident}: agspec items exercising {ident}")
    state = _State(config)
    setattr(config, _STATE_KEY, state)
    config.add_cleanup(state.close)


def pytest_report_header(config: pytest.Config) -> str | None:
    state = getattr(config, _STATE_KEY, None)
    if state is None:
        return None
    return f"agspec: conformance of {state.spec!r} (agspec-protocol/1, timeout {state.timeout:g} s)"


class AgspecFailure(Exception):
    """A conformance failure (outcome fail or xpass): the divergence / invariant / expectation report."""


class AgspecError(Exception):
    """An implementation error (crash, timeout, protocol): outcome error."""


class AgspecItem(pytest.Item):
    """One conformance case or catalogue episode run against the implementation under test."""

    def __init__(self, *, conform_item: Any, state: _State, **kw: Any):
        super().__init__(**kw)
        self.conform_item = conform_item
        self.state = state
        self.user_properties.append(("agspec_kind", conform_item.kind))

    def runtest(self) -> None:
        from agspec.conform import expect
        from agspec.conform.run_item import run_item

        state = self.state
        result = run_item(self.conform_item, state.implementation(), state.opts)
        state.ran += 1
        state.invariant_checks += result.invariant_checks
        for part, n in result.compared.items():
            state.compared[part] = state.compared.get(part, 0) + n
        exp = state.expectations.get(self.conform_item.id)
        outcome = expect.apply(result.outcome, exp)
        self.user_properties.append(("agspec_outcome", outcome))
        self.user_properties.append(("agspec_checks", {"ticks": result.ticks, "states": result.states,
                                                        "invariant_checks": result.invariant_checks,
                                                        "expectations": result.expectations}))
        if outcome == "pass":
            return
        if outcome == "skip":
            pytest.skip(result.message or "skipped")
        if outcome == "xfail":
            pytest.xfail(f"expected {exp.outcome}: {exp.reason or result.message}")
        text = result.rendered or result.message or outcome
        if outcome == "xpass":
            raise AgspecFailure(f"{self.conform_item.id} passed, but {self.config.getoption('agspec_expect')} lists it "
                                f"as an expected {exp.outcome} ({exp.reason or 'no reason given'}): the gap is gone, "
                                "remove the entry (XPASS counts as a failure)")
        if outcome == "error":
            raise AgspecError(text)
        raise AgspecFailure(text)

    def repr_failure(self, excinfo, style=None):
        if isinstance(excinfo.value, AgspecError):
            return f"implementation error\n{excinfo.value}"
        if isinstance(excinfo.value, AgspecFailure):
            return str(excinfo.value)
        return super().repr_failure(excinfo, style=style)

    def reportinfo(self):
        it = self.conform_item
        return (it.location or "agspec", None, f"agspec {it.kind} {it.id}: {it.title}")


class AgspecProblem(pytest.Item):
    """A failing item standing for a problem of the run itself (malformed suite, stale expectations)."""

    def __init__(self, *, message: str, **kw: Any):
        super().__init__(**kw)
        self.message = message

    def runtest(self) -> None:
        raise AgspecFailure(self.message)

    def repr_failure(self, excinfo, style=None):
        return str(excinfo.value)

    def reportinfo(self):
        return ("agspec", None, f"agspec {self.name}")


@pytest.hookimpl(wrapper=True)
def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list):
    """Add the agspec items before every other implementation runs (so -k and -m deselect among them),
    and the items standing for problems of the run after (so no selection hides them)."""
    state: _State | None = getattr(config, _STATE_KEY, None)
    if state is None:
        return (yield)
    state.load()
    for it in state.items:
        node = AgspecItem.from_parent(session, name=it.id, nodeid=it.id, conform_item=it, state=state)
        node.add_marker("agspec")
        node.add_marker("agspec_case" if it.kind == "case" else "agspec_episode")
        for ident in dict.fromkeys(tuple(it.rules) + tuple(it.invariants)):
            node.add_marker(ident)
        node.extra_keyword_matches.update(t for t in it.tags if t)
        node.extra_keyword_matches.add(it.title)
        items.append(node)
    result = yield
    if state.problem:
        items.append(AgspecProblem.from_parent(session, name="agspec-setup", nodeid="agspec-setup",
                                               message=state.problem))
    if state.stale:
        listed = ", ".join(state.stale)
        items.append(AgspecProblem.from_parent(
            session, name="agspec-stale-expectations", nodeid="agspec-stale-expectations",
            message=f"{config.getoption('agspec_expect')} lists {len(state.stale)} id(s) that name no case or episode "
                    f"(stale entries count as failures): {listed}"))
    return result


EXIT_VACUOUS = 3  # F-EXIT-CODES: as `agspec conform`, a vacuous run is a harness-class failure


def _level(state: _State) -> tuple[str, bool]:
    from agspec.conform.runner import level_name

    proven = [p for p, n in state.compared.items() if n]
    return level_name(proven), not proven and state.invariant_checks == 0


def pytest_terminal_summary(terminalreporter, exitstatus, config: pytest.Config) -> None:
    """F-CONFORM-LEVELS: the level proven and what was compared, after the agspec items ran."""
    state: _State | None = getattr(config, _STATE_KEY, None)
    if state is None or not state.ran:
        return
    level, vacuous = _level(state)
    counts = ", ".join(f"{n} {p}" for p, n in state.compared.items())
    terminalreporter.write_line(f"agspec: level proven {level} (compared: {counts}; "
                                f"{state.invariant_checks} invariant checks)"
                                + ("; VACUOUS: nothing behavioural was compared" if vacuous else ""))


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """A vacuous conformance session never passes (exit 3, as `agspec conform`)."""
    state: _State | None = getattr(session.config, _STATE_KEY, None)
    if state is not None and state.ran and _level(state)[1] and exitstatus == 0:
        session.exitstatus = EXIT_VACUOUS


__all__ = ["AgspecItem", "AgspecFailure", "AgspecError", "pytest_addoption", "pytest_configure",
           "pytest_collection_modifyitems", "pytest_report_header", "pytest_terminal_summary",
           "pytest_sessionfinish"]
