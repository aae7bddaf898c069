"""Ctrl-C of `acnmp experiment ...` (issue 36, row 10): it exited 130 with no word; it says at once
what it stops and what is (not) saved, then unwinds as before."""
from __future__ import annotations

import signal

from clients.cli import main


def test_ctrl_c_of_an_experiment_says_what_it_stops_and_what_is_not_written(tmp_path, monkeypatch, capsys):
    import acnmp_core.experiments.viapoint as e1

    real_train, interrupted = e1.train, []

    def train_after_ctrl_c(*args, **kwargs):  # the user's Ctrl-C as the real training starts
        interrupted.append(True)
        signal.raise_signal(signal.SIGINT)
        return real_train(*args, **kwargs)

    monkeypatch.setattr(e1, "train", train_after_ctrl_c)
    out = tmp_path / "e1.json"
    # Ctrl-C as in a terminal: another test of this process may have left SIGINT ignored (an
    # ignored SIGINT, as for a job started with `&`, the command leaves ignored)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        code = main(["experiment", "viapoint", "--train-steps", "5", "--budget", "5", "--quiet", "--json", str(out)])
        restored = signal.getsignal(signal.SIGINT)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert code == 130
    assert interrupted == [True]
    assert capsys.readouterr().err.splitlines() == [
        f"acnmp experiment viapoint: interrupted; stopping the run; --json {out} not written "
        "(results are written at the end)"]
    assert not out.exists()
    assert restored is signal.default_int_handler  # restored on the way out


def test_the_line_names_the_deployment_and_the_recording_kept():
    from clients.cli import build_parser
    from clients.commands.experiment import interrupted_line

    args = build_parser().parse_args(["experiment", "wall", "--distributed", "--record", "w.rrd"])
    line = interrupted_line(args)
    assert line.startswith("acnmp experiment wall: interrupted; stopping the run and the local deployment")
    assert line.endswith("the recording w.rrd keeps the roll-outs so far")
