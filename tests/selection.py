"""Which tests run.

``slow`` tests (minutes each) run only when a ``-m`` expression names them (``-m slow``, ``-m "slow
or not slow"``) or their node id is given. pytest's own ``-m`` replaces any other, so a default
marker expression in the configuration was dropped by ``-m "not e2e"``, which then ran the slow
tests too; deciding here keeps them out of any other selection.

``--fast`` (``bash scripts/test.sh --fast``: the inner loop) also leaves out the tests of
:data:`HEAVY`: those of the default suite that train networks or run simulations for seconds each.
They are listed here, by file or by test, rather than marked in their files, so the list reads in
one place; a new test is in the inner loop until it is listed. No torch here: the check of these
rules loads this module without the suite's conftest.
"""
from __future__ import annotations

import re

#: Node-id prefixes (files, or tests) that ``--fast`` leaves out, relative to the repository: the
#: unit tests that took a second or more each here (``pytest tests/unit --durations=0``), most of
#: the time of tests/unit, and every user of the session's trained E1 model (``e1_model``, whose
#: training the first of them pays).
HEAVY: tuple[str, ...] = tuple(f"tests/unit/{name}" for name in (
    "adaptation/test_loop.py",
    "adaptation/test_assimilation_beyond.py",
    "model/test_selection.py",
    "model/test_prior.py",
    "benchmarks/test_merge_inputs.py",
    "model/test_cnmp.py",
    "benchmarks/test_e6_fit_trace.py",
    "experiments/test_own_robot.py",
    "model/test_lr_schedule.py",
    "sim/test_planar_arm.py",
    "tasks/pour/test_task.py",
    "experiments/test_pour.py",
    "benchmarks/test_published_numbers.py",
    "experiments/test_push.py",
    "tasks/push/test_settings.py",
    "tasks/pusher/test_scene.py",
    "clients/commands/test_reproduce.py::test_reproduce_quick_e1_writes_the_report_and_resumes",
    "robots/test_plugins.py::test_the_command_line_says_one_line_for_a_broken_plugin",
    "services/recording/test_event_ids.py",
    "services/learner/test_concurrent_jobs.py",
    "adaptation/test_assimilation.py::test_wall_run_counts_executed_snaps",
    "test_threads.py::test_training_uses_one_thread",
    "model/test_training_checkpoint.py",
    "transfer/test_pair.py",
    "services/model/test_transfer_messages.py::test_a_pair_job_is_cancelled_while_queued_and_while_running",
    "test_typed_api.py",
    "sim/test_ur10.py",
    "experiments/test_ur10.py",
    "experiments/test_viapoint.py",
    "benchmarks/test_run_arguments.py::test_a_benchmark_run_of_the_default_writes_its_json_beside_the_papers",
    "experiments/test_wall.py",
    "tasks/wall/test_task.py::test_scoring_1000_environments_in_one_batch",
    "services/transport/test_wire.py::test_plain_messages_round_trip",
))


def add_options(parser) -> None:
    """The ``--fast`` option (pytest_addoption)."""
    parser.addoption("--fast", action="store_true",
                     help="the inner loop: leave out the heavy tests (tests/selection.py HEAVY) besides the slow ones")


def deselect(config, items: list) -> None:
    """Remove from ``items`` (and report deselected) the ``slow`` tests unless ``config``'s ``-m``
    expression names ``slow``, and with ``--fast`` the tests of :data:`HEAVY`; a test whose node id
    was given as an argument stays either way."""
    named = tuple(arg for arg in config.args if "::" in arg)

    def asked(item) -> bool:
        return any(item.nodeid.startswith(arg) or arg.endswith(item.nodeid) for arg in named)

    slow_decided = re.search(r"\bslow\b", config.getoption("markexpr") or "")
    fast = config.getoption("fast", False)
    dropped = [item for item in items if not asked(item) and (
        (not slow_decided and item.get_closest_marker("slow")) or (fast and item.nodeid.startswith(HEAVY)))]
    if dropped:
        config.hook.pytest_deselected(items=dropped)
        gone = set(map(id, dropped))
        items[:] = [item for item in items if id(item) not in gone]
