"""Demonstrations: the set a skill learns from and the file format it travels in.

- :mod:`.demos`: :class:`~acnmp_core.data.demos.Demonstration` (one trajectory, times (T,),
  values (T, D), task parameters (P,)) and :class:`~acnmp_core.data.demos.DemoSet`.
- :mod:`.demo_io`: the demonstrations file (.npz) a user writes and ``acnmp`` reads.

No torch here: the tasks' scripted experts build demonstrations without the model.
"""

from ..moved import forward

__getattr__ = forward(__name__)  # this package was a module: its old names, with a warning
