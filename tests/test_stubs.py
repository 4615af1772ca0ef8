"""The `_core.pyi` stubs match the native module (mypy's stubtest): every class, function and
signature, nothing missing."""

import subprocess
import sys

import pytest


@pytest.mark.expensive
def test_stubs_match_native_module():
    r = subprocess.run([sys.executable, "-m", "mypy.stubtest", "shieldnav._core"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
