"""The Python `Shield`: the issue's API shape, agreement with a numpy transcription of the
paper's equations, the guarantees of Sec. III, and clear errors on bad input."""

import numpy as np
import pytest
import shieldnav
from conftest import corridor
from reference_shield import rot_z, shield_filter
from shieldnav import SHIELD_DEFAULTS, InvalidArgumentError, Shield


def rot_rpy(r, p, y):
    cr, sr, cp, sp = np.cos(r), np.sin(r), np.cos(p), np.sin(p)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    return rot_z(y) @ ry @ rx


def test_paper_defaults_are_the_constructor_defaults():
    assert SHIELD_DEFAULTS["semi_axes"] == [0.9, 0.45]
    assert (SHIELD_DEFAULTS["gamma"], SHIELD_DEFAULTS["kappa"], SHIELD_DEFAULTS["alpha"]) == (0.9, 8.0, 2.0)
    assert SHIELD_DEFAULTS["crop_radius"] == 3.5
    assert SHIELD_DEFAULTS["safety_distance"] == 0.8
    assert Shield().config == dict(SHIELD_DEFAULTS)


def test_issue_api_shape_planar_and_3d(rng):
    shield = Shield(semi_axes=(0.9, 0.45), gamma=0.9, kappa=8.0, alpha=2.0,
                    crop_radius=3.5, u_max=(1.0, 1.0), method="composite")
    pts = corridor(800, rng).astype(np.float32)
    out = shield.filter(pts, np.array([0.5, 0.9]), yaw=0.0, omega=0.0)
    for name in ("u", "H", "h_min", "grad_p", "dH_dt", "num_points", "active", "feasible", "solve_time_ns"):
        assert hasattr(out, name)
    assert out.u.shape == (2,) and out.grad_p.shape == (2,) and out.num_points == 800
    s3 = Shield(semi_axes=(0.9, 0.45, 0.3))
    out3 = s3.filter(corridor(300, rng, dim=3), [0.2, 0.1, 0.0], rotation=rot_rpy(0.1, 0.0, 0.3),
                     omega=np.array([0.0, 0.1, 0.4]))
    assert out3.u.shape == (3,) and out3.grad_p.shape == (3,)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("u_max", [None, (1.0, 0.6)])
def test_planar_filter_matches_numpy_reference(rng, dtype, u_max):
    tol = 1e-9 if dtype == np.float64 else 1e-4
    active = 0
    for trial in range(40):
        pts = corridor(200, rng, half_width=rng.uniform(0.46, 0.8)).astype(dtype)
        yaw, omega = rng.uniform(-3, 3), rng.uniform(-1, 1)
        u_nom = rng.uniform(-3, 3, 2)
        ref = shield_filter(pts.astype(np.float64), u_nom, yaw=yaw, omega=omega, u_max=u_max)
        out = Shield(u_max=u_max).filter(pts, u_nom, yaw=yaw, omega=omega)
        # (the f32 kernel's documented accuracy: |ΔH| < 1e-5, gradients to 1e-4 relative)
        assert out.H == pytest.approx(ref["H"], abs=1e-12 if dtype == np.float64 else 1e-5)
        scale = max(1.0, float(np.abs(ref["grad_p"]).max()))
        assert out.dH_dt == pytest.approx(ref["dH_dt"], abs=tol * scale)
        np.testing.assert_allclose(out.grad_p, ref["grad_p"], atol=tol * scale, rtol=0)
        if ref["feasible"]:
            np.testing.assert_allclose(out.u, ref["u"], atol=1e-6 if dtype == np.float64 else 2e-3)
        assert out.feasible == ref["feasible"]
        active += out.active
    assert active > 5


def test_3d_filter_matches_numpy_reference(rng):
    for _ in range(20):
        pts = corridor(300, rng, dim=3)
        R = rot_rpy(*rng.uniform(-0.3, 0.3, 2), rng.uniform(-3, 3))
        w = rng.uniform(-1, 1, 3)
        u_nom = rng.uniform(-1, 1, 3)
        ref = shield_filter(pts, u_nom, yaw=R, omega=w, semi_axes=(0.9, 0.45, 0.3))
        out = Shield(semi_axes=(0.9, 0.45, 0.3)).filter(pts, u_nom, rotation=R, omega=w)
        assert out.H == pytest.approx(ref["H"], abs=1e-9)
        assert out.dH_dt == pytest.approx(ref["dH_dt"], abs=1e-9)
        np.testing.assert_allclose(out.grad_p, ref["grad_p"], atol=1e-9)
        np.testing.assert_allclose(out.u, ref["u"], atol=1e-6)


