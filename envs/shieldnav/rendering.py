"""Top-down rendering of a corridor-inspection episode.

:class:`TopDownRenderer` turns a :class:`RenderFrame` (plain numpy arrays, no Rust object) into
a ``(height, width, 3)`` uint8 image with Pillow's C drawing routines: walls, inspected wall
pieces, moving obstacles, LIDAR points (red inside the shield's crop radius), the robot body,
the shield ellipse, the nominal and filtered velocities, the reference view, the odometry
"ghost", a scale bar and status lines. World y points up on screen. :class:`HumanWindow` shows
frames in a pygame window; :func:`save_video` writes a GIF (Pillow) or an MP4 (imageio). pygame
and imageio are optional: ``pip install "shieldnav[render]"``.
"""

from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Sequence

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from .exceptions import InvalidArgumentError, ShieldnavError

_EXTRA = 'pip install "shieldnav[render]"'

#: RGB colour of each drawn element (read-only), for legends and tests.
COLORS = MappingProxyType({
    "background": (246, 246, 242), "wall": (70, 70, 70), "inspected": (30, 170, 60),
    "obstacle": (245, 140, 20), "point": (150, 150, 150), "point_near": (230, 25, 25),
    "crop": (205, 205, 225), "body": (240, 200, 40), "contact": (215, 45, 45),
    "body_edge": (90, 70, 10), "ellipse": (40, 100, 220), "u_nom": (230, 0, 230),
    "u_star": (110, 30, 160), "reference": (0, 190, 210), "ghost": (80, 80, 200),
    "ghost_fill": (214, 214, 238), "text": (20, 20, 20),
})
_RING = np.linspace(0, 2 * math.pi, 65)
_RING = np.column_stack([np.cos(_RING), np.sin(_RING)])  # unit circle, closed


def _arr(name, value, shape, dtype=np.float64):
    """``value`` as an array of ``shape`` (-1: any length), finite if float; else an error."""
    try:
        a = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as err:
        raise InvalidArgumentError(f"{name}: not a numeric array ({err})") from None
    if a.size == 0 and shape[0] == -1:
        a = a.reshape((0, *shape[1:]))
    if a.ndim != len(shape) or any(s not in (-1, n) for s, n in zip(shape, a.shape)):
        want = str(tuple("n" if s == -1 else s for s in shape)).replace("'", "")
        raise InvalidArgumentError(f"{name}: expected shape {want}, got {a.shape}")
    if dtype is np.float64 and not np.isfinite(a).all():
        raise InvalidArgumentError(f"{name}: contains NaN or inf")
    return a


def _positive(name, value, allow_zero=False, kind=numbers.Real):
    """``value`` as a finite number > 0 (>= 0 with ``allow_zero``) of ``kind``; else an error."""
    ok = isinstance(value, kind) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < 0 or (value == 0 and not allow_zero):
        what = ("non-negative " if allow_zero else "positive ") + (
            "integer" if kind is numbers.Integral else "finite number")
        raise InvalidArgumentError(f"{name}: expected a {what}, got {value!r}")
    return int(value) if kind is numbers.Integral else float(value)


