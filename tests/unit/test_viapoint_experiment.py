"""`acnmp experiment viapoint`: the CLI runs E1 and writes the documented JSON and figures."""
import json

from clients.cli import main


def test_viapoint_cli_writes_json_and_plots(tmp_path):
    out, png = tmp_path / "e1.json", tmp_path / "e1.png"
    code = main(["experiment", "viapoint", "--seed", "1", "--budget", "30", "--train-steps", "1500",
                 "--json", str(out), "--plot", str(png), "--quiet"])
    assert code == 0
    s = json.loads(out.read_text())
    assert s["experiment"] == "viapoint" and s["seed"] == 1 and s["wall_time_s"] > 0
    assert set(s["methods"]) == {"lfd_only", "rl_only", "acnmp"}
    for r in s["methods"].values():
        assert set(r) >= {"rollouts", "success", "error", "shape_error"}
        assert 1 <= r["rollouts"] <= 30
    assert s["methods"]["lfd_only"]["rollouts"] == 1 and not s["methods"]["lfd_only"]["success"]
    assert png.stat().st_size > 10_000 and (tmp_path / "e1_latents.png").stat().st_size > 5_000


def test_bad_cli_input_is_a_clear_error(capsys):
    assert main(["experiment", "viapoint", "--budget", "0"]) == 2
    assert "--budget" in capsys.readouterr().err
