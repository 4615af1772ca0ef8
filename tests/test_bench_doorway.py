"""The doorway benchmark (benchmarks/bench_doorway.py): a go-to-goal controller drives the
robot through a 0.75 m doorway, narrower than the shield's 0.9 m ellipse, without contact
under the braking shield and without one, the shield costing at most twice the time."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_doorway.py"
spec = importlib.util.spec_from_file_location("bench_doorway", PATH)
bench_doorway = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench_doorway)


def test_a_075_m_door_is_passed_without_contact_under_braking_within_twice_the_time(tmp_path):
    out = tmp_path / "doorway.json"
    rows = bench_doorway.main(["--doors", "0.75", "--shields", "braking", "none", "--seeds", "1", "--out", str(out)])
    by = {r["shield"]: r for r in rows}
    assert set(by) == {"braking", "none"}
    for r in by.values():
        assert r["reached"] == r["episodes"] == 1, r
        assert r["contact_steps"] == 0 and r["least_clearance"] > 0.0, r
    assert by["braking"]["time"] <= 2 * by["none"]["time"] + 1.0, by
    assert by["braking"]["tight_steps"] > 0, "the 0.9 m ellipse does not fit a 0.75 m door: the tight mode should drive it"
    data = json.loads(out.read_text())
    assert data["rows"] == rows and len(data["episodes"]) == 2


def test_the_doorway_site_is_as_named():
    site = bench_doorway.door_site(0.72)
    assert site["width"] == 0.72 and site["site"] == "doorway-0.72"
    start, goal = site["scenario"]["start"], site["goal"]
    assert start["x"] == pytest.approx(-2.5) and start["yaw"] == 0.0 and goal == pytest.approx((2.65, 0.0))
    jambs = [p["vertices"] for p in site["scenario"]["polygons"]]
    assert sorted(min(v[1] for v in j) for j in jambs)[1] == pytest.approx(0.36)  # the upper jamb's edge
    assert sorted(max(v[1] for v in j) for j in jambs)[0] == pytest.approx(-0.36)
