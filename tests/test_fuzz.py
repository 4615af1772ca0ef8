"""Property-based fuzzing of the public API (hypothesis): `Shield` keywords, `filter` and
`filter_world` arguments, `gym.make` keywords of every registered id, actions passed to `step`,
and map files whose YAML text or image bytes are mutated.

The property: a call either succeeds with finite outputs (and a `feasible` shield outcome meets
its row, the extra rows and the box to the shield's row tolerance) or raises one of the package's
errors (`InvalidArgumentError`, `MapFileError`) whose message names an argument, key or file
given; never a `PanicException`, a bare `TypeError`/`ValueError`/`OverflowError`, or an abort.

Profiles (`SHIELDNAV_FUZZ`): `short` (the default, in the test command: a few hundred examples,
derandomized, so the test command is deterministic) and `long` (`scripts/fuzz.sh`: random, with
`SHIELDNAV_FUZZ_EXAMPLES` examples per test and the example database in `.hypothesis/`). A
failing input's final (shrunk) example is written to `tests/regressions/<test>-<hash>.repr` as the
`repr` of its arguments; `test_regressions` replays every such file in every run.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import shutil
import struct
import sys
import warnings
import zlib
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from shieldnav import ENV_DEFAULTS, ENV_IDS, Shield, World
from shieldnav.exceptions import InvalidArgumentError, MapFileError
from shieldnav.maps import DEFAULT_MAP

REGRESSIONS = Path(__file__).parent / "regressions"
#: `ROW_TOLERANCE` of rust/core/src/shield/qp.rs: a row `gᵀu ≥ b` holds to `1e-9 max(|b|, 1)`.
ROW_TOLERANCE = 1e-9

_EXAMPLES = int(os.environ.get("SHIELDNAV_FUZZ_EXAMPLES", "20000"))
settings.register_profile("short", max_examples=40, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))
settings.register_profile("long", max_examples=_EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck), print_blob=True)
# `long` without shrinking: a quick look for failures while changing the strategies
settings.register_profile("explore", parent=settings.get_profile("long"), phases=[Phase.explicit, Phase.reuse, Phase.generate])
settings.load_profile(os.environ.get("SHIELDNAV_FUZZ", "short"))
_LONG = os.environ.get("SHIELDNAV_FUZZ", "short") != "short"


def _short(n: int, divisor: int = 1) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """`n` examples in the short profile; in the long one, the profile's count divided by
    `divisor` (tests that load a map each run fewer)."""
    return settings(max_examples=max(1, _EXAMPLES // divisor) if _LONG else n)


# ---------------------------------------------------------------------------------------------
# running a case: counting it, judging its error, saving it when it fails

_CASES = {"count": 0}


def _is_final() -> bool:
    try:
        from hypothesis.control import current_build_context

        return bool(current_build_context().is_final)
    except Exception:
        return False


def _save(test: str, kwargs: dict[str, Any]) -> None:
    with np.printoptions(threshold=sys.maxsize, floatmode="unique"):
        text = repr(kwargs)
    name = f"{test}-{hashlib.sha1(text.encode()).hexdigest()[:10]}.repr"
    REGRESSIONS.mkdir(exist_ok=True)
    (REGRESSIONS / name).write_text(f"# a failing input of tests/test_fuzz.py::{test}, replayed by test_regressions\n{text}\n")


def _run(test: str, check: Callable[..., None], **kwargs: Any) -> None:
    """Runs `check(**kwargs)`; any failure (a `PanicException` included, which is no
    `Exception`) becomes an `AssertionError` hypothesis shrinks, and its final example is saved."""
    _CASES["count"] += 1
    try:
        check(**kwargs)
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as err:
        if _is_final():
            _save(test, kwargs)
        if isinstance(err, AssertionError):
            raise
        raise AssertionError(f"{type(err).__module__}.{type(err).__name__}: {err}") from err


def _names(msg: str, names: Any) -> bool:
    return any(re.search(rf"(?<![A-Za-z0-9_]){re.escape(n)}(?![A-Za-z0-9_])", msg) for n in names)


def _expect_clear(err: BaseException, names: Any, files: Any = ()) -> None:
    """`err` is one of the package's errors and names one of `names` (or of the `files`)."""
    if type(err) is InvalidArgumentError or type(err) is MapFileError:
        msg = str(err)
        assert _names(msg, names) or any(str(f) in msg for f in files), f"{type(err).__name__} names none of {sorted(names)}: {msg}"
        return
    raise AssertionError(f"unclear error {type(err).__module__}.{type(err).__name__}: {err}") from err


