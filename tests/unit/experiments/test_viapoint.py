"""`acnmp experiment viapoint`: the CLI runs E1 and writes the documented JSON and figures."""
import json

import pytest

from clients.cli import main


def test_viapoint_cli_writes_json_and_plots(tmp_path, saved_figures):
    out, png = tmp_path / "e1.json", tmp_path / "e1.png"
    code = main(["experiment", "viapoint", "--seeds", "1-1", "--budget", "10", "--train-steps", "100",
                 "--json", str(out), "--plot", str(png), "--quiet"])
    assert code == 0
    s = json.loads(out.read_text())
    assert s["experiment"] == "viapoint" and s["seed"] == 1 and s["wall_time_s"] > 0
    # where the file came from: the commit and the libraries that produced it
    assert len(s["provenance"]["commit"]) == 40 and s["provenance"]["libraries"]["torch"]
    assert set(s["methods"]) == {"lfd_only", "rl_only", "acnmp"}
    for r in s["methods"].values():
        assert set(r) >= {"rollouts", "success", "error", "viapoint_error", "endpoint_error", "shape_error"}
        assert 1 <= r["rollouts"] <= 10
    assert s["methods"]["lfd_only"]["rollouts"] == 1 and not s["methods"]["lfd_only"]["success"]
    # the figures, checked on what they draw: Fig. 3 (paths and error curves) and Fig. 4 (latents)
    assert [p.name for _, p in saved_figures] == ["e1.png", "e1_latents.png"] and png.exists()
    paths, errors = saved_figures[0][0].axes
    legend = [t.get_text() for t in paths.get_legend().get_texts()]
    assert legend[0] == "demonstrations"
    assert legend[-2:] == ["extrapolated via-point", "start and end (conditioned)"]
    for name, m in (("LfD only", "lfd_only"), ("RL only", "rl_only"), ("ACNMP", "acnmp")):
        r = s["methods"][m]
        assert f"{name} ({r['rollouts']} roll-outs, err {r['error']:.3f})" in legend
        curve = next(line for line in errors.get_lines() if line.get_label() == name)
        assert curve.get_xdata()[-1] == r["rollouts"]  # the error curve ends at the roll-outs used
    # the authors' conditions: the common start, the extrapolated via-point and the common end
    cond = s["conditions"]["value"]
    star = next(line for line in paths.get_lines() if line.get_label() == "extrapolated via-point")
    ends = next(line for line in paths.get_lines() if line.get_label() == "start and end (conditioned)")
    assert star.get_xydata().tolist() == [cond[1]] and ends.get_xydata().tolist() == [cond[0], cond[2]]
    assert len([line for line in paths.get_lines() if line.get_label().startswith("_")]) == 5  # 6 demos
    latents = saved_figures[1][0].axes[0]
    before, after = latents.collections[:2]
    assert len(before.get_offsets()) == len(after.get_offsets()) == 6  # one point per demonstration


def test_bad_cli_input_is_a_clear_error(capsys):
    assert main(["experiment", "viapoint", "--budget", "0"]) == 2
    assert "--budget" in capsys.readouterr().err


@pytest.mark.parametrize("experiment", ["viapoint", "wall"])
@pytest.mark.parametrize("argv, words", [(["--seeds", "-1"], "--seeds: expected a count N (seeds 0..N-1) or the seeds"),
                                         (["--seed", "-1"], "--seed: expected an integer >= 0, got -1")])
def test_a_negative_seed_is_refused_before_any_training(experiment, argv, words, capsys):
    # numpy refuses a negative seed only when the run first draws from it, after the training.
    assert main(["experiment", experiment, *argv]) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err


def test_several_seeds_run_one_after_the_other_into_one_json(tmp_path, capsys):
    out = tmp_path / "e1.json"
    assert main(["experiment", "viapoint", "--seeds", "4,2", "--budget", "3", "--train-steps", "50", "--quiet",
                 "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert (r["seeds"], r["seed_list"]) == (2, [4, 2]) and [x["seed"] for x in r["runs"]] == [4, 2]
    assert r["methods"]["acnmp"]["rollouts"] == [x["methods"]["acnmp"]["rollouts"] for x in r["runs"]]
    printed = capsys.readouterr().out
    assert "seed 4," in printed and "seed 2," in printed and "over seeds 4, 2:" in printed
