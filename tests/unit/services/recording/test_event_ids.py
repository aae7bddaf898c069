"""The recorder's record of event ids (services/recording/event_ids.py): each id taken once in any
order, memory bounded per publisher, the missed count exact, the state carried across restarts."""
from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from services.recording.event_ids import IndexRanges, SeenEvents, split_event_id

PUBLISHERS = ("z1/1", "z1/2", "z2/7")

#: (publisher, sequence number) pairs in any order, with repeats: what caches, live samples and
#: ids read back from files give a recorder, at their most hostile.
ids_strategy = st.lists(st.tuples(st.sampled_from(PUBLISHERS), st.integers(0, 300)), max_size=400)


def _id(pub: str, sn: int) -> str:
    return f"{pub}/{sn}"


@settings(max_examples=200, deadline=None)
@given(ids_strategy)
def test_each_id_is_new_exactly_once_in_any_order(pairs):
    seen, model = SeenEvents(max_runs=1000), set()  # runs never given up: must equal a plain set
    for pub, sn in pairs:
        assert seen.add(_id(pub, sn)) == ((pub, sn) not in model)
        model.add((pub, sn))
    for pub in PUBLISHERS:
        for sn in range(0, 302):
            assert (_id(pub, sn) in seen) == ((pub, sn) in model)
    # missed: per publisher, the numbers below its newest one that never came
    expected = sum(max(sn for p, sn in model if p == pub) + 1 - sum(1 for p, _ in model if p == pub)
                   for pub in {p for p, _ in model})
    assert seen.missed() == expected


@settings(max_examples=300, deadline=None)
@given(ids_strategy, st.integers(1, 4))
def test_with_few_runs_memory_is_bounded_and_nothing_is_taken_twice(pairs, max_runs):
    seen, taken = SeenEvents(max_runs=max_runs), set()
    for pub, sn in pairs:
        if seen.add(_id(pub, sn)):
            assert (pub, sn) not in taken  # never recorded twice, whatever was given up
            taken.add((pub, sn))
        assert _id(pub, sn) in seen
        assert all(len(runs) <= 2 * max_runs for _mark, runs, _lost in seen.to_json().values())
    # every number below a publisher's newest recorded one is recorded or counted missed
    expected = sum(max(sn for p, sn in taken if p == pub) + 1 - sum(1 for p, _ in taken if p == pub)
                   for pub in {p for p, _ in taken})
    assert seen.missed() == expected


@settings(max_examples=200, deadline=None)
@given(ids_strategy, ids_strategy)
def test_the_state_survives_json_like_a_restarted_recorder_needs(before, after):
    """A recorder's marks file holds its state; the next one goes on from it as if never stopped."""
    one, restarted = SeenEvents(), None
    for pub, sn in before:
        one.add(_id(pub, sn))
    restarted = SeenEvents.from_json(json.loads(json.dumps(one.to_json())))
    assert restarted.missed() == one.missed()
    for pub, sn in after:
        assert restarted.add(_id(pub, sn)) == one.add(_id(pub, sn))
    assert restarted.to_json() == one.to_json()


def test_in_order_delivery_keeps_one_mark_per_publisher_and_a_gap_one_run():
    seen = SeenEvents()
    for sn in range(10_000):
        assert seen.add(_id("z/1", sn))
    assert seen.to_json() == {"z/1": [9_999, [], 0]}
    # a restarted recorder's first event after 7 were lost from the cache: one run, 7 missed
    assert seen.add(_id("z/1", 10_007)) and seen.add(_id("z/1", 10_008))
    assert seen.to_json() == {"z/1": [9_999, [10_007, 10_008], 0]} and seen.missed() == 7
    assert not seen.add(_id("z/1", 5)) and not seen.add(_id("z/1", 10_008))  # replayed: duplicates


def test_the_oldest_gap_is_given_up_beyond_max_runs_and_stays_missed():
    seen = SeenEvents(max_runs=2)
    for sn in (0, 2, 4, 6):  # gaps at 1, 3, 5: three runs above the mark 0, one too many
        seen.add(_id("z/1", sn))
    assert seen.to_json() == {"z/1": [2, [4, 4, 6, 6], 1]} and seen.missed() == 3
    assert not seen.add(_id("z/1", 1))  # given up: taken for a duplicate, still counted missed
    assert seen.add(_id("z/1", 3)) and seen.missed() == 2


@pytest.mark.parametrize("bad", ["", "z/1", "z/1/x", "z/1/-3", "7"])
def test_a_malformed_id_is_refused(bad):
    with pytest.raises(ValueError):
        split_event_id(bad)
    with pytest.raises(ValueError):
        SeenEvents().add(bad)


@pytest.mark.parametrize("data", [{"z/1": [0, [3], 0]}, {"z/1": [5, [4, 9], 0]}, {"z/1": [0, [9, 7], 0]},
                                  {"z/1": 3}, {"z/1": [0, None, 0]}])
def test_a_corrupt_state_is_refused(data):
    with pytest.raises(ValueError):
        SeenEvents.from_json(data)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 300), max_size=300))
def test_the_ranges_a_recorder_reports_hold_exactly_the_indices_recorded(indices):
    """What a recorder's status says it holds of a job (``held``), through the wire form and back."""
    seen = SeenEvents(max_runs=1000)
    for i in indices:
        seen.add(f"rollout/e1-0123456789/{i}")
    held = IndexRanges.from_wire(seen.ranges("rollout/e1-0123456789"))
    assert {i for i in range(-2, 305) if i in held} == set(indices)
    assert seen.ranges("rollout/another") == [] and 0 not in IndexRanges() and 10**12 in IndexRanges.everything()


@pytest.mark.parametrize("bad", [[[3, 2]], [[0, 2], [2, 4]], [[0, True]], [[0]], [(0, 1)], "0-1", [[-1, 0]]])
def test_ranges_that_are_not_sorted_disjoint_pairs_are_refused(bad):
    with pytest.raises(ValueError):
        IndexRanges.from_wire(bad)
