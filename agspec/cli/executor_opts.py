"""The campaign options shared by evaluate, check (and the other campaign commands): where items run.

``@executor_options`` adds ``--executor``, ``--address``, ``--retries``, ``--dispatch-seed`` and
``--runtime-env`` and hands the command one ``campaign`` argument, an
:class:`~agspec.campaign.executor.ExecutorSpec` built with the command's ``-j`` (spec chapter 14).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any, Callable

import click
import yaml

from agspec.campaign.executor import DEFAULT_RETRIES, EXECUTORS, ExecutorSpec
from agspec.cli.common import Choice, fail

_OPTIONS = [
    click.option("--executor", type=Choice(EXECUTORS), default="local", show_default=True,
                 help="Where items run: local processes (-j) or Ray actors (needs pip install 'agspec[ray]')."),
    click.option("--address", default=None, metavar="ADDR",
                 help="With --executor ray: `auto`, `ray://host:port` or `host:port` of a running cluster "
                      "(default: a local Ray started for this run)."),
    click.option("--retries", type=click.IntRange(0), default=DEFAULT_RETRIES, show_default=True,
                 help="Re-dispatch an item whose worker died at most this many times, then report it as an error."),
    click.option("--dispatch-seed", type=int, default=None, metavar="N",
                 help="Dispatch items in an order shuffled with seed N (the results are identical; "
                      "checks order independence)."),
    click.option("--runtime-env", default=None, metavar="JSON|FILE",
                 help="With --executor ray: a Ray runtime environment (JSON text or a .json/.yaml file), "
                      "e.g. to ship the simulator under test to the workers."),
]


def _runtime_env(text: str | None) -> dict[str, Any] | None:
    if text is None:
        return None
    source = text
    if not text.lstrip().startswith("{"):
        try:
            source = Path(text).read_text(encoding="utf-8")
        except OSError as exc:
            fail(f"--runtime-env {text}: cannot read it: {exc.strerror or exc}")
    try:
        env = yaml.safe_load(source)  # JSON is YAML: one parser for both spellings
    except yaml.YAMLError as exc:
        fail(f"--runtime-env: not JSON or YAML: {exc}")
    if not isinstance(env, dict):
        fail("--runtime-env must be a mapping, e.g. {\"working_dir\": \".\"}")
    return env


def make_spec(executor: str, address: str | None, retries: int, dispatch_seed: int | None,
              runtime_env: str | None, jobs: int | None) -> ExecutorSpec:
    """Check the campaign options together (usage errors exit 2, F-EXIT-CODES)."""
    if jobs is not None and jobs < 1:
        fail(f"-j must be at least 1, got {jobs}")
    if executor != "ray" and (address is not None or runtime_env is not None):
        fail("--address and --runtime-env need --executor ray")
    return ExecutorSpec(kind=executor, jobs=jobs, address=address, retries=retries, dispatch_seed=dispatch_seed,
                        runtime_env=_runtime_env(runtime_env))


def executor_options(command: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(command)
    def wrapper(*args: Any, executor: str, address: str | None, retries: int, dispatch_seed: int | None,
                runtime_env: str | None, **kwargs: Any) -> Any:
        campaign = make_spec(executor, address, retries, dispatch_seed, runtime_env, kwargs.get("jobs"))
        return command(*args, campaign=campaign, **kwargs)

    for option in reversed(_OPTIONS):
        wrapper = option(wrapper)
    return wrapper


JOBS_HELP = "Workers (default: 1 locally; with --executor ray every CPU of the cluster)."


__all__ = ["executor_options", "make_spec", "JOBS_HELP"]