def _finite(*values: Any) -> bool:
    return all(np.all(np.isfinite(np.asarray(v, dtype=float))) for v in values)


@pytest.fixture(autouse=True)
def _count_cases():
    """With `SHIELDNAV_FUZZ_COUNT_FILE` set, appends each test's number of cases to it (an
    interrupted run keeps the count of the tests it finished)."""
    before = _CASES["count"]
    yield
    out = os.environ.get("SHIELDNAV_FUZZ_COUNT_FILE")
    if out:
        with open(out, "a") as f:
            f.write(f"{_CASES['count'] - before}\n")


# ---------------------------------------------------------------------------------------------
# values

_floats = st.floats(allow_nan=True, allow_infinity=True)
_reals = st.floats(-1e6, 1e6, allow_nan=False)
_HOSTILE = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.sampled_from([10**400, -(10**400), 2**64, 2**63, -1, 0]),
    _floats,
    st.complex_numbers(max_magnitude=1e3),
    st.text(max_size=5),
    st.sampled_from(["1.0", "nan", "inf", "composite", "", "braking"]),
    st.binary(max_size=4),
    st.lists(_floats, max_size=4),
    st.tuples(_floats, _floats),
    st.tuples(st.booleans(), _floats),
    st.lists(st.one_of(st.none(), st.text(max_size=2), st.integers()), min_size=1, max_size=3),
    st.builds(np.array, st.lists(_floats, max_size=4)),
    st.builds(
        lambda v, t: np.array(v).astype(t) if t != "uint8" else np.array(v).clip(0, 255).astype(t),
        st.lists(_reals, min_size=1, max_size=3),
        st.sampled_from(["int64", "float32", "bool", "complex128", "uint8", "object"]),
    ),
    st.builds(lambda n: np.zeros((n, 2)), st.integers(0, 3)),
)


def _pos(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False)


# ---------------------------------------------------------------------------------------------
# the Shield's keywords

_SHIELD_KEYS: dict[str, st.SearchStrategy[Any]] = {
    "semi_axes": st.one_of(st.lists(_pos(1e-3, 10.0), min_size=2, max_size=3), st.tuples(_pos(0.05, 2.0), _pos(0.05, 2.0))),
    "gamma": _pos(1e-7, 1e7),
    "kappa": _pos(1e-4, 1e7),
    "alpha": _pos(1e-6, 1e6),
    "crop_radius": st.one_of(st.none(), _pos(1e-3, 1e4)),
    "u_max": st.one_of(st.none(), st.lists(_pos(1e-300, 1e6), min_size=2, max_size=3)),
    "method": st.sampled_from(["braking", "composite", "distance", "hardmin", "none"]),
    "safety_distance": _pos(1e-3, 10.0),
    "height_band": st.one_of(st.none(), st.tuples(_pos(-5.0, 5.0), _pos(-5.0, 5.0))),
    "voxel_size": st.one_of(st.none(), _pos(1e-6, 1e6)),
    "angular_bins": st.one_of(st.none(), st.integers(-2, 100_000)),
    "grad_eps": _pos(0.0, 1.0),
    "tracker_tau": _pos(1e-4, 10.0),
    "a_max": st.lists(_pos(1e-3, 1e3), min_size=1, max_size=3),
    "w_max": _pos(1e-3, 1e3),
    "yaw_accel_max": _pos(1e-3, 1e3),
    "dt": _pos(1e-5, 10.0),
    "brake_margin": _pos(0.0, 2.0),
    "rotation_weight": _pos(1e-4, 1e4),
}


def _keywords(keys: dict[str, st.SearchStrategy[Any]], hostile: st.SearchStrategy[Any], max_size: int = 4) -> st.SearchStrategy[dict[str, Any]]:
    """A few of `keys`, each with a plausible value or a hostile one."""
    return st.dictionaries(st.sampled_from(sorted(keys)), st.just(None), max_size=max_size).flatmap(
        lambda d: st.fixed_dictionaries({k: st.one_of(keys[k], hostile) for k in d})
    )


