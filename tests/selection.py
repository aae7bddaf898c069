"""Which tests run: the ``slow`` ones (minutes each) only when a ``-m`` expression names them
(``-m slow``, ``-m "slow or not slow"``) or their node id is given. pytest's own ``-m`` replaces any
other, so a default marker expression in the configuration was dropped by ``-m "not e2e"``, which
then ran the slow tests too; deciding here keeps them out of any other selection. No torch here:
the check of this rule loads it without the suite's conftest."""
from __future__ import annotations

import re


def deselect_slow(config, items: list) -> None:
    """Remove the ``slow`` tests from ``items`` (and report them deselected) unless ``config``'s
    ``-m`` expression names ``slow``; a test whose node id was given as an argument stays."""
    if re.search(r"\bslow\b", config.getoption("markexpr") or ""):
        return  # the expression decides
    named = tuple(arg for arg in config.args if "::" in arg)
    slow = [item for item in items if item.get_closest_marker("slow")
            and not any(item.nodeid.startswith(arg) or arg.endswith(item.nodeid) for arg in named)]
    if slow:
        config.hook.pytest_deselected(items=slow)
        items[:] = [item for item in items if item not in slow]
