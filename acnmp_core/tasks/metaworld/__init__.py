"""Meta-World's Sawyer tasks (``reach-v3``, ``push-v3``, ``pick-place-v3``, ``window-open-v3``,
``button-press-v3``) as ACNMP tasks and robot kinds.

:mod:`.scene`: the tasks, their parameters (puck and goal positions), regions and environments;
:mod:`.demos`: demonstrations by Meta-World's own scripted policies. The robot kinds
``metaworld-reach``, ``metaworld-push``, ``metaworld-pick-place``, ``metaworld-window-open`` and
``metaworld-button-press`` (through the Gymnasium adapter)
are in :mod:`acnmp_core.robots.metaworld`.
Needs the ``metaworld`` extra (``pip install 'acnmp[metaworld]'``); importing this package does not
import Meta-World, the first environment does.
"""