def check_shield_keywords(kwargs: dict[str, Any]) -> None:
    try:
        shield = Shield(**kwargs)
    except BaseException as err:
        _expect_clear(err, kwargs)
        return
    assert shield.dim in (2, 3) and shield.method in ("braking", "composite", "distance", "hardmin", "none")


@_short(60)
@given(kwargs=_keywords(_SHIELD_KEYS, _HOSTILE))
def test_shield_keywords(kwargs):
    _run("test_shield_keywords", check_shield_keywords, kwargs=kwargs)


# ---------------------------------------------------------------------------------------------
# filter and filter_world

_SCALE = st.sampled_from([1e-300, 1e-9, 1.0, 1.0, 1.0, 10.0, 1e3, 1e16, 1e155, 1e300])


def _array(shape: tuple[int, ...], dtype: Any, scale: float, data: list[float]) -> np.ndarray:
    if not math.prod(shape):
        return np.zeros(shape, dtype)
    with np.errstate(all="ignore"):
        return (np.resize(np.asarray(data, dtype=np.float64), shape) * scale).astype(dtype)


def _arrays(shape: st.SearchStrategy[tuple[int, ...]], extreme: bool = True) -> st.SearchStrategy[np.ndarray]:
    elem = st.one_of(_reals, _floats) if extreme else _reals
    dtype = st.sampled_from([np.float64, np.float64, np.float32])
    return st.builds(_array, shape,
        dtype,
        _SCALE,
        st.lists(elem, min_size=1, max_size=64),
    )


def _points(dim: int) -> st.SearchStrategy[Any]:
    good = _arrays(st.tuples(st.integers(0, 40), st.just(dim)))
    odd = _arrays(st.one_of(st.tuples(st.integers(0, 4)), st.tuples(st.integers(0, 3), st.integers(0, 5)), st.tuples(st.just(2), st.just(2), st.just(2))))
    return st.one_of(good, good, good, odd, _HOSTILE)


def _vector(n: int) -> st.SearchStrategy[Any]:
    return st.one_of(_arrays(st.just((n,))), _arrays(st.just((n,))), _arrays(st.tuples(st.integers(0, 4))), _HOSTILE)


_shields = st.fixed_dictionaries(
    {
        "method": _SHIELD_KEYS["method"],
        "dim": st.sampled_from([2, 2, 3]),
        "u_max": st.one_of(st.none(), st.lists(st.sampled_from([1e-300, 1e-3, 0.5, 1.0, 1.6, 1e6]), min_size=3, max_size=3)),
        "crop_radius": st.one_of(st.none(), st.just(3.5), _pos(1e-3, 1e4)),
        "voxel_size": st.one_of(st.none(), _pos(1e-4, 10.0)),
        "angular_bins": st.one_of(st.none(), st.integers(1, 5000)),
        "alpha": st.one_of(st.just(2.0), _pos(1e-6, 1e6)),
        "kappa": st.one_of(st.just(8.0), _pos(1e-3, 1e6)),
        "gamma": st.one_of(st.just(0.9), _pos(1e-6, 1e6)),
    }
)


def _make_shield(spec: dict[str, Any]) -> Shield | None:
    dim = spec["dim"]
    kw = {k: v for k, v in spec.items() if k != "dim"}
    kw["semi_axes"] = (0.9, 0.45) if dim == 2 else (0.9, 0.45, 0.6)
    kw["u_max"] = None if spec["u_max"] is None else spec["u_max"][:dim]
    if dim == 3:
        kw["height_band"] = None
    try:
        return Shield(**kw)
    except InvalidArgumentError:
        return None  # (the keywords' own test covers refusals)


