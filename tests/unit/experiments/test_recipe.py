"""The experiments' recipes (acnmp_core/experiments/recipe.py): the paper's is exactly what each
experiment ran before recipes existed; the default is the product's AdaptConfig() with only the
experiment's protocol, and the product's self-selecting model."""
from __future__ import annotations

from dataclasses import fields

import pytest

from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.experiments import pour, push, transfer, ur10, viapoint, wall
from acnmp_core.experiments.recipe import DEFAULT, PAPER, RECIPES, Protocol, Recipe, chosen_priors
from acnmp_core.model.cnmp import CNMPConfig

#: Each experiment's adaptation settings as its code built them before the recipes (commit 6402ddc),
#: written out: the paper's recipe must give these, field for field.
BEFORE = {
    "E1 acnmp": AdaptConfig.paper(mode="acnmp", max_rollouts=100),
    "E1 rl_only": AdaptConfig.paper(mode="rl_only", max_rollouts=100),
    "E1 lfd_only": AdaptConfig.paper(mode="lfd_only", max_rollouts=100),
    "E2": AdaptConfig.paper(max_rollouts=300),
    "E3": AdaptConfig.paper(max_rollouts=1000),
    "E4": AdaptConfig.paper(noisy_per_iter=1, max_rollouts=40, n_knots=20, noise="cubic", sl_steps=1, sl_steps_reuse=0,
                            explore_scale=0.35, signal_tolerance=1e-4),
    "E5": AdaptConfig.paper(max_rollouts=60),
    "E6": AdaptConfig.paper(max_rollouts=60, explore_error_gain=1.5e-3, explore_cap=0.5, lr=3e-3, max_reuse=100,
                            temperature=0.05, solution="any", noise="demos"),
}
#: What each experiment's protocol fixes, whatever the method (the default recipe adds only these).
PROTOCOL = {"E1 acnmp": {"mode": "acnmp", "max_rollouts": 100}, "E1 rl_only": {"mode": "rl_only", "max_rollouts": 100},
            "E1 lfd_only": {"mode": "lfd_only", "max_rollouts": 100}, "E2": {"max_rollouts": 300},
            "E3": {"max_rollouts": 1000}, "E4": {"max_rollouts": 40, "noisy_per_iter": 1}, "E5": {"max_rollouts": 60},
            "E6": {"max_rollouts": 60, "solution": "any"}}


def settings(recipe: Recipe) -> dict[str, AdaptConfig]:
    """Every experiment's adaptation settings under ``recipe``, as its run function builds them."""
    return {**{f"E1 {m}": viapoint.adapt_config(m, 100, recipe) for m in viapoint.METHODS},
            "E2": push.adapt_settings(recipe), "E3": wall.adapt_settings(recipe),
            "E4": transfer.TransferExperimentConfig(recipe=recipe).adapt, "E5": ur10.adapt_settings(recipe),
            "E6": pour.e6_adapt_config(recipe=recipe)}


def test_the_papers_recipe_is_what_every_experiment_ran_before_field_for_field():
    assert settings(PAPER) == BEFORE
    assert settings(Recipe()) == BEFORE  # the paper's is the recipe unless one is named
    assert transfer.TransferExperimentConfig().adapt == BEFORE["E4"] == transfer.e4_adapt_config()
    assert PAPER.prior == "none" and wall.make_wall_cnmp(0).config.prior == "none"


def test_the_default_recipe_is_the_products_defaults_and_the_protocol_only():
    defaults = AdaptConfig()
    for name, cfg in settings(DEFAULT).items():
        changed = {f.name: getattr(cfg, f.name) for f in fields(cfg) if getattr(cfg, f.name) != getattr(defaults, f.name)}
        assert changed == {k: v for k, v in PROTOCOL[name].items() if v != getattr(defaults, k)}, name
    assert DEFAULT.prior == "auto" == CNMPConfig(n_outputs=1).prior  # the product's default model
    assert wall.make_wall_cnmp(0, DEFAULT.prior).config.prior == "auto"


def test_a_paper_setting_that_breaks_the_protocol_is_refused_naming_the_field():
    with pytest.raises(ValueError, match="max_rollouts 20 is not the protocol's 10"):
        DEFAULT.adapt_config(Protocol(10), AdaptConfig.paper(max_rollouts=20))
    with pytest.raises(ValueError, match="solution"):
        PAPER.adapt_config(Protocol(10, solution="any"), AdaptConfig.paper(max_rollouts=10))
    # the method's own fields come last under both recipes
    assert DEFAULT.adapt_config(Protocol(7), mode="rl_only") == AdaptConfig(max_rollouts=7, mode="rl_only")


@pytest.mark.parametrize("bad, words", [(lambda: Recipe("tuned"), "recipe: expected one of paper, default"),
                                        (lambda: Protocol(0), "budget"),
                                        (lambda: Protocol(5, solution="best"), "solution"),
                                        (lambda: Protocol(5, noisy_per_iter=0), "noisy_per_iter")])
def test_a_bad_recipe_or_protocol_is_refused(bad, words):
    with pytest.raises(ValueError, match=words):
        bad()


def test_the_defaults_result_lies_beside_the_papers_and_records_the_recipe():
    assert RECIPES == ("paper", "default")
    assert PAPER.result_name("e1_viapoint") == "e1_viapoint"
    assert DEFAULT.result_name("e1_viapoint") == "e1_viapoint_default"
    assert DEFAULT.to_dict() == {"name": "default", "prior": "auto"}
    # E4's pairs train their arms as the network alone under both recipes, and the result says so
    assert transfer.TransferExperimentConfig(recipe=DEFAULT).to_dict()["recipe"] == {"name": "default", "prior": "none"}


def test_the_prior_each_seed_chose_is_read_wherever_the_experiment_keeps_it():
    linear, alone = {"prior": "linear"}, {"prior": "none"}
    assert chosen_priors({"seed": 3, "model": linear}) == {3: "linear"}  # one E1 seed
    assert chosen_priors({"seed": 0, "methods": {"acnmp": {"model": alone}}}) == {0: "none"}  # E3
    runs = [{"seed": 0, "method": "acnmp", "model": linear}, {"seed": 0, "method": "promp_rl"},
            {"seed": 1, "method": "acnmp", "model": alone}]
    assert chosen_priors({"runs": runs}) == {0: "linear", 1: "none"}  # E2, E5, E6, several E1 seeds
    assert chosen_priors({"per_run": [{"seed": 0}]}) == {}  # E4: the pairs record none

