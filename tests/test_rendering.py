"""Top-down renderer, window and video writer, on synthetic frames (numpy only, no env)."""

import dataclasses
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from shieldnav.exceptions import InvalidArgumentError, ShieldnavError
from shieldnav.rendering import COLORS, HumanWindow, RenderFrame, TopDownRenderer, fit_bounds, save_video

# 200x200 px over 10 m: 20 px/m, the robot at the origin is at pixel (col 100, row 100).
SIZE, PPM = 200, 20


def frame(**kw):
    base = dict(walls=np.empty((0, 4)), pieces=np.empty((0, 4)), inspected=np.empty(0, bool),
                obstacles=np.empty((0, 4)), pose=np.zeros(3), footprint=(1.0, 0.6), semi_axes=None,
                points=np.empty((0, 2)), crop_radius=None, u_nom=np.zeros(2), u_star=np.zeros(2),
                reference=None, ghost_pose=None)
    base.update(kw)
    return RenderFrame(**base)


def render(f, **kw):
    return TopDownRenderer(**{"width": SIZE, "height": SIZE, "view_size": 10.0, **kw}).draw(f)


def mask(img, colour):
    return np.all(img == np.array(colour, np.uint8), axis=-1)


def test_shape_dtype_and_everything_drawn():
    f = frame(walls=np.array([[-4.0, 3, 4, 3]]), pieces=np.array([[-4.0, 3, 0, 3], [0, 3, 4, 3]]),
              inspected=np.array([True, False]), obstacles=np.array([[2.0, -2, 3, -2]]),
              pose=np.array([0.0, 0, 0.4]), semi_axes=(0.9, 0.45),
              points=np.array([[1.0, 1], [4, -3]]), crop_radius=2.0, u_nom=np.array([1.0, 0]),
              u_star=np.array([0.5, 0.5]), reference=np.array([-2.0, -2, 1]),
              ghost_pose=np.array([0.3, 0.2, 0.5]), text=("t = 1.00 s", "coverage 3 %"))
    img = TopDownRenderer(width=300, height=200).draw(f)
    assert img.shape == (200, 300, 3) and img.dtype == np.uint8
    assert img.flags.c_contiguous and img.flags.writeable
    for name in ("wall", "inspected", "obstacle", "point", "point_near", "body", "ellipse",
                 "u_nom", "u_star", "reference", "text"):
        assert mask(img, COLORS[name]).any(), name


def test_wall_colours_the_expected_pixels():
    img = render(frame(walls=np.array([[-4.0, 3, 4, 3]])))  # row 100 - 3*20 = 40, cols 20..180
    wall = mask(img, COLORS["wall"])
    assert wall[39:42, 30:170].any(axis=0).all()
    assert not wall[:35].any() and not wall[46:].any()
    assert not wall[:, :15].any() and not wall[:, 186:].any()


def test_long_wall_crossing_the_view_is_not_culled():
    img = render(frame(walls=np.array([[-100.0, -2, 100, -2]])))  # row 140
    assert mask(img, COLORS["wall"])[139:142].any(axis=0).all()