def _rows_hold(shield: Shield, out: Any, u_nom: Any, extra_A: Any, extra_b: Any) -> None:
    """A feasible outcome's command meets its barrier row, the extra rows and the box."""
    cfg = shield.config
    dim, method = shield.dim, shield.method
    u = np.asarray(out.u, dtype=float)
    assert u.shape == (dim,)
    if method == "none":
        assert np.array_equal(u, np.asarray(u_nom, dtype=float)) and out.feasible, "the method \"none\" sends u_nom"
        return
    box = cfg["u_max"]
    if box is None and method == "braking":
        box = (*ENV_DEFAULTS["v_max"], 0.0)  # the tracker's v_max, and no climb
    if box is not None:
        assert np.all(np.abs(u) <= np.asarray(box, dtype=float)[:dim]), f"u={u} outside the box {box}"
    if method == "braking":
        omega = np.atleast_1d(np.asarray(out.omega, dtype=float))
        assert np.all(np.abs(omega) <= cfg["w_max"] * (1 + ROW_TOLERANCE)), f"omega={omega} beyond w_max={cfg['w_max']}"
    if not out.feasible or method == "braking":
        return  # the braking shield scales or brakes its row's command after the check
    g = np.asarray(out.grad_p, dtype=float)
    alpha = float(cfg["alpha"])
    b = -alpha * out.H - out.dH_dt
    if math.isfinite(b) and out.num_points > 0:
        gu = 0.0
        for j in range(dim):
            gu += float(g[j]) * float(u[j])
        assert gu >= b - ROW_TOLERANCE * max(abs(b), 1.0), f"feasible but the row misses: g·u={gu!r} < b={b!r} (u={u}, u_nom={u_nom})"
    if extra_A is not None and extra_b is not None:
        A = np.asarray(extra_A, dtype=float).reshape(-1, dim)
        c = np.asarray(extra_b, dtype=float).reshape(-1)
        for a, ck in zip(A, c):
            au = 0.0
            for j in range(dim):
                au += float(a[j]) * float(u[j])
            assert au >= ck - ROW_TOLERANCE * max(abs(ck), 1.0), f"feasible but an extra row misses: {au!r} < {ck!r}"


_FILTER_NAMES = ("points", "u_nom", "position", "yaw", "omega", "rotation", "extra_A", "extra_b", "velocity")


def check_filter(spec: dict[str, Any], args: dict[str, Any]) -> None:
    shield = _make_shield(spec)
    if shield is None:
        return
    try:
        out = shield.filter_world(**args) if "position" in args else shield.filter(**args)
    except BaseException as err:
        _expect_clear(err, _FILTER_NAMES)  # (a missing `velocity` of the braking shield included)
        return
    assert _finite(out.u, out.H, out.h_min, out.grad_p, out.dH_dt, out.omega), f"non-finite outcome {out!r}"
    assert out.num_points >= 0 and isinstance(out.feasible, bool)
    _rows_hold(shield, out, args.get("u_nom"), args.get("extra_A"), args.get("extra_b"))


def _rot_z(t: float) -> np.ndarray:
    return np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1.0]])


def _filter_args(dim: int, world: bool) -> st.SearchStrategy[dict[str, Any]]:
    optional = {
        "yaw": st.one_of(_floats, _HOSTILE),
        "omega": st.one_of(_floats, _vector(3), st.floats(-1e4, 1e4)),
        "rotation": st.one_of(_arrays(st.just((3, 3))), st.builds(_rot_z, _reals), _HOSTILE),
        "extra_A": st.one_of(_arrays(st.tuples(st.integers(0, 4), st.just(dim))), _arrays(st.tuples(st.integers(0, 3), st.integers(0, 4))), _HOSTILE),
        "extra_b": st.one_of(_arrays(st.tuples(st.integers(0, 4))), _HOSTILE),
        "velocity": st.one_of(_vector(3), st.tuples(*[st.floats(-2.0, 2.0)] * 3)),
    }
    required = {"points": _points(dim), "u_nom": _vector(dim)}
    if world:
        required["position"] = st.one_of(_vector(dim), _vector(3))
    return st.fixed_dictionaries(required, optional={k: v for k, v in optional.items()})


@_short(120)
@given(data=st.data())
def test_filter(data):
    spec = data.draw(_shields, label="shield")
    args = data.draw(_filter_args(spec["dim"], world=False), label="args")
    _run("test_filter", check_filter, spec=spec, args=args)


@_short(60)
@given(data=st.data())
def test_filter_world(data):
    spec = data.draw(_shields, label="shield")
    args = data.draw(_filter_args(spec["dim"], world=True), label="args")
    _run("test_filter_world", check_filter, spec=spec, args=args)


@_short(60)
@given(
    spec=_shields,
    row=st.tuples(_reals, _reals),
    b=st.one_of(_reals, st.floats(-1e300, 1e300)),
    u_nom=st.tuples(st.floats(-1e17, 1e17), st.floats(-1e17, 1e17)),
    y=_pos(-3.0, 3.0),
)
def test_filter_extra_rows_meet_their_tolerance(spec, row, b, u_nom, y):
    """The Clarabel path with one extra row: a valid call, so only `feasible`'s promise is judged."""
    spec = {**spec, "dim": 2}
    args = {"points": np.array([[0.0, y], [1.0, -y]]), "u_nom": np.array(u_nom), "extra_A": np.array([row]), "extra_b": np.array([b])}
    _run("test_filter_extra_rows_meet_their_tolerance", check_filter, spec=spec, args=args)


