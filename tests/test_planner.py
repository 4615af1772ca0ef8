"""The view planner (paper Eq. flip) and the nominal P controller, from Python."""

import numpy as np
import pytest

from shieldnav import NominalController, ViewPlanner


def wall_right(y=-2.0):
    x = np.arange(-20, 20, 0.05)
    return np.stack([x, np.full_like(x, y)], axis=1)


def test_flip_step_from_python_matches_the_equation():
    p_d, psi = ViewPlanner().plan(wall_right(), (0.0, 0.0), 0.0)
    d_hov = 2 * np.tan(np.radians(69.4) / 2) * 2.0 * (1 - 0.5)
    np.testing.assert_allclose(p_d, [d_hov, -0.5], atol=1e-9)
    assert psi == pytest.approx(-np.pi / 2)


def test_odometry_jump_fools_the_planner():
    truth, _ = ViewPlanner().plan(wall_right(), (0.0, 0.0), 0.0)
    fooled, _ = ViewPlanner().plan(wall_right(), (150.0, 0.0), 0.0)
    np.testing.assert_allclose(fooled - truth, [150.0, 0.0], atol=1e-9)


def test_path_and_hold_and_errors():
    planner = ViewPlanner(horizon=4)
    path = planner.predict_path(wall_right(), (0.0, 0.0), 0.0)
    assert len(path) == 4 and all(b[0][0] > a[0][0] for a, b in zip(path, path[1:]))
    first = planner.update(wall_right(), (0.0, 0.0), 0.0)
    held = planner.update(wall_right(), (0.3, 0.0), 0.0)
    np.testing.assert_array_equal(first[0], held[0])
    assert planner.plan(np.zeros((0, 2)), (0.0, 0.0), 0.0) is None
    with pytest.raises(ValueError, match="gamma_h"):
        ViewPlanner(gamma_h=1.5)
    with pytest.raises(ValueError, match="points"):
        planner.plan(np.zeros((3, 4)), (0.0, 0.0), 0.0)


def test_nominal_controller_is_kp_4_and_saturates_keeping_direction():
    c = NominalController(u_max=(1.0, 1.0))
    u, w = c.command((0.1, -0.05), 0.0, (0.0, 0.0), 0.0)
    np.testing.assert_allclose(u, [0.4, -0.2])
    u, _ = c.command((3.0, 1.5), 0.0, (0.0, 0.0), 0.0)
    np.testing.assert_allclose(u, [1.0, 0.5])
    with pytest.raises(ValueError, match="kp"):
        NominalController(kp=0.0)
