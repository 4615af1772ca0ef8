"""The ``shieldnav`` command line: every subcommand, its outputs, and named errors."""

from __future__ import annotations

import json
import subprocess
import sys
from importlib.metadata import entry_points

import numpy as np
import pytest
from PIL import Image

from shieldnav import Shield
from shieldnav.cli import main


def test_console_script_points_at_main():
    (ep,) = [e for e in entry_points(group="console_scripts") if e.name == "shieldnav"]
    assert ep.load() is main


def test_python_dash_m_runs_the_same_command_line():
    done = subprocess.run([sys.executable, "-m", "shieldnav", "run", "shieldnav/NoSuchScenario-v0"], capture_output=True, text=True)
    assert done.returncode == 2 and "shieldnav: error:" in done.stderr and "NoSuchScenario" in done.stderr, done.stderr
    done = subprocess.run([sys.executable, "-m", "shieldnav", "info"], capture_output=True, text=True)
    assert done.returncode == 0 and "shieldnav/ConstrictedPassage-v0" in done.stdout, done.stderr


def test_info_lists_every_id_and_the_papers_defaults(capsys):
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    for env_id in ("shieldnav/ConstrictedPassage-v0", "shieldnav/MapInspection-v0"):
        assert env_id in out
    assert "kappa" in out and "8.0" in out


def test_render_writes_the_top_down_picture(tmp_path):
    out = tmp_path / "site.png"
    assert main(["render", "shieldnav/CorridorInspection-v0", "--seed", "3", "--out", str(out)]) == 0
    with Image.open(out) as im:
        img = np.asarray(im)
    assert img.ndim == 3 and img.shape[0] > 100 and img.std() > 5  # a drawing, not a blank


def test_run_scripted_passes_scenario_1_and_writes_a_gif(tmp_path, capsys):
    gif = tmp_path / "run.gif"
    assert main(["run", "shieldnav/ConstrictedPassage-v0", "--policy", "scripted", "--gif", str(gif)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["success"] and summary["collisions"] == 0
    with Image.open(gif) as im:
        assert im.n_frames > 10


def test_run_honours_steps_and_settings(capsys):
    assert main(["run", "shieldnav/OdometryJump-v0", "--policy", "random", "--steps", "40", "--set", "semi_axes=[0.9, 0.5]", "--shield", "hardmin"]) == 0
    assert json.loads(capsys.readouterr().out)["steps"] == 40


def test_filter_equals_the_shield(tmp_path, capsys):
    pts = np.array([[1.2, 0.3], [1.0, -0.5], [0.7, 0.1]])
    np.save(tmp_path / "scan.npy", pts)
    assert main(["filter", str(tmp_path / "scan.npy"), "--u-nom", "1.0", "0.2"]) == 0
    got = json.loads(capsys.readouterr().out)
    want = Shield().filter(pts, np.array([1.0, 0.2]), yaw=0.0, omega=0.0)
    assert got["u"] == pytest.approx(list(want.u), abs=1e-12)
    assert got["H"] == pytest.approx(want.H, abs=1e-12) and got["active"] == want.active


@pytest.mark.parametrize(
    "argv, message",
    [
        (["run", "shieldnav/Nope-v0"], "invalid environment id 'shieldnav/Nope-v0'"),
        (["run", "shieldnav/ConstrictedPassage-v0", "--set", "kappa=-1"], "invalid `kappa`"),
        (["render", "shieldnav/ConstrictedPassage-v0", "--set", "kappa"], "expected key=value"),
        (["filter", "/no/such/scan.npy", "--u-nom", "1", "0"], "is not a file"),
    ],
)
def test_errors_name_what_is_wrong(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err
