import os
import sys
from pathlib import Path

# the human render mode opens a pygame window: headless under test
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def corridor(n, rng, dim=2, half_width=1.0, length=3.0):
    """n points on the two walls of a corridor along the body x axis."""
    x = rng.uniform(-length, length, n)
    y = np.where(rng.random(n) < 0.5, half_width, -half_width) + rng.normal(0, 0.01, n)
    cols = [x, y] if dim == 2 else [x, y, rng.uniform(-0.3, 1.0, n)]
    return np.stack(cols, axis=1)