# ---------------------------------------------------------------------------------------------
# gym.make keywords and actions

_ENV_KEYS: dict[str, st.SearchStrategy[Any]] = {
    k: (
        st.booleans()
        if isinstance(v, bool)
        else st.integers(-2, 2 * v + 2) if isinstance(v, int)
        else st.floats(-2 * abs(v) - 1, 2 * abs(v) + 1) if isinstance(v, float)
        else st.lists(st.floats(-5.0, 5.0), min_size=len(v), max_size=len(v)) if isinstance(v, tuple)
        else st.just(v)
    )
    for k, v in ENV_DEFAULTS.items()
    if k not in ("lidar_columns", "lidar_channels", "time_limit")
}
_ENV_KEYS.update(
    {
        "lidar_columns": st.integers(-1, 4096),
        "lidar_channels": st.integers(-1, 64),
        "time_limit": st.one_of(st.none(), st.integers(-1, 10**6)),
        "shield": st.sampled_from(["braking", "composite", "distance", "hardmin", "none", "nope"]),
        "action_mode": st.sampled_from(["body", "world", "velocity", "x"]),
        "site_kind": st.sampled_from(["office", "tunnel", "warehouse", "x"]),
        "observation": st.sampled_from(["flat", "dict", "points", "x"]),
        "render_mode": st.sampled_from([None, "rgb_array", "x"]),
        "report_timing": st.booleans(),
        "unknown_keyword": st.integers(),
        "map_path": st.sampled_from([str(DEFAULT_MAP), "/nonexistent.yaml", "/dev/null", "", "~"]),
    }
)


def _env_kwargs(env_id: str) -> st.SearchStrategy[dict[str, Any]]:
    keys = dict(_ENV_KEYS)
    if env_id != "shieldnav/MapInspection-v0":
        keys.pop("map_path")
    # (gymnasium's `make` reads `render_mode` itself, as a string, before the env sees it)
    return _keywords(keys, _HOSTILE, max_size=3).filter(lambda kw: not ("render_mode" in kw and kw["render_mode"] is not None and not isinstance(kw["render_mode"], str)))


def check_make(env_id: str, kwargs: dict[str, Any]) -> None:
    try:
        with warnings.catch_warnings():
            # (gymnasium's own note on a render mode the env does not list; the env refuses it)
            warnings.filterwarnings("ignore", message=".*not in the possible render_modes")
            env = gym.make(env_id, **kwargs)
    except BaseException as err:
        _expect_clear(err, list(kwargs) + ["site"], files=[kwargs.get("map_path", "\0")])
        return
    try:
        obs, info = env.reset(seed=1)
        env.action_space.seed(1)  # (hypothesis replays a failing example: the same actions)
        for _ in range(3):
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            flat = obs["flat"] if isinstance(obs, dict) else obs
            assert _finite(flat, reward), f"non-finite step output {flat}, {reward}"
            if terminated or truncated:
                break
    finally:
        env.close()


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_make_keywords(env_id):
    @_short(12, 10) if env_id == "shieldnav/MapInspection-v0" else _short(30)
    @given(kwargs=_env_kwargs(env_id))
    def inner(kwargs):
        _run("test_make_keywords", check_make, env_id=env_id, kwargs=kwargs)

    inner()


_ENVS: dict[str, Any] = {}


def check_action(env_id: str, action: Any) -> None:
    env = _ENVS.get(env_id)
    if env is None:
        env = _ENVS[env_id] = gym.make(env_id).unwrapped
        env.reset(seed=0)
    try:
        obs, reward, terminated, truncated, info = env.step(action)
    except BaseException as err:
        _expect_clear(err, ["action"])
        return
    assert _finite(obs, reward), f"non-finite step output for action {action!r}"
    assert isinstance(terminated, bool) and isinstance(truncated, bool)
    if terminated or truncated:
        env.reset(seed=0)


