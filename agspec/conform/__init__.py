"""The conformance harness (spec F-CONFORM, F-PROTOCOL, F-REPRO) and differential testing.

The driver API — every episode agspec runs against an implementation goes through it:

* ``impl.make_impl(spec) -> Implementation`` (``reference``, ``python:mod:factory`` or a command);
  one class, ``start/load/reset/step/close``; ``ReferenceImpl`` is the in-process interpreter and
  exposes ``.simulator`` for ``global`` policies.
* ``driver.Pair(expected, actual_or_None, labels, specs, expected_side="A", cache_loads=True)``.
* ``driver.lockstep(pair, instance, seed, policy, ticks, stop_at_done=True, tolerance=None,
  observer=None) -> Run``: never raises for a failing implementation.  ``observer(step: Step) ->
  stop?`` sees every reply pair (``t`` -1 for reset, ``joint``, ``observations`` = I_t it was chosen
  on, ``expected``, ``actual``, ``divergence``).  ``Run``: ``divergence`` (the one
  ``compare.Divergence``), ``failure``/``failure_tick`` (an ``ImplementationFailure``, cause
  chained), ``both_failed``, ``invalid`` (F-SYMBOLIC-ACTIONS), ``actions``, ``script``, ``ticks``,
  ``states``.
* Policies (``policies``): ``ControllerPolicy(name, seed)``, ``ScriptPolicy(script)``,
  ``GenePolicy(genes)`` — ``act(t, observations, robots, simulator) -> {robot: action}``.
* Users: ``lockstep.run_item`` (suite cases, catalogue episodes, ``--replay``, the pytest plugin;
  ``runner.run`` schedules items), ``diff`` + ``shrink`` (``agspec diff``), ``viewer.record``.
* Formats (reports, reproducers' JSON, traces, pointers, schemas) come from ``agspec.formats``.
"""
