"""The shield sweep: the soft-min's conservatism against its bound, and a small episode sweep
whose outcome the composite's ln(N)/κ term decides."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents import benchmark, sweep
from tests.test_benchmark import strict_json

CP = "shieldnav/ConstrictedPassage-v0"


def test_conservatism_lies_within_the_soft_min_bounds_and_grows_like_log_n_over_kappa():
    rows = sweep.conservatism(kappas=(4.0, 8.0, 16.0), counts=(50, 500, 5000, 20000))
    for r in rows:
        assert r["lower"] - 1e-4 <= r["H"] <= r["upper"] + 1e-4, r
    for kappa in (4.0, 8.0, 16.0):
        rs = [r for r in rows if r["kappa"] == kappa]
        gap = np.array([r["upper"] - r["H"] for r in rs])
        n = np.array([r["points"] for r in rs])
        assert np.all(np.diff(gap) > 0), "more points, more conservative"
        # far from the walls of a 2 m corridor most points saturate tanh, so the gap follows
        # (γ/κ) ln N up to a constant: its slope in ln N is γ/κ within 20 %
        slope = np.polyfit(np.log(n), gap, 1)[0]
        assert math.isclose(slope, rs[0]["gamma"] / kappa, rel_tol=0.2), (kappa, slope)


def test_small_kappa_deadlocks_in_the_constricted_passage_the_paper_kappa_passes(tmp_path):
    rows = sweep.main(["--quick", "--experiments", "kappa", "--scenarios", "shieldnav/ConstrictedPassage-v0",
                       "--workers", "1", "--out", str(tmp_path), "--no-plots"])
    by = {r["setting"]: r for r in rows if r["scenario"] == "shieldnav/ConstrictedPassage-v0"}
    assert by["κ=2"]["deadlock_rate"] == 1.0 and by["κ=2"]["success_rate"] == 0.0
    assert by["κ=8"]["deadlock_rate"] == 0.0 and by["κ=8"]["success_rate"] == 1.0
    assert by["κ=8"]["with_contact"] == 0
    saved = strict_json(tmp_path / "sweep.json")  # valid JSON: no NaN deadlock time
    assert {e["summary"]["deadlock_time"] is None for e in saved["episodes"]} == {True, False}
    assert len(saved["episodes"]) == 3 and {r["setting"] for r in saved["aggregate"]} == {"κ=2", "κ=8", "κ=32"}
    assert (tmp_path / "sweep.csv").read_text().startswith("experiment,setting,scenario")


def test_rate_settings_keep_the_episode_duration():
    todo = sweep.tasks(["rates"], ["shieldnav/ConstrictedPassage-v0"], 1, quick=False)
    limits = {t["setting"]: t["kwargs"]["time_limit"] * t["kwargs"].get("dt", 0.02) for t in todo}
    assert all(math.isclose(v, 30.0) for v in limits.values()), limits


@pytest.mark.parametrize("args, message", [
    (["--seeds", "0"], "argument --seeds: must be at least 1, got 0"),
    (["--workers", "-1"], "argument --workers: must be at least 1, got -1"),
    (["--max-steps", "0"], "argument --max-steps: must be at least 1, got 0"),
    (["--scenarios", "bogus"], "argument --scenarios: unknown environment id 'bogus'"),
    (["--scenarios", CP, CP], f"argument --scenarios: {CP} given more than once"),
    (["--experiments", "kappa", "kappa"], "argument --experiments: kappa given more than once"),
    (["--out", "/proc/shieldnav"], "argument --out: cannot write to the folder /proc/shieldnav"),
])
def test_user_errors_are_usage_errors_naming_the_option_before_anything_runs(args, message, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(benchmark, "run", lambda *a: pytest.fail("episodes ran"))
    with pytest.raises(SystemExit) as exc:
        sweep.main(["--experiments", "kappa", "--workers", "1", "--out", str(tmp_path / "out"), *args])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_seeds_win_over_quick(tmp_path, monkeypatch):
    ran = []
    monkeypatch.setattr(benchmark, "run", lambda todo, *a: ran.extend(todo) or [])
    sweep.main(["--quick", "--seeds", "2", "--experiments", "kappa", "--scenarios", CP, "--out", str(tmp_path), "--no-plots"])
    assert sorted({t["seed"] for t in ran}) == [0, 1] and len(ran) == 2 * len(sweep.QUICK["kappa"])