def test_gradients_against_central_differences_via_world_frame(rng):
    """dH/dp by moving the robot, dH/dt by turning it, with the points fixed in the world."""
    shield = Shield(crop_radius=None)
    pts_w = corridor(120, rng) + np.array([5.0, -2.0])
    p, yaw, omega, eps = np.array([5.2, -2.1]), 0.4, 0.7, 1e-6

    def H(p, yaw):
        return shield.filter_world(pts_w, [0.0, 0.0], position=p, yaw=yaw, omega=omega).H

    out = shield.filter_world(pts_w, [0.0, 0.0], position=p, yaw=yaw, omega=omega)
    for k in range(2):
        e = np.eye(2)[k] * eps
        assert (H(p + e, yaw) - H(p - e, yaw)) / (2 * eps) == pytest.approx(out.grad_p[k], abs=1e-6)
    fd_t = (H(p, yaw + omega * eps) - H(p, yaw - omega * eps)) / (2 * eps)
    assert fd_t == pytest.approx(out.dH_dt, abs=1e-6)
    assert abs(out.dH_dt) > 1e-3


def test_gradients_against_central_differences_3d(rng):
    shield = Shield(semi_axes=(0.9, 0.45, 0.3), crop_radius=None)
    pts_w = corridor(150, rng, dim=3)
    p, R, w, eps = np.array([0.1, 0.05, 0.2]), rot_rpy(0.2, -0.1, 0.8), np.array([0.3, -0.4, 0.9]), 1e-6

    def H(p, R):
        return shield.filter_world(pts_w, [0.0] * 3, position=p, rotation=R, omega=w).H

    def turn(R, dt):
        th = np.linalg.norm(w) * dt
        k = w / np.linalg.norm(w)
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        return R @ (np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K)

    out = shield.filter_world(pts_w, [0.0] * 3, position=p, rotation=R, omega=w)
    for k in range(3):
        e = np.eye(3)[k] * eps
        assert (H(p + e, R) - H(p - e, R)) / (2 * eps) == pytest.approx(out.grad_p[k], abs=1e-6)
    assert (H(p, turn(R, eps)) - H(p, turn(R, -eps))) / (2 * eps) == pytest.approx(out.dH_dt, abs=1e-6)


def test_nonnegative_H_implies_every_point_outside_the_ellipse(rng):
    shield = Shield(crop_radius=None)
    seen = 0
    for trial in range(300):
        pts = rng.uniform(-1, 1, (rng.integers(1, 60), 2)) * rng.uniform(0.5, 3.0)
        for arr in (pts, pts.astype(np.float32)):
            out = shield.filter(arr, [0.0, 0.0])
            if out.H >= 0:
                seen += 1
                p = arr.astype(np.float64)
                assert np.all((p[:, 0] / 0.9) ** 2 + (p[:, 1] / 0.45) ** 2 - 1 >= 0)
    assert seen > 50


def test_odometry_jump_of_100m_changes_nothing(rng):
    shield = Shield(u_max=(1.0, 1.0))
    body = np.abs(corridor(500, rng, half_width=0.6))  # one wall, on the robot's left
    yaw = 0.7
    outs = []
    for offset in (0.0, 120.0, -350.0):
        pos = np.array([2.0 + offset, -1.0 + offset / 2])
        world = body @ rot_z(yaw)[:2, :2].T + pos
        u_toward_wall = rot_z(yaw)[:2, :2] @ [0.3, 2.0]
        outs.append(shield.filter_world(world, u_toward_wall, position=pos, yaw=yaw, omega=0.2))
    assert outs[0].active
    for o in outs[1:]:
        np.testing.assert_allclose(o.u, outs[0].u, atol=1e-9)
        assert o.H == pytest.approx(outs[0].H, abs=1e-9)