@dataclass(frozen=True, eq=False)
class RenderFrame:
    """Everything drawn in one image, in the world frame (metres, radians).

    Fields are converted (arrays to float64, ``inspected`` from bools or 0/1 integers to bool)
    and validated on construction (``contact`` must be a bool); a malformed one raises
    :class:`InvalidArgumentError` naming it.
    """

    walls: np.ndarray                   # (M, 4) static wall segments [ax, ay, bx, by]
    pieces: np.ndarray                  # (P, 4) wall pieces (sub-segments of walls)
    inspected: np.ndarray               # (P,) bool: piece already inspected (thick green)
    obstacles: np.ndarray               # (K, 4) segments of the moving obstacles now (orange)
    pose: np.ndarray                    # (3,) true pose x, y, yaw
    footprint: tuple[float, float]      # body length (along the heading), width
    semi_axes: tuple[float, float] | None  # shield ellipse (a along heading, b across) or None
    points: np.ndarray                  # (n, 2) valid LIDAR returns
    crop_radius: float | None           # points this close to the robot are drawn red
    u_nom: np.ndarray                   # (2,) nominal velocity (m/s): arrow, 1 m/s = 1 m
    u_star: np.ndarray                  # (2,) filtered velocity (m/s): arrow
    reference: np.ndarray | None        # (3,) reference view pose x, y, yaw, or None
    ghost_pose: np.ndarray | None       # (3,) odometry estimate x, y, yaw, or None
    text: Sequence[str] = ()            # status lines, top-left
    contact: bool = False               # body drawn red when in contact

    def __post_init__(self):
        fix = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        for name, shape in (("walls", (-1, 4)), ("pieces", (-1, 4)), ("obstacles", (-1, 4)),
                            ("pose", (3,)), ("points", (-1, 2)), ("u_nom", (2,)),
                            ("u_star", (2,)), ("reference", (3,)), ("ghost_pose", (3,))):
            if getattr(self, name) is not None or name not in ("reference", "ghost_pose"):
                fix(name, _arr(name, getattr(self, name), shape))
        inspected = _arr("inspected", self.inspected, (len(self.pieces),), None)
        if inspected.dtype != bool and not (inspected.dtype.kind in "iu" and np.isin(inspected, (0, 1)).all()):
            raise InvalidArgumentError(f"inspected: expected bools (or 0/1), got {inspected.dtype} values")
        fix("inspected", inspected.astype(bool))
        for name in ("footprint", "semi_axes"):
            if getattr(self, name) is not None or name == "footprint":
                v = _arr(name, getattr(self, name), (2,)).tolist()
                fix(name, tuple(_positive(f"{name}[{i}]", x) for i, x in enumerate(v)))
        if self.crop_radius is not None:
            fix("crop_radius", _positive("crop_radius", self.crop_radius, allow_zero=True))
        if isinstance(self.text, str):
            raise InvalidArgumentError("text: expected a sequence of lines, got one str")
        fix("text", tuple(str(t) for t in self.text))
        if not isinstance(self.contact, (bool, np.bool_)):
            raise InvalidArgumentError(f"contact: expected True or False, got {self.contact!r}")
        fix("contact", bool(self.contact))


def fit_bounds(walls, margin: float = 1.0) -> tuple[float, float, float, float]:
    """Bounding box ``(xmin, ymin, xmax, ymax)`` of ``walls`` (M, 4), grown by ``margin`` m."""
    xy = _arr("walls", walls, (-1, 4)).reshape(-1, 2)
    if not len(xy):
        raise InvalidArgumentError("walls: cannot fit bounds to an empty wall set")
    m = _positive("margin", margin, allow_zero=True)
    (x0, y0), (x1, y1) = xy.min(axis=0) - m, xy.max(axis=0) + m
    return float(x0), float(y0), float(x1), float(y1)