_ACTIONS = st.one_of(
    _arrays(st.just((3,))),
    _arrays(st.just((3,)), extreme=False),
    st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3),
    _arrays(st.one_of(st.tuples(st.integers(0, 5)), st.tuples(st.integers(1, 3), st.integers(1, 3)))),
    _HOSTILE,
)


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_step_actions(env_id):
    @_short(25)
    @given(action=_ACTIONS)
    def inner(action):
        _run("test_step_actions", check_action, env_id=env_id, action=action)

    inner()


# ---------------------------------------------------------------------------------------------
# mutated map files

_MAP_DIR = DEFAULT_MAP.parent
_YAML = DEFAULT_MAP.read_text()
_IMAGE_NAME = "building_31.png"
_PNG = (_MAP_DIR / _IMAGE_NAME).read_bytes()

_TOKENS = st.sampled_from(
    [
        ":", "[", "]", "{", "}", "-", ",", "#", "'", '"', "\n", " ", "\t", "\x00", "é", "nan", "inf", "-inf", "1e400", "-1e308", "0", "-0.0", "1e-320",
        "image: ", "resolution: ", "origin: ", "negate: ", "occupied_thresh: ", "free_thresh: ", "mode: ", "trinary", "scale", "raw",
        "/dev/zero", "/dev/null", "/", "..", "missing.png", "building_31.png", "map.pgm", "true", "null", "~", "&a", "*a", "!!str", "---", "...",
    ]
)
_YAML_EDIT = st.one_of(
    st.tuples(st.just("delete"), st.integers(0, 200), st.integers(0, 40)),
    st.tuples(st.just("insert"), st.integers(0, 200), st.one_of(_TOKENS, st.text(max_size=6))),
    st.tuples(st.just("replace"), st.integers(0, 200), st.one_of(_TOKENS, st.text(max_size=6))),
    st.tuples(
        st.just("value"),
        st.sampled_from(["image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"]),
        st.one_of(_TOKENS, st.text(max_size=8), st.builds(repr, _floats)),
    ),
)


def _mutate_yaml(text: str, edits: list[tuple[Any, ...]]) -> str:
    for edit in edits:
        kind, where = edit[0], edit[1]
        if kind == "value":
            lines = [ln for ln in text.split("\n") if not ln.startswith(f"{where}:")]
            text = "\n".join(lines) + f"\n{where}: {edit[2]}\n"
            continue
        i = where % (len(text) + 1)
        if kind == "delete":
            text = text[:i] + text[i + edit[2]:]
        elif kind == "insert":
            text = text[:i] + edit[2] + text[i:]
        else:
            text = text[:i] + edit[2] + text[i + len(edit[2]):]
    return text


def _load(tmp: Path, yaml_text: str, image: bytes, image_name: str = _IMAGE_NAME) -> None:
    """`World(ros_map=...)` on the files: it loads with finite walls or is a clear error."""
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    (tmp / image_name).write_bytes(image)
    yaml_path = tmp / "map.yaml"
    yaml_path.write_bytes(yaml_text.encode("utf-8", "surrogatepass"))
    try:
        world = World(ros_map=str(yaml_path))
    except BaseException as err:
        _expect_clear(err, ["ros_map"], files=[yaml_path.name, image_name])
        return
    assert _finite(world.walls, world.true_pose)


def _scratch(name: str) -> Path:
    import tempfile

    return Path(tempfile.gettempdir()) / f"shieldnav-fuzz-{os.getpid()}" / name


def check_map_yaml(yaml_text: str) -> None:
    _load(_scratch("yaml"), yaml_text, _PNG)


@_short(40, 10)
@given(edits=st.lists(_YAML_EDIT, min_size=1, max_size=4))
def test_map_yaml_mutations(edits):
    _run("test_map_yaml_mutations", check_map_yaml, yaml_text=_mutate_yaml(_YAML, edits))


def _png_chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    out, i = [], 8
    while i + 8 <= len(data):
        (n,) = struct.unpack(">I", data[i:i + 4])
        out.append((data[i + 4:i + 8], data[i + 8:i + 8 + n]))
        i += 12 + n
    return out


def _png(chunks: list[tuple[bytes, bytes]]) -> bytes:
    return b"\x89PNG\r\n\x1a\n" + b"".join(struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d)) for t, d in chunks)