def kkt_holds(u, u_nom, g, b, u_max):
    """Checks the KKT conditions of min |u-u_nom|^2 s.t. g.u >= b, |u| <= u_max."""
    u, u_nom, g = map(np.asarray, (u, u_nom, g))
    assert g @ u >= b - 1e-9 and np.all(np.abs(u) <= np.asarray(u_max) + 1e-12)
    free = np.abs(np.abs(u) - u_max) > 1e-9
    d = u - u_nom
    # on free coordinates d = mu g with one mu >= 0
    mus = d[free & (np.abs(g) > 1e-9)] / g[free & (np.abs(g) > 1e-9)]
    if len(mus):
        assert np.all(mus >= -1e-9) and np.ptp(mus) < 1e-6
        mu = mus.mean()
        if mu > 1e-9:
            assert abs(g @ u - b) < 1e-7
        # coordinates at a bound: the box multiplier (mu g - d) pushes inward
        for j in np.flatnonzero(~free):
            assert (mu * g[j] - d[j]) * np.sign(u[j]) >= -1e-7
    return True


def test_filtered_command_is_kkt_optimal_with_box(rng):
    shield = Shield(u_max=(0.8, 0.5))
    checked = 0
    for _ in range(200):
        pts = corridor(150, rng, half_width=rng.uniform(0.45, 1.0))
        u_nom = rng.uniform(-2, 2, 2)
        yaw = rng.uniform(-3, 3)
        out = shield.filter(pts, u_nom, yaw=yaw, omega=0.3)
        if out.feasible:
            b = -2.0 * out.H - out.dH_dt
            assert kkt_holds(out.u, u_nom, out.grad_p, b, np.array([0.8, 0.5]))
            checked += out.active
    assert checked > 10


def door(width):
    ys = np.arange(width / 2, 3.0, 0.02)
    pts = [(x, s * y) for y in ys for x in (-0.1, 0.1) for s in (1, -1)]
    pts += [(x, s * width / 2) for x in np.arange(-0.08, 0.1, 0.02) for s in (1, -1)]
    return np.array(pts)


def test_distance_baseline_deadlocks_where_the_ellipse_passes_untouched():
    pts = door(1.3)
    comp = Shield(method="composite").filter(pts, [0.8, 0.0])
    assert comp.feasible and not comp.active
    np.testing.assert_array_equal(comp.u, [0.8, 0.0])
    dist = Shield(method="distance").filter(pts, [0.8, 0.0])
    assert not dist.feasible and dist.h_min < 0


def test_methods_hardmin_and_none():
    pts = np.array([[2.0, 0.0], [0.0, 0.6]])
    hm = Shield(method="hardmin").filter(pts, [0.0, 1.0])
    assert hm.H == pytest.approx(0.36 / 0.2025 - 1)
    assert hm.active and hm.u[1] < 1.0
    none = Shield(method="none").filter(door(0.6), [0.0, 3.0])
    np.testing.assert_array_equal(none.u, [0.0, 3.0])
    assert none.H < 0 and not none.active


@pytest.mark.parametrize("case", ["kappa100", "far", "empty", "huge"])
def test_no_nan_or_inf_at_extremes(rng, case):
    kappa = 100.0 if case == "kappa100" else 8.0
    pts = {
        "kappa100": corridor(500, rng),
        "far": rng.uniform(1e3, 1.1e3, (800, 2)),
        "empty": np.zeros((0, 2)),
        "huge": corridor(100_000, rng),
    }[case]
    shield = Shield(kappa=kappa, crop_radius=None, u_max=(1.0, 1.0))
    for arr in (pts, pts.astype(np.float32)):
        out = shield.filter(arr, [0.5, 0.5], omega=0.5)
        vals = [out.H, out.h_min, out.dH_dt, *out.u, *out.grad_p]
        assert np.all(np.isfinite(vals)), out
    if case == "huge":
        # ln(N)/kappa conservatism: 100k points make H negative even though none is inside
        assert out.H < 0 < out.h_min and out.num_points == 100_000


