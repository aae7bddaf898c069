"""Which learner serves a skill: the same answer on every learner, one owner per skill, skills
spread over the learners, and a dead owner's skills answered ``unavailable`` by the others."""
from __future__ import annotations

import pytest

from services.learner.ownership import Ownership, learner_argv, numbered_ids, owner_of, parse_learners, skill_of_job

LEARNERS = ("learner", "learner-2", "learner-3")
SKILLS = [f"skill{i}" for i in range(300)]


def test_every_skill_has_one_owner_the_same_for_every_order_of_the_list():
    owners = [owner_of(s, LEARNERS) for s in SKILLS]
    assert owners == [owner_of(s, tuple(reversed(LEARNERS))) for s in SKILLS]
    counts = {lid: owners.count(lid) for lid in LEARNERS}
    assert all(60 <= n <= 140 for n in counts.values()), counts  # spread, about a third each


def test_removing_a_learner_moves_only_its_own_skills():
    before = {s: owner_of(s, LEARNERS) for s in SKILLS}
    after = {s: owner_of(s, LEARNERS[:2]) for s in SKILLS}
    assert all(after[s] == before[s] for s in SKILLS if before[s] != "learner-3")


def test_a_learner_serves_its_skills_leaves_a_live_owners_and_names_a_dead_one():
    skill = next(s for s in SKILLS if owner_of(s, LEARNERS) == "learner-2")
    mine = next(s for s in SKILLS if owner_of(s, LEARNERS) == "learner")
    me = Ownership("learner", LEARNERS)
    assert me.decide(mine) == "serve"
    assert me.decide(skill) == "learner-2"  # not seen live yet: answered unavailable, naming it
    assert me.live() == ["learner"]  # what its job list names live: itself
    me.token_changed("learner-2", True)
    assert me.decide(skill) == "drop" and me.live() == ["learner", "learner-2"]
    me.token_changed("learner-2", False)
    assert me.decide(skill) == "learner-2" and me.live() == ["learner"]
    assert Ownership("solo").decide(skill) == "serve"  # a lone learner serves every skill


def test_job_ids_and_the_learners_option():
    assert skill_of_job("pick-place-0123456789") == "pick-place"
    assert parse_learners("learner, learner-2") == ("learner", "learner-2")
    for bad in ("", "a,a", "a,b/c"):
        with pytest.raises(ValueError, match="--learners"):
            parse_learners(bad)
    with pytest.raises(ValueError, match="not among"):
        Ownership("other", LEARNERS)


def test_the_first_learner_keeps_the_deployments_state_directory(tmp_path):
    """What a launcher hands its learners (docs/DEPLOYMENT.md, "Several learners"): the first keeps
    the deployment's state directory, so a deployment of one learner grown to several still serves
    its skills; the others get ``learners/<id>`` under it; a lone learner gets no --learners."""
    ids = numbered_ids(3)
    assert ids == ("learner", "learner-2", "learner-3")
    assert learner_argv("learner", ids, tmp_path) == ["--state-dir", str(tmp_path), "--id", "learner",
                                                      "--learners", "learner,learner-2,learner-3"]
    assert learner_argv("learner-3", ids, tmp_path)[:2] == ["--state-dir", str(tmp_path / "learners" / "learner-3")]
    assert learner_argv("learner", numbered_ids(1), tmp_path) == ["--state-dir", str(tmp_path), "--id", "learner"]