def test_walls_and_orientation_y_up_x_right():
    up = mask(render(frame(walls=np.array([[-1.0, 3, 1, 3]]))), COLORS["wall"])
    down = mask(render(frame(walls=np.array([[-1.0, -3, 1, -3]]))), COLORS["wall"])
    right = mask(render(frame(walls=np.array([[3.0, -1, 3, 1]]))), COLORS["wall"])
    assert up.any() and not up[SIZE // 2:].any()
    assert down.any() and not down[: SIZE // 2].any()
    assert right.any() and not right[:, : SIZE // 2].any()


def test_view_follows_the_robot():
    f = frame(walls=np.array([[9.0, 13, 11, 13]]), pose=np.array([10.0, 10, 0]))
    wall = mask(render(f), COLORS["wall"])
    assert wall[39:42, 85:115].any(axis=0).all()


def test_inspected_piece_has_the_inspected_colour():
    f = frame(walls=np.array([[-4.0, 3, 4, 3]]), pieces=np.array([[-4.0, 3, 0, 3], [0, 3, 4, 3]]),
              inspected=np.array([True, False]))
    img = render(f)
    assert mask(img, COLORS["inspected"])[38:43, 30:95].any(axis=0).all()
    assert not mask(img, COLORS["inspected"])[:, 105:].any()
    assert mask(img, COLORS["wall"])[39:42, 110:170].any(axis=0).all()


def test_obstacle_is_orange():
    img = render(frame(obstacles=np.array([[2.0, -2, 3, -2]])))  # row 140, cols 140..160
    assert mask(img, COLORS["obstacle"])[137:144, 143:157].any(axis=0).all()


def test_points_inside_crop_radius_are_highlighted():
    near, far = [1.0, 0.5], [3.5, -1.0]
    f = frame(points=np.array([near, far]), crop_radius=2.0)
    img = render(f)
    pixels = TopDownRenderer(SIZE, SIZE, 10.0).world_to_pixel(f, [near, far])
    (cn, rn), (cf, rf) = np.floor(pixels).astype(int)
    assert (cn, rn) == (120, 90)
    assert tuple(img[rn, cn]) == COLORS["point_near"]
    assert tuple(img[rf, cf]) == COLORS["point"]
    assert mask(img, COLORS["point_near"]).sum() == 4 and mask(img, COLORS["point"]).sum() == 4
    assert mask(img, COLORS["crop"]).any()  # the crop circle, drawn faintly
    no_crop = render(dataclasses.replace(f, crop_radius=None))
    assert not mask(no_crop, COLORS["point_near"]).any()
    assert mask(no_crop, COLORS["point"]).sum() == 8


def test_body_colour_and_contact():
    img = render(frame())
    assert tuple(img[100, 100]) == COLORS["body"]
    assert mask(img, COLORS["body"]).sum() > 0.5 * (1.0 * PPM) * (0.6 * PPM)  # minus edge, tick
    hit = render(frame(contact=True))
    assert tuple(hit[100, 100]) == COLORS["contact"] and not mask(hit, COLORS["body"]).any()


def test_body_rotates_with_yaw():
    along_y = mask(render(frame(pose=np.array([0.0, 0, np.pi / 2]))), COLORS["body"])
    rows, cols = np.nonzero(along_y)
    assert np.ptp(rows) > 1.4 * np.ptp(cols)


def test_velocity_arrows_point_in_the_commanded_direction():
    img = render(frame(footprint=(0.6, 0.4), u_nom=np.array([1.0, 0]), u_star=np.array([0.0, 1])))
    nom, star = mask(img, COLORS["u_nom"]), mask(img, COLORS["u_star"])
    assert nom[97:104, 107:119].any(axis=0).all()   # 1 m/s = 20 px to the right of col 100
    assert not nom[:, :100].any() and not nom[:, 123:].any()
    assert star[81:93, 97:104].any(axis=1).all()    # straight up
    assert not star[101:].any()


def test_reference_marker_and_ghost():
    ref = render(frame(reference=np.array([-3.0, 0, 0])))  # col 40, row 100
    rows, cols = np.nonzero(mask(ref, COLORS["reference"]))
    assert abs(np.median(cols) - 45) < 8 and abs(np.median(rows) - 100) < 4
    ghost = frame(ghost_pose=np.array([-3.0, 2, 0]), walls=np.array([[-5.0, 2, -1, 2]]))
    img = render(ghost)  # pale body at col 40, row 60, drawn under everything else
    assert tuple(img[62, 40]) == COLORS["ghost_fill"]
    assert mask(img, COLORS["wall"])[59:62, 33:47].any(axis=0).all()  # the wall shows through
    assert mask(img, COLORS["ghost"])[50:70, 25:55].any()  # its outline


def test_offscreen_ghost_gets_a_border_arrow():
    img = render(frame(ghost_pose=np.array([50.0, 0, 0])))
    ghost = mask(img, COLORS["ghost"])
    rows, cols = np.nonzero(ghost)
    assert len(cols) and cols.min() > 150 and cols.max() >= 185 and abs(np.median(rows) - 100) < 4
    on_screen = mask(render(frame(ghost_pose=np.array([1.0, 1, 0]))), COLORS["ghost"])
    assert on_screen.any() and np.nonzero(on_screen)[1].max() < 135  # its outline, no arrow


def test_text_and_scale_bar():
    ink = mask(render(frame(text=("t = 1.00 s",))), COLORS["text"])
    assert ink[:20, :80].any()
    assert ink[SIZE - 13:SIZE - 10, 12:29].any(axis=0).all()  # the 1 m bar: 20 px from col 10
    assert not mask(render(frame()), COLORS["text"])[:20, :80].any()


def test_follow_false_fits_all_walls():
    walls = np.array([[10.0, 20, 60, 20], [60, 20, 60, 40], [60, 40, 10, 40], [10, 40, 10, 20]])
    f = frame(walls=walls, pose=np.array([30.0, 30, 0]))
    assert fit_bounds(walls, margin=1.0) == (9.0, 19.0, 61.0, 41.0)
    r = TopDownRenderer(300, 200, follow=False)
    wall = mask(r.draw(f), COLORS["wall"])
    rows, cols = np.nonzero(wall)
    assert cols.min() < 15 and cols.max() > 285  # 52 m over 300 px: the width is the limit
    assert rows.min() > 40 and rows.max() < 160
    corners = r.world_to_pixel(f, walls.reshape(-1, 2))
    assert (corners >= 0).all() and (corners[:, 0] < 300).all() and (corners[:, 1] < 200).all()
    assert not mask(TopDownRenderer(300, 200).draw(f), COLORS["wall"]).any()  # follow: all far
    fixed = TopDownRenderer(300, 200, follow=False, bounds=(0, 0, 200, 100))
    assert np.nonzero(mask(fixed.draw(f), COLORS["wall"]))[1].max() < 100


@pytest.mark.parametrize("kw, name", [
    ({"width": 0}, "width"), ({"height": -5}, "height"), ({"width": 10.5}, "width"),
    ({"view_size": 0.0}, "view_size"), ({"view_size": float("nan")}, "view_size"),
    ({"follow": "yes"}, "follow"), ({"bounds": (0, 0, 0, 1)}, "bounds"),
    ({"bounds": (0, 0, 1)}, "bounds"), ({"margin": -1.0}, "margin"),
])
def test_bad_renderer_arguments(kw, name):
    with pytest.raises(InvalidArgumentError, match=name):
        TopDownRenderer(**kw)


@pytest.mark.parametrize("kw, name", [
    ({"walls": np.zeros((3, 3))}, "walls"), ({"inspected": np.ones(2, bool)}, "inspected"),
    ({"pose": np.array([0.0, np.nan, 0])}, "pose"), ({"footprint": (1.0, -0.5)}, "footprint"),
    ({"semi_axes": (0.0, 0.5)}, "semi_axes"), ({"points": np.zeros((4, 3))}, "points"),
    ({"crop_radius": -1.0}, "crop_radius"), ({"u_nom": np.zeros(3)}, "u_nom"),
    ({"ghost_pose": np.zeros(2)}, "ghost_pose"), ({"text": "one line"}, "text"),
    ({"contact": "no"}, "contact"), ({"pieces": np.zeros((3, 4)), "inspected": np.array([2.0, 0.0, 1.0])}, "inspected: expected bools"),
])
def test_bad_frame_fields(kw, name):
    with pytest.raises(InvalidArgumentError, match=name):
        frame(**kw)


def test_draw_rejects_non_frames():
    with pytest.raises(InvalidArgumentError, match="frame"):
        TopDownRenderer().draw({"pose": np.zeros(3)})


def test_save_video_gif_round_trip(tmp_path):
    r = TopDownRenderer(120, 80)
    frames = [r.draw(frame(walls=np.array([[-5.0, k * 0.5, 5, k * 0.5]]))) for k in range(5)]
    path = tmp_path / "episode.gif"
    save_video(frames, path, fps=20)
    with Image.open(path) as gif:
        assert gif.n_frames == 5 and gif.size == (120, 80)
        assert gif.info["duration"] == 50


@pytest.mark.parametrize("frames, path, name", [
    ([], "a.gif", "frames"),
    ([np.zeros((4, 4, 3), np.uint8), np.zeros((4, 5, 3), np.uint8)], "a.gif", r"frames\[1\]"),
    ([np.zeros((4, 4, 3))], "a.gif", r"frames\[0\]"),
    ([np.zeros((4, 4), np.uint8)], "a.gif", r"frames\[0\]"),
    ([np.zeros((4, 4, 3), np.uint8)], "a.avi", "path"),
])
def test_save_video_rejects_bad_input(tmp_path, frames, path, name):
    with pytest.raises(InvalidArgumentError, match=name):
        save_video(frames, tmp_path / path)
    with pytest.raises(InvalidArgumentError, match="fps"):
        save_video([np.zeros((4, 4, 3), np.uint8)], tmp_path / "a.gif", fps=0)


def test_optional_dependencies_name_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pygame", None)
    monkeypatch.setitem(sys.modules, "imageio", None)
    window = HumanWindow(64, 48, fps=30)  # constructing needs no pygame
    with pytest.raises(ImportError, match=r"shieldnav\[render\]"):
        window.show(np.zeros((48, 64, 3), np.uint8))
    with pytest.raises(ImportError, match=r"shieldnav\[render\]"):
        save_video([np.zeros((16, 16, 3), np.uint8)], tmp_path / "a.mp4")
    with pytest.raises(InvalidArgumentError, match="rgb"):
        window.show(np.zeros((64, 48, 3), np.uint8))
    window.close()  # a no-op when never opened


def test_the_render_extra_holds_what_its_hints_name():
    tomllib = pytest.importorskip("tomllib")
    root = Path(__file__).resolve().parents[1]
    extra = tomllib.loads((root / "pyproject.toml").read_text())["project"]["optional-dependencies"]["render"]
    names = {re.split(r"[<>=\[]", e)[0] for e in extra}
    assert {"pygame", "imageio", "imageio-ffmpeg"} <= names, names


def test_render_fps_is_the_control_rate():
    import gymnasium as gym

    assert gym.make("shieldnav/ConstrictedPassage-v0").metadata["render_fps"] == 50
    env = gym.make("shieldnav/ConstrictedPassage-v0", dt=0.04)
    assert env.metadata["render_fps"] == 25 and env.unwrapped.metadata["render_fps"] == 25


def test_canvas_reuse_does_not_leak_between_frames():
    r = TopDownRenderer(SIZE, SIZE, 10.0)
    first = r.draw(frame(walls=np.array([[-4.0, 3, 4, 3]]), points=np.array([[2.0, 2]])))
    kept = first.copy()
    second = r.draw(frame())
    assert np.array_equal(first, kept)  # each call returns a new array
    assert mask(first, COLORS["wall"]).any()
    assert not mask(second, COLORS["wall"]).any() and not mask(second, COLORS["point"]).any()


def test_empty_frame_and_unbounded_fit_view():
    for r in (TopDownRenderer(64, 48), TopDownRenderer(64, 48, follow=False)):
        img = r.draw(frame(footprint=(2.0, 1.0)))  # no walls: follow=False centres the robot
        assert img.shape == (48, 64, 3) and tuple(img[24, 32]) == COLORS["body"]


def test_human_window_with_a_stand_in_pygame(monkeypatch):
    import types

    calls, events = [], [[], [types.SimpleNamespace(type="quit")]]
    screen = types.SimpleNamespace(blit=lambda surface, at: calls.append(("blit", surface, at)))
    pg = types.SimpleNamespace(
        QUIT="quit",
        display=types.SimpleNamespace(init=lambda: calls.append("init"),
                                      get_driver=lambda: "x11",
                                      set_mode=lambda size: calls.append(("mode", size)) or screen,
                                      set_caption=lambda title: None,
                                      flip=lambda: calls.append("flip"),
                                      quit=lambda: calls.append("quit")),
        event=types.SimpleNamespace(get=lambda: events.pop(0)),
        image=types.SimpleNamespace(frombuffer=lambda buf, size, fmt: (bytes(buf), size, fmt)),
        time=types.SimpleNamespace(Clock=lambda: types.SimpleNamespace(tick=lambda fps: None)))
    monkeypatch.setitem(sys.modules, "pygame", pg)
    window = HumanWindow(64, 48, fps=30)
    rgb = np.random.default_rng(0).integers(0, 255, (48, 64, 3), dtype=np.uint8)
    assert window.show(rgb) is True
    assert calls[:2] == ["init", ("mode", (64, 48))] and calls[-1] == "flip"
    (_, (data, size, fmt), at) = calls[2]
    assert data == rgb.tobytes() and size == (64, 48) and fmt == "RGB" and at == (0, 0)
    assert window.show(rgb) is False and calls[-1] == "quit"  # the user closed the window
    window.close()
    assert calls.count("quit") == 1


def test_human_window_without_a_display_is_an_error(monkeypatch):
    """SDL without a display falls back to its offscreen driver: render_mode="human" then
    drew nowhere and returned None silently."""
    import types

    calls = []
    pg = types.SimpleNamespace(display=types.SimpleNamespace(init=lambda: calls.append("init"), get_driver=lambda: "offscreen", quit=lambda: calls.append("quit")))
    monkeypatch.setitem(sys.modules, "pygame", pg)
    monkeypatch.delenv("SDL_VIDEODRIVER", raising=False)
    with pytest.raises(ShieldnavError, match=r"needs a display.*rgb_array.*\(shieldnav\.rendering\.save_video\)"):
        HumanWindow(64, 48).show(np.zeros((48, 64, 3), np.uint8))
    import shieldnav.rendering

    assert callable(shieldnav.rendering.save_video), "the function the message names"
    # 0/1 integers are bools; a frame takes them
    assert frame(pieces=np.zeros((2, 4)), inspected=np.array([0, 1])).inspected.tolist() == [False, True]
    assert calls == ["init", "quit"]
    # asked for on purpose, it draws nowhere without complaint
    monkeypatch.setenv("SDL_VIDEODRIVER", "offscreen")
    pg.display.set_mode = lambda size: types.SimpleNamespace(blit=lambda *a: None)
    pg.display.set_caption = lambda title: None
    pg.display.flip = lambda: None
    pg.event = types.SimpleNamespace(get=lambda: [])
    pg.QUIT = "quit"
    pg.image = types.SimpleNamespace(frombuffer=lambda *a: None)
    pg.time = types.SimpleNamespace(Clock=lambda: types.SimpleNamespace(tick=lambda fps: None))
    assert HumanWindow(64, 48).show(np.zeros((48, 64, 3), np.uint8)) is True


def test_status_line_shows_no_h_before_the_first_step():
    import gymnasium as gym

    env = gym.make("shieldnav/ConstrictedPassage-v0", render_mode="rgb_array")
    env.reset(seed=0)
    text = env.unwrapped.render_frame().text
    assert "H = n/a" in text[1] and "nan" not in " ".join(text)
    env.step(np.zeros(env.action_space.shape, np.float32))
    assert "H = n/a" not in env.unwrapped.render_frame().text[1]
    env.close()