def test_downsampling_keeps_the_nearest_point(rng):
    pts = corridor(20_000, rng)
    full = Shield(crop_radius=None).filter(pts, [0.0, 0.0])
    thin = Shield(crop_radius=None, angular_bins=720).filter(pts, [0.0, 0.0])
    vox = Shield(crop_radius=None, voxel_size=0.1).filter(pts, [0.0, 0.0])
    assert full.H < 0 < thin.H and thin.num_points <= 720
    assert thin.h_min == full.h_min == vox.h_min
    assert vox.num_points < full.num_points


def test_points_are_read_without_copy_and_not_modified(rng):
    pts = corridor(100, rng).astype(np.float32)
    before = pts.copy()
    Shield().filter(pts, [0.1, 0.0])
    np.testing.assert_array_equal(pts, before)
    assert pts.flags.writeable


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"semi_axes": (0.9, 0.0)}, "semi_axes"),
        ({"semi_axes": (0.9,)}, "semi_axes"),
        ({"gamma": 0.0}, "gamma"),
        ({"kappa": -1.0}, "kappa"),
        ({"alpha": float("nan")}, "alpha"),
        ({"crop_radius": float("inf")}, "crop_radius"),
        ({"u_max": (1.0,)}, "u_max"),
        ({"u_max": (1.0, -1.0)}, "u_max"),
        ({"method": "cbf"}, "method"),
        ({"angular_bins": 1}, "angular_bins"),
        ({"angular_bins": 10**12}, "angular_bins"),  # (asked for 16 TB and aborted the process)
        ({"semi_axes": (1e-300, 1e-300)}, "semi_axes"),  # (1/a² overflowed: NaN blamed on the points)
    ],
)
def test_bad_constructor_arguments_raise_value_error_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        Shield(**kwargs)


def test_bad_filter_arguments_raise_value_error_naming_them():
    s = Shield()
    ok = np.zeros((3, 2))
    cases = [
        (lambda: s.filter(np.array([[np.nan, 1.0]]), [0, 0]), "points"),
        (lambda: s.filter(np.array([[9.0, 1.0], [1e9, np.inf]]), [0, 0]), "points"),
        (lambda: s.filter(np.zeros((3, 4)), [0, 0]), "points"),
        (lambda: s.filter(np.zeros(6), [0, 0]), "points"),
        (lambda: s.filter(np.zeros((3, 2), dtype=np.int64), [0, 0]), "points"),
        (lambda: s.filter(np.zeros((2, 6))[:, ::3], [0, 0]), "points"),
        (lambda: s.filter([[0.0, 1.0]], [0, 0]), "points"),
        (lambda: s.filter(ok, [0, 0, 0]), "u_nom"),
        (lambda: s.filter(ok, [0, np.nan]), "u_nom"),
        (lambda: s.filter(ok, [0, 0], yaw=np.inf), "yaw"),
        (lambda: s.filter(ok, [0, 0], rotation=np.eye(3)), "rotation"),
        (lambda: s.filter(ok, [0, 0], omega=[1.0, 2.0, 3.0]), "omega"),
        (lambda: Shield(semi_axes=(1, 1, 1)).filter(ok, [0, 0, 0]), "points"),
        (lambda: Shield(semi_axes=(1, 1, 1)).filter(np.zeros((3, 3)), [0, 0, 0], rotation=2 * np.eye(3)), "rotation"),
        (lambda: s.filter(ok, [0, 0], extra_A=np.zeros((1, 2))), "extra_A"),
        (lambda: s.filter(ok, [0, 0], extra_A=np.zeros((1, 3)), extra_b=[0.0]), "extra_A"),
    ]
    for call, name in cases:
        with pytest.raises(ValueError, match=name):
            call()
        try:
            call()
        except InvalidArgumentError:
            pass


def test_extra_linear_constraints():
    s = Shield(u_max=(1.0, 1.0))
    out = s.filter(np.array([[0.0, 0.7]]), [1.0, 1.0], extra_A=np.array([[-1.0, 0.0]]), extra_b=[-0.3])
    assert out.feasible and out.u[0] <= 0.3 + 1e-7


def test_empty_scan_is_valid():
    out = Shield(u_max=(1.0, 1.0)).filter(np.zeros((0, 2), np.float32), [2.0, 0.5])
    assert out.num_points == 0 and out.feasible and not out.active
    np.testing.assert_array_equal(out.u, [1.0, 0.5])  # clamped to the box, nothing else
    assert out.H == 0.9


