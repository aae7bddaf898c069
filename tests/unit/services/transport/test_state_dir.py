"""The default state directory: the user state directory, the old ./runs/<ns>/state still found."""
from __future__ import annotations

from services.transport.state_dir import default_state_dir, legacy_state_dir


def test_the_default_is_the_user_state_directory_whatever_the_current_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    said = []
    for cwd in (tmp_path / "a", tmp_path / "b"):
        assert default_state_dir("lab", cwd=cwd, say=said.append) == tmp_path / "state" / "acnmp" / "lab"
    assert said == []


def test_a_state_directory_at_the_old_default_is_still_used_and_named(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    old = legacy_state_dir("lab", tmp_path)
    (old / "skills").mkdir(parents=True)
    said = []
    assert default_state_dir("lab", cwd=tmp_path, say=said.append) == old
    assert len(said) == 1 and str(old) in said[0] and "mv" in said[0]
    assert str(tmp_path / "state" / "acnmp" / "lab") in said[0]


def test_the_new_place_wins_once_it_exists_and_an_empty_old_one_is_ignored(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    old = legacy_state_dir("lab", tmp_path)
    old.mkdir(parents=True)
    assert default_state_dir("lab", cwd=tmp_path, say=print) == tmp_path / "state" / "acnmp" / "lab"
    (old / "skills").mkdir()
    new = tmp_path / "state" / "acnmp" / "lab"
    new.mkdir(parents=True)
    assert default_state_dir("lab", cwd=tmp_path, say=print) == new


def test_up_says_where_its_state_goes(capsys):
    from clients.cli import main

    try:
        main(["up", "--help"])
    except SystemExit:
        pass
    assert "~/.local/state/acnmp/<namespace>" in " ".join(capsys.readouterr().out.split())
