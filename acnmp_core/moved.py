"""Modules that moved when the library was laid out by concept (2026-12-05), kept importable under
their old names with a :class:`DeprecationWarning` that names the new path.

A plugin or script written against the old layout (``from acnmp_core.demo_io import load_demos``,
``import acnmp_core.adapt_job``) keeps working: the old name is an alias of the new module (the
same module object, so a monkeypatch through either name reaches the same code), and the warning
says where it lives now. Two kinds of move:

- :data:`MODULES`: an old module whose name is free now; a finder on ``sys.meta_path``
  (:func:`install`, called by ``acnmp_core/__init__.py``) answers an import of the old name with
  the new module.
- :data:`PACKAGES`: an old module whose name is now a package's (``acnmp_core.data`` was a module,
  ``acnmp_core/data/`` a package): the package's ``__getattr__`` (:func:`forward`) finds a name
  the package lacks in the modules listed, so ``from acnmp_core.data import DemoSet`` still works.

docs/ROBOTS.md ("A plugin") tells plugin authors; the old names go in a later release.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from types import ModuleType
from typing import Callable

#: old module -> the module it is now (commits b80e0aa, 10b5631 and bda26b0 of 2026-12-05)
MODULES: dict[str, str] = {
    "acnmp_core.demo_io": "acnmp_core.data.demo_io",
    "acnmp_core.adapt_job": "acnmp_core.jobs.adapt",
    "acnmp_core.transfer_job": "acnmp_core.jobs.transfer",
    "acnmp_core.assimilation": "acnmp_core.adaptation.assimilation",
    "acnmp_core.exploration": "acnmp_core.adaptation.exploration",
    "acnmp_core.promp": "acnmp_core.baselines.promp",
    "acnmp_core.promp_rl": "acnmp_core.baselines.promp_rl",
    "acnmp_core.promp_selfimprove": "acnmp_core.baselines.promp_selfimprove",
    "acnmp_core.checkpoint": "acnmp_core.model.checkpoint",
    "acnmp_core.cnmp": "acnmp_core.model.cnmp",
    "acnmp_core.device": "acnmp_core.model.device",
    "acnmp_core.normalization": "acnmp_core.model.normalization",
    "acnmp_core.optim_step": "acnmp_core.model.optim_step",
    "acnmp_core.training": "acnmp_core.model.training",
    "acnmp_core.plots": "acnmp_core.experiments.plots",
    "acnmp_core.robots.kinematics": "acnmp_core.sim.kinematics",
    "acnmp_core.robots.physics": "acnmp_core.sim.physics",
    "acnmp_core.robots.planar_arm": "acnmp_core.sim.planar_arm",
    "acnmp_core.robots.quiet_pybullet": "acnmp_core.sim.quiet_pybullet",
    "acnmp_core.robots.ur10_description": "acnmp_core.sim.ur10_description",
    "acnmp_core.robots.urdf": "acnmp_core.sim.urdf",
    "acnmp_core.tasks.pour_demos": "acnmp_core.tasks.pour.demos",
    "acnmp_core.tasks.push_demos": "acnmp_core.tasks.push.demos",
    "acnmp_core.tasks.push_settings": "acnmp_core.tasks.push.settings",
    "acnmp_core.tasks.pusher_scene": "acnmp_core.tasks.pusher.scene",
    "acnmp_core.tasks.transfer_demos": "acnmp_core.tasks.transfer.demos",
    "acnmp_core.tasks.transfer_scene": "acnmp_core.tasks.transfer.scene",
    "acnmp_core.tasks.ur10_demos": "acnmp_core.tasks.ur10_pick_place.demos",
    "acnmp_core.tasks.wall_settings": "acnmp_core.tasks.wall.settings",
    "acnmp_core.tasks.metaworld.kinds": "acnmp_core.robots.metaworld",
}

#: old module, now a package -> (its public names then, the modules they are in now)
PACKAGES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "acnmp_core.data": (("Demonstration", "DemoSet", "PackedDemos", "Episode", "EpisodeSampler"),
                        ("acnmp_core.data.demos", "acnmp_core.model.episodes")),
    "acnmp_core.adaptation": (("MODES", "ADVANTAGES", "SOLUTIONS", "NOISES", "CREDITS", "AdaptConfig", "AdaptTarget",
                               "IterationLog", "AdaptResult", "per_step_advantages", "adapt"),
                              ("acnmp_core.adaptation.loop", "acnmp_core.adaptation.config",
                               "acnmp_core.adaptation.credit", "acnmp_core.adaptation.exploration")),
    "acnmp_core.transfer": (("TransferConfig", "PairTrainResult", "TransferPair", "train_pair", "TransferredSkill",
                             "spread_observations", "latent_plane"),
                            ("acnmp_core.transfer.config", "acnmp_core.transfer.pair")),
    "acnmp_core.tasks.viapoint": (("DEMO_AMPLITUDES", "EXTRAPOLATION_AMPLITUDE", "OBSTACLES", "OBSTACLE_RADIUS",
                                   "BUMP_WIDTH", "two_bump", "obstacle_demos", "two_bump_demos", "extrapolated_viapoint",
                                   "extrapolation_conditions", "ViaPointTask", "shape_error"),
                                  ("acnmp_core.tasks.viapoint.task",)),
    "acnmp_core.tasks.wall": (("WORLD_LOW", "WORLD_HIGH", "START", "WALL_THICKNESS", "HOLE_WIDTH", "START_TOLERANCE",
                               "GOAL_TOLERANCE", "GOAL_WEIGHT", "TEST_SEED", "N_TASK_PARAMS", "X_C_RANGE", "Y_C_RANGE",
                               "GOAL_X_GAP", "Y_G_RANGE", "sample_environments", "test_environments", "wall_rectangles",
                               "WallScores", "wall_scores", "wall_rewards", "wall_success", "wall_errors", "demonstrate",
                               "make_demo_set", "WallTask"),
                              ("acnmp_core.tasks.wall.task", "acnmp_core.tasks.wall.settings")),
    "acnmp_core.tasks.ur10_pick_place": (("N_STEPS", "SEGMENTS", "GRASP_PHASE", "CROSS_PHASE", "RELEASE_PHASE",
                                          "GRASP_DEPTH", "CLEARANCE", "H_OBJ_RANGE", "H_OBS_RANGE", "check_task_params",
                                          "grasp_point", "avoidance_point", "phase_of", "gripper_schedule",
                                          "reward_steps", "UR10PickPlaceTask"),
                                         ("acnmp_core.tasks.ur10_pick_place.task",)),
}


def _warn(old: str, new: str) -> None:
    # stacklevel 3: the importer's line (past this function and the loader or __getattr__)
    warnings.warn(f"{old} moved to {new}; import it from there (the old name goes in a later release)",
                  DeprecationWarning, stacklevel=3)


class _AliasLoader(importlib.abc.Loader):
    """Loads an old module name as the new module itself."""

    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        _warn(spec.name, self.new)
        return importlib.import_module(self.new)

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the new module was executed when it was imported."""


class MovedModuleFinder(importlib.abc.MetaPathFinder):
    """Finds the old names of :data:`MODULES` (and nothing else)."""

    def find_spec(self, fullname: str, path=None, target=None):
        new = MODULES.get(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _AliasLoader(new))


def install() -> None:
    """Put the finder on ``sys.meta_path`` once per process."""
    if not any(isinstance(f, MovedModuleFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, MovedModuleFinder())


def forward(package: str) -> Callable[[str], object]:
    """A module ``__getattr__`` for ``package`` (a key of :data:`PACKAGES`): one of its old
    module's public names is found in the modules it went to (the first that has it, imported
    then), with a warning naming where it is; AttributeError as usual for any other name."""
    names, homes = PACKAGES[package]

    def __getattr__(name: str) -> object:
        if name in names:
            for home in homes:
                module = importlib.import_module(home)
                if name in vars(module):
                    value = getattr(module, name)
                    where = getattr(value, "__module__", None) if callable(value) else None
                    _warn(f"{package}.{name}", f"{where or home}.{name}")
                    # kept, so ``from package import name`` (which asks twice) warns once
                    setattr(sys.modules[package], name, value)
                    return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return __getattr__