def test_version_and_exports():
    assert shieldnav.__version__
    assert set(shieldnav.__all__) >= {"Shield", "ShieldOutcome", "InvalidArgumentError"}


def test_filter_world_planar_height_band_is_relative_to_the_robot():
    """A planar shield's band applies to heights above the robot: floor points 0.5 m below
    the sensor are dropped in both frames when the world position carries the robot's z."""
    a = np.linspace(0, 2 * np.pi, 36, endpoint=False)
    floor = np.c_[0.6 * np.cos(a), 0.6 * np.sin(a), -0.5 * np.ones(36)]
    shield = Shield()
    body = shield.filter(floor, [1.0, 0.0])
    world = shield.filter_world(floor + [3.0, 2.0, 0.5], [1.0, 0.0], position=[3.0, 2.0, 0.5])
    assert body.num_points == world.num_points == 0
    np.testing.assert_array_equal(world.u, [1.0, 0.0])
    # without z the robot stands at z = 0: the same points are then 0 m above it, in the band
    low = shield.filter_world(floor + [3.0, 2.0, 0.5], [1.0, 0.0], position=[3.0, 2.0])
    assert low.num_points == 36 and not low.feasible
    with pytest.raises(InvalidArgumentError, match="position.*2 values \\(x, y\\) or 3"):
        shield.filter_world(floor, [1.0, 0.0], position=[0.0, 0.0, 0.0, 0.0])


def test_rotation_as_float32_or_lists_and_its_tolerance():
    s3 = Shield(semi_axes=(0.9, 0.45, 0.3))
    pts, u = np.array([[1.2, 0.1, 0.0]]), [1.0, 0.0, 0.0]
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    ref = s3.filter(pts, u, rotation=R)
    for r in (R.astype(np.float32), R.tolist()):
        np.testing.assert_array_equal(s3.filter(pts, u, rotation=r).u, ref.u)
    # a rotation written to six decimals, 1.5e-6 off orthonormal (1e-6 refused it)
    a = 0.788628762541806
    c, s, c7, s7 = np.cos(a), np.sin(a), np.cos(0.7 * a), np.sin(0.7 * a)
    exact = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array([[1.0, 0.0, 0.0], [0.0, c7, -s7], [0.0, s7, c7]])
    rounded = np.round(exact, 6)
    assert np.abs(rounded.T @ rounded - np.eye(3)).max() > 1.5e-6
    np.testing.assert_allclose(s3.filter(pts, u, rotation=rounded).u, s3.filter(pts, u, rotation=exact).u, atol=1e-4)
    off = R.copy()
    off[0, 1] += 3e-5
    with pytest.raises(InvalidArgumentError, match="rotation.*proper rotation"):
        s3.filter(pts, u, rotation=off)
    for bad, what in ((np.eye(2), "shape"), ("eye", "3x3 array of numbers")):
        with pytest.raises(InvalidArgumentError, match=f"rotation.*{what}"):
            s3.filter(pts, u, rotation=bad)


def test_gamma_bounds_and_the_smallest_gamma_gives_a_finite_command():
    for g in (0.0, 1e-7, 1e-308, 2e6, float("nan")):
        with pytest.raises(InvalidArgumentError, match="gamma"):
            Shield(gamma=g)
    # a point exactly on the ellipse, and others, at the least gamma
    out = Shield(gamma=1e-6).filter(np.array([[0.9, 0.0], [2.0, 1.0], [-3.0, 0.2]]), [1.0, 0.0])
    assert np.isfinite(out.u).all() and out.u[0] <= 1e-9


def test_a_huge_nominal_command_is_projected_onto_the_row():
    """1e17 m/s cancelled in u_nom + mu g and left the row unmet while called feasible."""
    shield = Shield(crop_radius=None, u_max=None)
    pts = np.array([[0.5, 0.0]])
    ref = shield.filter(pts, [10.0, 0.0])
    assert ref.active and ref.feasible
    for big in (1e15, 1e17):
        out = shield.filter(pts, [big, 0.0])
        assert out.active and out.feasible
        assert out.u[0] == pytest.approx(ref.u[0], rel=1e-12) and out.u[1] == 0.0
