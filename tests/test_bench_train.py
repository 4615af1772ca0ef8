"""The training-throughput benchmark runs end to end and reports what it measured."""

import json
import sys
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import bench_train  # noqa: E402


def test_bench_train_reports_throughput_and_no_training_contact(tmp_path):
    out = tmp_path / "bench_train.json"
    rows = bench_train.main(["--timesteps", "1024", "--configs", "sb3", "--env-seconds", "0.2", "--out", str(out)])
    assert [r["config"] for r in rows] == ["env alone, 64 envs", "sb3"]
    assert all(r["steps_per_s"] > 0 for r in rows)
    # the steps asked for, trained under the braking shield without a contact
    assert rows[1]["steps"] == 1024 and rows[1]["training_contact_steps"] == 0
    assert json.loads(out.read_text())["rows"][1]["config"] == "sb3"