def _place(local, pose):
    """Body-frame points (n, 2) to the world frame of ``pose``."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return local @ np.array([[c, s], [-s, c]]) + pose[:2]


def _body(length, width, pose, n=4):
    """Rounded-rectangle outline (4n vertices), length along the heading, centred on ``pose``."""
    r = 0.2 * min(length, width)
    cx, cy = length / 2 - r, width / 2 - r
    centres = np.repeat([[cx, cy], [-cx, cy], [-cx, -cy], [cx, -cy]], n, axis=0)
    ang = (np.arange(4)[:, None] + np.linspace(0, 1, n)).ravel() * (math.pi / 2)
    return _place(centres + r * np.column_stack([np.cos(ang), np.sin(ang)]), pose)


def _arrow(d, a, b, colour, width=3):
    """Arrow from pixel ``a`` to pixel ``b``; nothing if shorter than one pixel."""
    v = b - a
    n = math.hypot(*v)
    if n < 1.0:
        return
    u, head = v / n, min(10.0, 0.45 * n)
    base, side = b - u * head, np.array([-u[1], u[0]]) * head * 0.5
    d.line([*a, *base], fill=colour, width=width)
    d.polygon([*b, *(base + side), *(base - side)], fill=colour)


class TopDownRenderer:
    """Draws :class:`RenderFrame` s as ``(height, width, 3)`` uint8 images.

    ``follow=True``: a ``view_size``-metre square (over the shorter image side) centred on the
    robot. ``follow=False``: the fixed ``bounds`` ``(xmin, ymin, xmax, ymax)`` if given, else
    the walls' bounding box grown by ``margin`` metres (per frame), aspect ratio preserved.
    An instance owns one canvas: do not call :meth:`draw` from several threads at once.
    """

    def __init__(self, width: int = 640, height: int = 640, view_size: float = 14.0,
                 follow: bool = True, bounds: Sequence[float] | None = None, margin: float = 1.0):
        self.width = _positive("width", width, kind=numbers.Integral)
        self.height = _positive("height", height, kind=numbers.Integral)
        if not isinstance(follow, bool):
            raise InvalidArgumentError(f"follow: expected a bool, got {follow!r}")
        self.follow, self.view_size = follow, _positive("view_size", view_size)
        self.margin, self.bounds = _positive("margin", margin, allow_zero=True), None
        if bounds is not None:
            b = _arr("bounds", bounds, (4,))
            if not (b[2] > b[0] and b[3] > b[1]):
                raise InvalidArgumentError(f"bounds: expected xmin < xmax, ymin < ymax: {tuple(b)}")
            self.bounds = tuple(b.tolist())
        load = getattr(ImageFont, "load_default_imagefont", ImageFont.load_default)
        self._font = load()  # bitmap: ~20x faster than the FreeType default
        # One reused canvas that Pillow draws straight into: RGBA frombuffer shares the numpy
        # memory, and clearing `readonly` stops Pillow copying it on the first write. A fresh
        # image and tobytes() per frame cost ~1000 page faults (~2 ms) besides the drawing.
        self._buf = np.zeros((self.height, self.width, 4), np.uint8)
        size = (self.width, self.height)
        self._img = Image.frombuffer("RGBA", size, self._buf, "raw", "RGBA", 0, 1)
        self._img.readonly = 0

    def view(self, frame: RenderFrame) -> tuple[float, float, float]:
        """World point at the image centre and the scale: ``(cx, cy, pixels per metre)``."""
        if self.follow or (self.bounds is None and not len(frame.walls)):
            return *frame.pose[:2].tolist(), min(self.width, self.height) / self.view_size
        x0, y0, x1, y1 = self.bounds or fit_bounds(frame.walls, self.margin)
        x1, y1 = max(x1, x0 + 1e-6), max(y1, y0 + 1e-6)
        return (x0 + x1) / 2, (y0 + y1) / 2, min(self.width / (x1 - x0), self.height / (y1 - y0))

    def world_to_pixel(self, frame: RenderFrame, xy) -> np.ndarray:
        """Pixel coordinates ``(column, row)`` (float, shape (..., 2)) of world points ``xy``."""
        return self._px(xy, self.view(frame))

    def _px(self, xy, view):
        cx, cy, s = view
        xy = np.asarray(xy, dtype=np.float64)
        out = np.empty(xy.shape)
        out[..., 0] = self.width / 2 + (xy[..., 0] - cx) * s
        out[..., 1] = self.height / 2 - (xy[..., 1] - cy) * s
        return out

    def draw(self, frame: RenderFrame) -> np.ndarray:
        """Render ``frame``; returns a new C-contiguous ``(height, width, 3)`` uint8 array."""
        if not isinstance(frame, RenderFrame):
            raise InvalidArgumentError(f"frame: expected a RenderFrame, got {type(frame).__name__}")
        v, f, C = self.view(frame), frame, COLORS
        self._img.paste(C["background"], (0, 0, self.width, self.height))
        d = ImageDraw.Draw(self._img)
        centre = self._px(f.pose[:2], v)
        if f.ghost_pose is not None:  # first and pale: what lies on it is drawn over it
            ghost = self._px(_body(*f.footprint, f.ghost_pose), v).ravel().tolist()
            d.polygon(ghost, fill=C["ghost_fill"], outline=C["ghost"])
        if f.crop_radius:
            r = f.crop_radius * v[2]
            d.ellipse([*(centre - r), *(centre + r)], outline=C["crop"])
        self._segments(d, f.walls, C["wall"], 2, v)
        self._segments(d, f.pieces[f.inspected], C["inspected"], 4, v)
        self._segments(d, f.obstacles, C["obstacle"], 6, v)
        self._points(f, v)
        body = self._px(_body(*f.footprint, f.pose), v)  # outline by line: polygon(width=2) is slow
        d.polygon(body.ravel().tolist(), fill=C["contact" if f.contact else "body"])
        d.line(np.vstack([body, body[:1]]).ravel().tolist(), fill=C["body_edge"], width=2)
        nose = np.array([[0.2, 0.0], [0.45, 0.0]]) * f.footprint[0]  # heading tick, off-centre
        d.line(self._px(_place(nose, f.pose), v).ravel().tolist(), fill=C["body_edge"], width=2)
        if f.semi_axes is not None:
            ring = self._px(_place(_RING * f.semi_axes, f.pose), v)
            d.line(ring.ravel().tolist(), fill=C["ellipse"], width=2)
        if f.reference is not None:
            tick = _place(np.array([[0.0, 0.0], [0.6, 0.0]]), f.reference)  # 0.6 m heading tick
            (x, y), end = self._px(tick, v).tolist()
            d.ellipse([x - 6, y - 6, x + 6, y + 6], outline=C["reference"], width=2)
            d.line([x, y, *end], fill=C["reference"], width=2)
        for name in ("u_nom", "u_star"):
            _arrow(d, centre, self._px(f.pose[:2] + getattr(f, name), v), C[name])
        if f.ghost_pose is not None:
            self._offscreen_arrow(d, self._px(f.ghost_pose[:2], v))
        self._scale_bar(d, v[2])
        if f.text:
            lh = self._font.getbbox("Hg")[3] + 3
            wide = max(self._font.getlength(t) for t in f.text)
            d.rectangle([2, 2, 8 + wide, 6 + lh * len(f.text)], fill=(255, 255, 255))
            for i, line in enumerate(f.text):
                d.text((5, 5 + i * lh), line, fill=C["text"], font=self._font)
        out = np.empty((self.height, self.width, 3), np.uint8)
        for c in range(3):  # channel by channel: ~5x faster than out[...] = buf[..., :3]
            out[..., c] = self._buf[..., c]
        return out

    def _segments(self, d, seg, colour, width, view):
        """Segments touching the view (culled in numpy); runs sharing endpoints: one polyline."""
        cx, cy, s = view
        hw, hh = self.width / (2 * s) + 1.0, self.height / (2 * s) + 1.0
        ax, ay, bx, by = seg.T
        keep = ((np.maximum(ax, bx) >= cx - hw) & (np.minimum(ax, bx) <= cx + hw)
                & (np.maximum(ay, by) >= cy - hh) & (np.minimum(ay, by) <= cy + hh))
        p = self._px(seg[keep].reshape(-1, 2, 2), view).reshape(-1, 4)
        if not len(p):
            return
        gap = np.abs(p[1:, 0] - p[:-1, 2]) + np.abs(p[1:, 1] - p[:-1, 3]) > 0.5
        cut, rows = (np.flatnonzero(gap) + 1).tolist(), p.tolist()
        for a, b in zip([0, *cut], [*cut, len(rows)]):
            xy = rows[a] if b == a + 1 else [c for r in rows[a:b] for c in r[:2]] + rows[b - 1][2:]
            d.line(xy, fill=colour, width=width)

    def _points(self, f, view):
        """LIDAR points as 2x2-pixel dots written straight into the canvas (near ones on top)."""
        near = np.zeros(len(f.points), bool)
        if f.crop_radius is not None:
            near = np.hypot(*(f.points - f.pose[:2]).T) <= f.crop_radius
        px = np.floor(self._px(f.points, view)).astype(np.intp)
        ok = (px[:, 0] >= 0) & (px[:, 0] < self.width) & (px[:, 1] >= 0) & (px[:, 1] < self.height)
        order = np.argsort(near[ok], kind="stable")
        col, row = px[ok][order].T
        rgb = np.where(near[ok][order, None], COLORS["point_near"], COLORS["point"])
        for dr, dc in ((0, 0), (0, 1), (1, 0), (1, 1)):
            r, c = np.minimum(row + dr, self.height - 1), np.minimum(col + dc, self.width - 1)
            self._buf[r, c, :3] = rgb

    def _offscreen_arrow(self, d, p):
        """If pixel ``p`` is off-screen, an arrow at the image border pointing toward it."""
        if 0 <= p[0] < self.width and 0 <= p[1] < self.height:
            return
        half = np.array([self.width / 2, self.height / 2])
        u = (p - half) / np.linalg.norm(p - half)
        tip = half + u * np.min((half - 6) / np.maximum(np.abs(u), 1e-9))
        _arrow(d, tip - 28 * u, tip, COLORS["ghost"])

    def _scale_bar(self, d, s):
        """1 m, or the 1-2-5 length nearest 80 px if 1 m is under 30 px or over a third wide."""
        metres = 1.0
        if not 30 <= s <= self.width / 3:
            nice = [k * 10.0 ** e for e in range(-2, 5) for k in (1, 2, 5)]
            metres = min(nice, key=lambda m: abs(math.log(m * s / 80)))
        x0, y0, n = 10, self.height - 12, metres * s
        d.line([x0, y0 - 4, x0, y0, x0 + n, y0, x0 + n, y0 - 4], fill=COLORS["text"], width=2)
        d.text((x0 + n + 5, y0 - 10), f"{metres:g} m", fill=COLORS["text"], font=self._font)


class HumanWindow:
    """A pygame window showing frames at most ``fps`` times a second; pygame imported lazily."""

    def __init__(self, width: int = 640, height: int = 640, fps: float = 20):
        self.width = _positive("width", width, kind=numbers.Integral)
        self.height = _positive("height", height, kind=numbers.Integral)
        self.fps = _positive("fps", fps)
        self._pg: Any = None  # the pygame module, once imported
        self._screen: Any = None

    def show(self, rgb: np.ndarray) -> bool:
        """Display ``rgb`` ((height, width, 3) uint8); False once the user closed the window."""
        rgb = np.ascontiguousarray(rgb)
        if rgb.dtype != np.uint8 or rgb.shape != (self.height, self.width, 3):
            want = (self.height, self.width, 3)
            raise InvalidArgumentError(f"rgb: expected uint8 {want}, got {rgb.dtype} {rgb.shape}")
        if self._screen is None:
            try:
                import pygame
            except ImportError as err:
                raise ImportError(f"HumanWindow needs pygame: {_EXTRA}") from err
            pygame.display.init()
            # (without a display SDL falls back to drawing nowhere: say so instead)
            driver = pygame.display.get_driver()
            if driver in ("offscreen", "dummy") and os.environ.get("SDL_VIDEODRIVER") != driver:
                pygame.display.quit()
                raise ShieldnavError(f"render_mode='human' needs a display (SDL found none and chose {driver!r}); use render_mode='rgb_array' and save the "
                                     f"frames (shieldnav.rendering.save_video), or set SDL_VIDEODRIVER={driver} to draw nowhere on purpose")
            self._pg, self._clock = pygame, pygame.time.Clock()
            self._screen = pygame.display.set_mode((self.width, self.height))
            pygame.display.set_caption("shieldnav")
        if any(e.type == self._pg.QUIT for e in self._pg.event.get()):
            self.close()
            return False
        self._screen.blit(self._pg.image.frombuffer(rgb, (self.width, self.height), "RGB"), (0, 0))
        self._pg.display.flip()
        self._clock.tick(self.fps)
        return True

    def close(self) -> None:
        """Close the window, if open (a later :meth:`show` opens a new one)."""
        if self._screen is not None:
            self._pg.display.quit()
            self._screen = None


def save_video(frames: Sequence[np.ndarray], path: str | os.PathLike, fps: float = 20) -> None:
    """Write ``frames`` (equal-shape (H, W, 3) uint8 arrays) to ``path`` at ``fps``.

    ``.gif``: Pillow, looping, 256 colours per frame (Pillow merges identical consecutive
    frames into one longer one). ``.mp4``: imageio's ffmpeg writer, from the ``render`` extra.
    """
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in (".gif", ".mp4"):
        raise InvalidArgumentError(f"path: expected a .gif or .mp4 file name, got {path!r}")
    fps, frames = _positive("fps", fps), list(frames)
    if not frames:
        raise InvalidArgumentError("frames: empty, nothing to write")
    for i, f in enumerate(frames):
        if not isinstance(f, np.ndarray) or f.dtype != np.uint8 or f.ndim != 3 or f.shape[2] != 3:
            got = f"{f.dtype} {f.shape}" if isinstance(f, np.ndarray) else type(f).__name__
            raise InvalidArgumentError(f"frames[{i}]: expected a (H, W, 3) uint8 array, got {got}")
        if f.shape != frames[0].shape:
            raise InvalidArgumentError(f"frames[{i}]: shape {f.shape}, frames[0] {frames[0].shape}")
    if ext == ".gif":
        im = [Image.fromarray(f) for f in frames]
        im[0].save(path, save_all=True, append_images=im[1:], duration=round(1000 / fps), loop=0)
        return
    try:
        import imageio.v2 as imageio
        import imageio_ffmpeg  # noqa: F401  (the backend of imageio's FFMPEG format)
    except ImportError as err:
        raise ImportError(f"writing .mp4 needs imageio and imageio-ffmpeg: {_EXTRA}") from err
    with imageio.get_writer(path, format="FFMPEG", mode="I", fps=fps) as writer:
        for f in frames:
            writer.append_data(f)
