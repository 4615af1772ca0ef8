"""The release wheel without a Rust toolchain: installed into a fresh virtual environment with no
cargo or rustc on PATH, it runs the README's quick starts and `shieldnav info`, and its shield
kernel runs at the SIMD level this CPU has (the wheel is generic x86-64 code that chooses at run
time). Expensive: ``scripts/wheel.sh`` builds the wheel and runs this with ``SHIELDNAV_WHEEL``
naming it."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

WHEEL = os.environ.get("SHIELDNAV_WHEEL")
README = Path(__file__).resolve().parents[1] / "README.md"
pytestmark = [pytest.mark.expensive, pytest.mark.skipif(not WHEEL, reason="scripts/wheel.sh builds the wheel and runs this test (SHIELDNAV_WHEEL)")]

QUICK_START_CHECKS = """
episode = info["shieldnav_episode"]
assert episode["collisions"] == 0 and episode["steps"] > 100, episode
"""


def cpu_simd_level() -> str:
    """The level the shield's kernel should pick on this CPU (``SimdLevel::detect``'s rule)."""
    flags = set()
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("flags"):
            flags = set(line.split(":", 1)[1].split())
            break
    if {"avx2", "fma"} <= flags:
        return "avx512" if {"avx512f", "avx512vl", "avx512dq"} <= flags else "avx2"
    return "portable"


def test_the_wheel_installs_and_runs_the_quick_starts_without_a_rust_toolchain(tmp_path):
    path = os.pathsep.join(p for p in os.environ["PATH"].split(os.pathsep) if not (Path(p) / "cargo").exists() and not (Path(p) / "rustc").exists())
    assert shutil.which("cargo", path=path) is None and shutil.which("rustc", path=path) is None
    env = {**os.environ, "PATH": path, "CARGO_HOME": str(tmp_path / "no-cargo"), "RUSTUP_HOME": str(tmp_path / "no-rustup"), "SDL_VIDEODRIVER": "dummy"}
    venv = tmp_path / "venv"
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, env=env)
    python = str(venv / "bin" / "python")
    subprocess.run([python, "-m", "pip", "install", "-q", "--disable-pip-version-check", "--only-binary", ":all:", WHEEL], check=True, env=env)
    installed = time.perf_counter() - started

    info = subprocess.run([str(venv / "bin" / "shieldnav"), "info"], check=True, env=env, capture_output=True, text=True).stdout
    level = re.search(r"shield kernel: (\w+)", info)
    assert level is not None, info
    assert level.group(1) == cpu_simd_level(), info

    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    quick = README.read_text().split("## Quick start", 1)[1].split("\n## ", 1)[0]
    starts = [b for b in blocks if b in quick]
    assert len(starts) >= 2, "the README's quick start has its Python blocks"
    script = tmp_path / "quick_start.py"
    script.write_text(starts[0] + QUICK_START_CHECKS + "\n" + starts[1] + "\nassert obs.shape[0] == 64\nvec.close()\n")
    subprocess.run([python, str(script)], check=True, env=env, cwd=tmp_path)
    total = time.perf_counter() - started
    size = Path(WHEEL).stat().st_size / 2**20
    print(f"\nwheel {Path(WHEEL).name}: {size:.1f} MB; fresh venv + install {installed:.1f} s, + quick starts {total:.1f} s; kernel {level.group(1)}")