_BYTE_EDIT = st.one_of(
    st.tuples(st.just("set"), st.integers(0, len(_PNG) - 1), st.integers(0, 255)),
    st.tuples(st.just("cut"), st.integers(0, len(_PNG)), st.integers(1, 4000)),
    st.tuples(st.just("insert"), st.integers(0, len(_PNG)), st.binary(min_size=1, max_size=16)),
    st.tuples(st.just("header"), st.integers(16, 28), st.sampled_from([0, 1, 0x7F, 0xFF, 0x10, 3, 8, 16])),
    st.tuples(st.just("size"), st.integers(0, 2**32 - 1), st.integers(0, 2**32 - 1)),
)


def _mutate_png(edits: list[tuple[Any, ...]], fix_crc: bool) -> bytes:
    data = bytearray(_PNG)
    for kind, a, b in edits:
        if kind in ("set", "header"):
            if a < len(data):
                data[a] = b
        elif kind == "cut":
            del data[a:a + b]
        elif kind == "insert":
            data[a:a] = b
        elif len(data) >= 24:
            data[16:24] = struct.pack(">II", a, b)
    if fix_crc:
        return _png(_png_chunks(bytes(data)))
    return bytes(data)


def check_map_image(image: bytes) -> None:
    _load(_scratch("image"), _YAML, image)


@_short(40, 10)
@given(edits=st.lists(_BYTE_EDIT, min_size=1, max_size=4), fix_crc=st.booleans())
def test_map_image_mutations(edits, fix_crc):
    _run("test_map_image_mutations", check_map_image, image=_mutate_png(edits, fix_crc))


def check_map_pgm(header: str, body: bytes) -> None:
    yaml_text = _YAML.replace(_IMAGE_NAME, "map.pgm")
    _load(_scratch("pgm"), yaml_text, header.encode("latin-1") + body, image_name="map.pgm")


@_short(30, 10)
@given(
    magic=st.sampled_from(["P5", "P2", "P6", "P4", "P1", "P7", "PX", ""]),
    w=st.one_of(st.integers(0, 300), st.sampled_from([10**5, 2**32, 2**64, -1])),
    h=st.one_of(st.integers(0, 300), st.sampled_from([10**5, 2**32, -3])),
    maxval=st.sampled_from([255, 65535, 0, 1, 65536, 99999999999]),
    sep=st.sampled_from(["\n", " ", "\n# comment\n", "\t"]),
    fill=st.integers(0, 255),
    walls=st.booleans(),
    extra=st.integers(-50, 50),
)
def test_map_pgm_headers(magic, w, h, maxval, sep, fill, walls, extra):
    header = f"{magic}{sep}{w} {h}{sep}{maxval}\n"
    n = max(0, min(max(w, 0) * max(h, 0), 300 * 300) + extra)
    body = bytearray([fill]) * n
    if walls and 0 < w <= 300 and 0 < h <= 300 and n >= w * h:
        for i in range(w * h):
            r, c = divmod(i, w)
            if r in (0, h - 1) or c in (0, w - 1):
                body[i] = 0
    _run("test_map_pgm_headers", check_map_pgm, header=header, body=bytes(body))


# ---------------------------------------------------------------------------------------------
# saved failing inputs

_CHECKS = {
    "test_shield_keywords": check_shield_keywords,
    "test_filter": check_filter,
    "test_filter_world": check_filter,
    "test_filter_extra_rows_meet_their_tolerance": check_filter,
    "test_make_keywords": check_make,
    "test_step_actions": check_action,
    "test_map_yaml_mutations": check_map_yaml,
    "test_map_image_mutations": check_map_image,
    "test_map_pgm_headers": check_map_pgm,
}
#: Saved inputs whose fix lies outside this package's Python and shield code: name → reason.
def _saved() -> list[Any]:
    out = []
    for path in sorted(REGRESSIONS.glob("*.repr")):
        test = path.name.rsplit("-", 1)[0]
        out.append(pytest.param(path, test, id=path.name))
    return out


@pytest.mark.parametrize("path, test", _saved())
def test_regressions(path, test):
    def array(data: Any, dtype: Any = None, shape: Any = None) -> np.ndarray:  # numpy's repr of an empty array names its shape
        a = np.array(data, dtype=dtype)
        return a if shape is None else a.reshape(shape)

    namespace = {"array": array, "np": np, "inf": np.inf, "nan": np.nan}
    namespace.update({t: getattr(np, t) for t in ("float32", "float64", "int64", "uint8", "complex128", "bool_", "object_")})
    kwargs = eval(path.read_text(), namespace)  # noqa: S307 (files this module wrote)
    _CHECKS[test](**kwargs)
