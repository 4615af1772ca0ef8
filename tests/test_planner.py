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


def test_fortran_ordered_points_are_refused_not_misread():
    # np.array([xs, ys]).T is Fortran-ordered: read as rows it planned toward a wrong wall
    x = np.arange(-20, 20, 0.05)
    pts = np.array([x, np.full_like(x, -2.0)]).T
    assert pts.flags.f_contiguous and not pts.flags.c_contiguous
    with pytest.raises(ValueError, match="points.*C-contiguous"):
        ViewPlanner().plan(pts, (0.0, 0.0), 0.0)
    p_d, _ = ViewPlanner().plan(np.ascontiguousarray(pts), (0.0, 0.0), 0.0)
    assert p_d[1] == pytest.approx(-0.5)


def test_planner_bounds_and_names():
    for h in (0, 10_001, 2**40):  # 2**40 aborted the process allocating the path
        with pytest.raises(ValueError, match="horizon"):
            ViewPlanner(horizon=h)
    with pytest.raises(ValueError, match="fov_h_deg"):
        ViewPlanner(fov_h_deg=200.0)
    planner = ViewPlanner()
    assert planner.update(wall_right(), (0.0, 0.0), 0.0) is not None
    # checked while the held reference stands too (they returned it)
    for args, name in [((wall_right(), (np.nan, 0.0), 0.0), "position"), ((wall_right(), (0.0, 0.0), np.nan), "yaw"),
                       ((np.array([[1e200, 1e200]]), (0.0, 0.0), 0.0), "points"), ((np.zeros((0, 2)), (0.0, 0.0), np.inf), "yaw")]:
        with pytest.raises(ValueError, match=f"`{name}`"):
            planner.update(*args)
        with pytest.raises(ValueError, match=f"`{name}`"):
            planner.plan(*args)


def test_planner_output_goes_straight_into_the_controller():
    p_d, psi = ViewPlanner().plan(wall_right(), np.array([0.0, 0.0]), 0.0)
    u, w = NominalController().command(p_d, psi, np.zeros(2), 0.0)
    assert u[0] > 0.0 and w < 0.0
    with pytest.raises(ValueError, match="goal"):
        NominalController().command((1.0, 2.0, 3.0), 0.0, (0.0, 0.0), 0.0)


def test_controller_saturates_for_any_finite_gain_and_names_its_inputs():
    u, _ = NominalController(kp=1e300).command((1e9, 1.0), 0.0, (0.0, 0.0), 0.0)  # gave NaN
    assert u[0] == pytest.approx(1.0) and 0.0 < u[1] < 1e-8
    c = NominalController()
    for args, name in [(((1e10, 0.0), 0.0, (0.0, 0.0), 0.0), "goal"), (((0.0, 0.0), 0.0, (np.nan, 0.0), 0.0), "position"),
                       (((0.0, 0.0), np.nan, (0.0, 0.0), 0.0), "goal_yaw"), (((0.0, 0.0), 0.0, (0.0, 0.0), np.inf), "yaw")]:
        with pytest.raises(ValueError, match=f"`{name}`"):
            c.command(*args)


def test_planar_plan_with_a_turned_robot_and_3d_points():
    """The body points turned into the world by the estimated yaw (R, not its transpose); a
    point straight below the robot gives no direction in the plane and is not the nearest."""
    yaw = 0.8
    body = np.c_[wall_right(), np.zeros(len(wall_right()))]
    body = np.vstack([[0.0, 0.0, -0.4], body])
    p_d, psi = ViewPlanner().plan(np.ascontiguousarray(body), (1.0, 2.0), yaw)
    d_hov = 2 * np.tan(np.radians(69.4) / 2) * 2.0 * 0.5
    c, s = np.cos(yaw), np.sin(yaw)
    np.testing.assert_allclose(p_d, [1.0 + c * d_hov + s * 0.5, 2.0 + s * d_hov - c * 0.5], atol=1e-12)
    assert psi == pytest.approx(yaw - np.pi / 2)


def test_gamma_v_acts_in_3d_planning_and_is_refused_in_the_plane():
    with pytest.raises(ValueError, match="gamma_v.*planar"):
        ViewPlanner(gamma_v=0.5)
    # a point 1 m ahead and 1 m up: nu_x = (1, 0, 1)/sqrt2, nu_z = (-1, 0, 1)/sqrt2
    pts = np.array([[1.0, 0.0, 1.0]])
    outs = {}
    for g, fov in ((1.0, 45.0), (0.0, 45.0), (0.0, 90.0)):
        p_d, psi = ViewPlanner(planar=False, gamma_v=g, fov_v_deg=fov).plan(pts, (0.0, 0.0, 0.0), 0.0)
        assert p_d.shape == (3,) and psi == pytest.approx(0.0)
        d_vov = 2 * np.tan(np.radians(fov) / 2) * np.sqrt(2) * (1 - g)
        d_insp = np.sqrt(2) - 1.5
        np.testing.assert_allclose(p_d[[0, 2]], np.array([d_insp - d_vov, d_insp + d_vov]) / np.sqrt(2), atol=1e-12)
        outs[(g, fov)] = p_d
    assert not np.allclose(outs[(0.0, 45.0)], outs[(0.0, 90.0)])
    with pytest.raises(ValueError, match="position.*3 numbers"):
        ViewPlanner(planar=False).plan(pts, (0.0, 0.0), 0.0)
