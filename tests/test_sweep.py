"""The shield sweep: the soft-min's conservatism against its bound, and a small episode sweep
whose outcome the composite's ln(N)/κ term decides."""

from __future__ import annotations

import json
import math

import numpy as np

from agents import sweep


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
    saved = json.loads((tmp_path / "sweep.json").read_text())
    assert len(saved["episodes"]) == 3 and {r["setting"] for r in saved["aggregate"]} == {"κ=2", "κ=8", "κ=32"}
    assert (tmp_path / "sweep.csv").read_text().startswith("experiment,setting,scenario")


def test_rate_settings_keep_the_episode_duration():
    todo = sweep.tasks(["rates"], ["shieldnav/ConstrictedPassage-v0"], 1, quick=False)
    limits = {t["setting"]: t["kwargs"]["time_limit"] * t["kwargs"].get("dt", 0.02) for t in todo}
    assert all(math.isclose(v, 30.0) for v in limits.values()), limits
