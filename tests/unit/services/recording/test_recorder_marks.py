"""What a restarted recorder starts from (services/recording/recorder.py ``earlier_events``): the
marks file of the newest earlier recording plus that recording's event ids, not every earlier file."""
from __future__ import annotations

import logging

import numpy as np

from services.recording.event_ids import SeenEvents, marks_path
from services.recording.events import rollout_event
from services.recording.recorder import earlier_events, read_marks, write_marks
from services.recording.rrd_writer import RrdWriter


def _recording(path, pub: str, sns) -> None:
    """A recording holding rollout events with ids ``<pub>/<sn>``, as a recorder writes them."""
    with RrdWriter(path) as writer:
        for sn in sns:
            writer.log_event(rollout_event("j", sn, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0]), f"{pub}/{sn}")


def test_the_newest_marks_file_and_its_recording_are_enough(tmp_path, caplog):
    first, second = tmp_path / "r.rrd", tmp_path / "r.1.rrd"
    first.write_bytes(b"never read: the second recording's marks file covers it")
    inherited = SeenEvents()
    inherited.update(f"z/1/{sn}" for sn in range(10))  # what the first recording held
    write_marks(second, inherited)  # the second recorder, at its start
    _recording(second, "z/1", range(10, 15))  # ... then killed
    with caplog.at_level(logging.WARNING):
        seen = earlier_events([first, second])
    assert not caplog.records  # the first file was not opened
    assert seen.to_json() == {"z/1": [14, [], 0]}


def test_without_a_marks_file_it_walks_back_to_the_one_before(tmp_path):
    first, second = tmp_path / "r.rrd", tmp_path / "r.1.rrd"
    write_marks(first, SeenEvents())
    _recording(first, "z/1", range(0, 4))
    _recording(second, "z/1", range(7, 9))  # its recorder died before its marks file (hypothetically)
    seen = earlier_events([first, second])
    assert seen.to_json() == {"z/1": [3, [7, 8], 0]} and seen.missed() == 3


def test_marks_files_round_trip_and_a_bad_one_is_ignored(tmp_path):
    rec = tmp_path / "r.rrd"
    assert read_marks(rec) is None
    seen = SeenEvents()
    seen.update(["a/1/0", "a/1/5", "b/2/0"])
    path = write_marks(rec, seen)
    assert path == marks_path(rec) and read_marks(rec).to_json() == seen.to_json()
    path.write_text('{"v": 1, "publishers": {"a/1": [0, [1], 0]}}')
    assert read_marks(rec) is None


def test_a_learner_jobs_rollouts_are_known_by_job_and_index_to_the_next_recorder(tmp_path):
    """A restarted learner publishes its journal's roll-outs again from a new publisher: the next
    recorder must know them by job and index, not only by the first publisher's numbers."""
    rec = tmp_path / "r.rrd"
    with RrdWriter(rec) as writer:
        for i in range(3):
            learner = rollout_event("e1-abc", i, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0])
            learner["attempt"] = 0
            writer.log_event(learner, f"z/1/{i}")
        # an experiment's roll-out (no attempt): its job name may come again in a later run
        writer.log_event(rollout_event("push-0", 0, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0]), "z/1/3")
    seen = earlier_events([rec])
    assert not seen.add("rollout/e1-abc/2")  # held: the journal's copy is a duplicate
    assert seen.add("rollout/e1-abc/3")  # a roll-out the file lacks
    assert seen.add("rollout/push-0/0")
