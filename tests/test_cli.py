"""The ``shieldnav`` command line: every subcommand, its outputs, and named errors."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import warnings
from importlib.metadata import entry_points
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from shieldnav import Shield, cli
from shieldnav.cli import main

ROOT = Path(__file__).resolve().parents[1]


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


@pytest.mark.parametrize("yaw, omega", [(0.0, 0.0), (0.3, 0.5)])
def test_filter_3d_equals_the_3d_shield(yaw, omega, tmp_path, capsys):
    pts = np.array([[1.0, 0.1, 0.05], [0.9, -0.3, 0.2], [-1.5, 0.0, 0.0]])
    np.save(tmp_path / "scan.npy", pts)
    argv = ["filter", str(tmp_path / "scan.npy"), "--u-nom", "1.0", "0.2", "0.1", "--semi-axes", "0.9", "0.45", "0.4"]
    assert main(argv + ["--yaw", str(yaw), "--omega", str(omega)]) == 0
    got = json.loads(capsys.readouterr().out)
    c, s = np.cos(yaw), np.sin(yaw)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    want = Shield(semi_axes=(0.9, 0.45, 0.4)).filter(pts, np.array([1.0, 0.2, 0.1]), rotation=rotation, omega=np.array([0.0, 0.0, omega]))
    assert want.active and len(got["u"]) == 3 and got["num_points"] == 3
    assert got["u"] == pytest.approx(list(want.u), abs=1e-12)
    assert got["H"] == pytest.approx(want.H, abs=1e-12)


@pytest.mark.parametrize("semi_axes, u_nom, message", [
    ([], ["1", "0", "0"], "a 2D shield (2 semi-axes) takes 2 values, got 3"),
    (["--semi-axes", "1", "1", "1"], ["1", "0"], "a 3D shield (3 semi-axes) takes 3 values, got 2"),
])
def test_filter_u_nom_must_match_the_shield_dimension(semi_axes, u_nom, message, tmp_path, capsys):
    np.save(tmp_path / "scan.npy", np.ones((2, 3)))
    assert main(["filter", str(tmp_path / "scan.npy"), "--u-nom", *u_nom, *semi_axes]) == 2
    assert f"shieldnav: error: invalid `--u-nom`: {message}" in capsys.readouterr().err


@pytest.mark.parametrize("semi_axes", [["0.9", "0.45"], ["0.9", "0.45", "0.4"]])
def test_empty_csv_is_an_empty_scan_like_an_empty_npy(semi_axes, tmp_path, capsys):
    dim = len(semi_axes)
    (tmp_path / "scan.csv").write_text("")
    np.save(tmp_path / "scan.npy", np.empty((0, dim)))
    outs = []
    for name in ("scan.csv", "scan.npy"):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert main(["filter", str(tmp_path / name), "--u-nom", *["1"] * dim, "--semi-axes", *semi_axes]) == 0
        outs.append({k: v for k, v in json.loads(capsys.readouterr().out).items() if k != "solve_time_us"})
    assert outs[0] == outs[1] and outs[0]["num_points"] == 0 and outs[0]["u"] == [1.0] * dim


@pytest.mark.parametrize("name, write", [
    ("bad.csv", lambda p: p.write_text("1,2\nx,y\n")),
    ("ragged.csv", lambda p: p.write_text("1,2\n3\n")),
    ("objects.npy", lambda p: np.save(p, np.array([{"x": 1}], dtype=object), allow_pickle=True)),
    ("truncated.npy", lambda p: p.write_bytes(b"\x93NUMPY")),
])
def test_unreadable_scans_name_the_file(name, write, tmp_path, capsys):
    write(tmp_path / name)
    assert main(["filter", str(tmp_path / name), "--u-nom", "1", "0"]) == 2
    assert f"shieldnav: error: invalid `points`: cannot read {tmp_path / name}: " in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["run", "shieldnav/Nope-v0"], "invalid environment id 'shieldnav/Nope-v0'"),
        (["run", "shieldnav/ConstrictedPassage-v0", "--set", "kappa=-1"], "invalid `kappa`"),
        (["render", "shieldnav/ConstrictedPassage-v0", "--set", "kappa"], "expected key=value"),
        (["filter", "/no/such/scan.npy", "--u-nom", "1", "0"], "is not a file"),
        (["run", "shieldnav/ConstrictedPassage-v0", "--seed", "-1"], "invalid `--seed`: must be at least 0, got -1"),
        (["render", "shieldnav/ConstrictedPassage-v0", "--seed", "-1"], "invalid `--seed`: must be at least 0, got -1"),
        (["run", "shieldnav/ConstrictedPassage-v0", "--steps", "0"], "invalid `--steps`: must be at least 1, got 0"),
        (["run", "shieldnav/ConstrictedPassage-v0", "--steps", "-5"], "invalid `--steps`: must be at least 1, got -5"),
        (["run", "shieldnav/ConstrictedPassage-v0", "--set", "render_mode=human"], "invalid `--set render_mode`: the command chooses"),
        (["render", "shieldnav/ConstrictedPassage-v0", "--set", "render_mode=human"], "invalid `--set render_mode`: the command chooses"),
    ],
)
def test_errors_name_what_is_wrong(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("shieldnav: error: ") and message in err, err


def console_script():
    """The installed ``shieldnav`` script next to this interpreter (its sys.path lacks the cwd)."""
    script = shutil.which("shieldnav", path=str(Path(sys.executable).parent))
    if script is None:
        pytest.skip("no shieldnav console script next to the interpreter")
    return script


def test_console_script_runs_the_scripted_policy_anywhere(tmp_path):
    # the scripted agent ships in the package: no repository on the path
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    argv = [console_script(), "run", "shieldnav/ConstrictedPassage-v0", "--policy", "scripted", "--steps", "5"]
    for cwd in (ROOT, tmp_path):
        done = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        assert json.loads(done.stdout)["steps"] == 5


@pytest.mark.parametrize("argv, message", [
    (["run", "shieldnav/ConstrictedPassage-v0", "--gif", "{tmp}/run.mp4"], "invalid `--gif`: writing .mp4 needs imageio and imageio-ffmpeg"),
    (["run", "shieldnav/ConstrictedPassage-v0", "--gif", "{tmp}/nosuch/run.gif"], "invalid `--gif`: the folder {tmp}/nosuch does not exist"),
    (["run", "shieldnav/ConstrictedPassage-v0", "--gif", "{tmp}/run.avi"], "invalid `--gif`: expected a .gif or .mp4 file name"),
    (["run", "shieldnav/ConstrictedPassage-v0", "--gif", "{tmp}/folder.gif"], "invalid `--gif`: {tmp}/folder.gif is a folder"),
    (["render", "shieldnav/ConstrictedPassage-v0", "--out", "{tmp}/site.txt"], "invalid `--out`: expected an image file name that Pillow writes"),
    (["render", "shieldnav/ConstrictedPassage-v0", "--out", "{tmp}/site"], "invalid `--out`: expected an image file name that Pillow writes"),
    (["render", "shieldnav/ConstrictedPassage-v0", "--out", "{tmp}/nosuch/site.png"], "invalid `--out`: the folder {tmp}/nosuch does not exist"),
])
def test_output_paths_are_refused_before_the_episode(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "imageio", None)  # import imageio raises ImportError, installed or not
    monkeypatch.setattr(cli, "_make", lambda *a, **k: pytest.fail("the environment was made"))
    (tmp_path / "folder.gif").mkdir()
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("shieldnav: error: ") and err.count("\n") == 1 and message.replace("{tmp}", str(tmp_path)) in err, err


def test_an_import_error_is_a_named_error_not_a_traceback(capsys, monkeypatch):
    def needs_a_package(_):
        raise ImportError('this needs a package: pip install "shieldnav[render]"')

    monkeypatch.setattr(cli, "cmd_info", needs_a_package)
    assert main(["info"]) == 2
    assert capsys.readouterr().err == 'shieldnav: error: this needs a package: pip install "shieldnav[render]"\n'
