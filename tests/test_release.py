"""The release's build recipe agrees with itself: the workflow builds the wheel scripts/wheel.sh
builds (abi3 on manylinux_2_28), with a feature the extension crate has, and tests it with the
same wheel test."""

from __future__ import annotations

import re
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def test_the_release_workflow_and_the_wheel_script_build_the_same_wheel():
    workflow = yaml.safe_load((ROOT / ".github" / "workflows" / "release.yml").read_text())
    script = (ROOT / "scripts" / "wheel.sh").read_text()
    crate = (ROOT / "rust" / "py" / "Cargo.toml").read_text()
    assert re.search(r'^abi3 = \["pyo3/abi3-py310"\]', crate, flags=re.M)
    steps = workflow["jobs"]["wheels"]["steps"]
    build = next(s for s in steps if s.get("uses", "").startswith("PyO3/maturin-action"))
    assert "--features abi3" in build["with"]["args"] and "--features abi3" in script
    assert build["with"]["manylinux"] == "2_28" and "--compatibility manylinux_2_28" in script
    assert any("tests/test_wheel.py" in s.get("run", "") for s in steps) and "tests/test_wheel.py" in script
    assert {"x86_64", "aarch64"} == {p["target"] for p in workflow["jobs"]["wheels"]["strategy"]["matrix"]["platform"]}
    assert workflow["jobs"]["release"]["needs"] == ["wheels", "sdist", "node"]
