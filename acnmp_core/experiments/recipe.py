"""Which method an experiment runs: the paper's or the product's default (:class:`Recipe`).

Each of the paper's six experiments (E1-E6) runs one of two recipes:

* **"paper"** (:data:`PAPER`): the paper's method as this project reproduces it, the numbers the
  experiments' pages have always reported: the CNMP alone (``CNMPConfig(prior="none")``) adapted
  with the experiment's own settings (``AdaptConfig.paper(...)`` and, where its study chose them,
  more: E4's cubic noise, E6's exploration). Unchanged, bit for bit.
* **"default"** (:data:`DEFAULT`): the product's default, what ``acnmp up`` serves a user: the
  model chooses at training between the demonstrations' linear path beside the network and the
  network alone (``CNMPConfig(prior="auto")``, :mod:`acnmp_core.model.selection`), and adapts with
  ``AdaptConfig()``'s defaults plus only what the experiment's protocol fixes for any method
  (:class:`Protocol`: its roll-out budget, the roll-out that may end it, the roll-outs of an
  iteration where the paper counts iterations). Nothing in it is tuned per experiment.

A recipe is the method only: the demonstrations, the training steps, the assimilation, the task
and its success are the experiment's, the same under both.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from ..adaptation.config import SOLUTIONS, AdaptConfig
from ..validation import check_positive_int

#: The recipes' names, the paper's method first.
RECIPES = ("paper", "default")
#: ``CNMPConfig.prior`` of the experiments' models under each recipe.
PRIORS = {"paper": "none", "default": "auto"}


@dataclass(frozen=True)
class Protocol:
    """What an experiment's protocol fixes of the adaptation, whatever the method.

    budget : roll-outs per adaptation (``AdaptConfig.max_rollouts``).
    solution : which executed roll-out may end the adaptation (``AdaptConfig.solution``): "mean",
        or "any" where the protocol stops at the first roll-out that succeeds (E6: the roll-out
        that pours within 30 g).
    noisy_per_iter : noisy roll-outs per iteration where the protocol counts iterations of a fixed
        size (E4: the authors' two roll-outs, the mean and one noisy; its checkpoints are after
        3/7/11/19 iterations); None leaves it to the method.
    """

    budget: int
    solution: str = "mean"
    noisy_per_iter: int | None = None

    def __post_init__(self) -> None:
        check_positive_int("budget", self.budget)
        if self.solution not in SOLUTIONS:
            raise ValueError(f"solution: expected one of {SOLUTIONS}, got {self.solution!r}")
        if self.noisy_per_iter is not None:
            check_positive_int("noisy_per_iter", self.noisy_per_iter)

    def fields(self) -> dict:
        """The AdaptConfig fields the protocol fixes, by name."""
        out = {"max_rollouts": self.budget, "solution": self.solution}
        if self.noisy_per_iter is not None:
            out["noisy_per_iter"] = self.noisy_per_iter
        return out


@dataclass(frozen=True)
class Recipe:
    """The method an experiment runs (module docstring): ``name`` "paper" or "default"."""

    name: str = "paper"

    def __post_init__(self) -> None:
        if self.name not in RECIPES:
            raise ValueError(f"recipe: expected one of {', '.join(RECIPES)}, got {self.name!r}")

    @property
    def prior(self) -> str:
        """``CNMPConfig.prior`` of the experiment's model: "none" (the paper's CNMP) or "auto" (the
        default: chosen from the demonstrations at training)."""
        return PRIORS[self.name]

    def adapt_config(self, protocol: Protocol, paper: AdaptConfig | None = None, **fields) -> AdaptConfig:
        """The adaptation settings of this recipe for an experiment whose protocol is ``protocol``.

        paper : the experiment's settings of the paper's method (default ``AdaptConfig.paper()``
            over the protocol's fields); they must agree with ``protocol`` (ValueError naming the
            field otherwise), since the protocol binds every method.
        fields : AdaptConfig fields set last under both recipes: the method's ``mode`` (E1's three
            methods), an ablation's overrides.

        Returns the paper's settings (unchanged) for "paper"; ``AdaptConfig`` with the product's
        defaults and the protocol's fields for "default".
        """
        if paper is None:
            paper = AdaptConfig.paper(**protocol.fields())
        for name, value in protocol.fields().items():
            if getattr(paper, name) != value:
                raise ValueError(f"paper: its {name} {getattr(paper, name)!r} is not the protocol's {value!r}")
        cfg = paper if self.name == "paper" else AdaptConfig(**protocol.fields())
        return replace(cfg, **fields) if fields else cfg

    def result_name(self, stem: str) -> str:
        """The name of a benchmark's result under this recipe: ``stem`` for the paper's method (the
        results of record so far), ``<stem>_default`` for the default, beside it."""
        return stem if self.name == "paper" else f"{stem}_{self.name}"

    def to_dict(self, prior: str | None = None) -> dict:
        """What a result records: the recipe's name and its models' ``CNMPConfig.prior`` (default
        :attr:`prior`; an experiment whose models are the same under both recipes says theirs)."""
        return {"name": self.name, "prior": self.prior if prior is None else prior}


#: The paper's method.
PAPER = Recipe("paper")
#: The product's default.
DEFAULT = Recipe("default")


def chosen_priors(result: dict) -> dict[int, str]:
    """The prior each seed's model had in an experiment's JSON ``result`` (what ``run_viapoint``'s
    summary, ``run_push``, ``run_wall``, ``run_ur10``, ``run_pour`` or several E1 seeds give):
    ``{seed: "none" | "linear"}``, empty for a result without the models recorded (E4, whose pairs
    are the network alone under both recipes, or a result made before they were)."""
    if isinstance(result.get("model"), dict):  # one E1 seed
        return {int(result["seed"]): result["model"]["prior"]}
    acnmp = (result.get("methods") or {}).get("acnmp")
    if isinstance(acnmp, dict) and isinstance(acnmp.get("model"), dict):  # E3
        return {int(result["seed"]): acnmp["model"]["prior"]}
    runs = result.get("runs") if isinstance(result.get("runs"), list) else []
    return {int(r["seed"]): r["model"]["prior"] for r in runs if isinstance(r.get("model"), dict)}


def model_prior(model) -> dict:
    """What a trained model's prior turned out to be, for a result: ``{"prior": "none" | "linear",
    "errors": {candidate: held-out error} or None, "reason": one line or None}``; ``model`` is a
    trained :class:`~acnmp_core.model.cnmp.CNMP` (with "auto" its config holds the choice)."""
    choice = model.config.prior_choice
    return {"prior": model.config.prior, "errors": None if choice is None else dict(choice.errors),
            "reason": None if choice is None else choice.reason}
