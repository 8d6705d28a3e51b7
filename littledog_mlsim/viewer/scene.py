"""The web page: a viser server drawing LittleDogs, their trails, covariance ellipses and plots.

Why viser (docs/viewer.md compares the candidates): its wheel carries the whole client (one
HTML page with three.js, no external URL; the share button, which would open a tunnel, is
hidden), it has the primitives, GUI inputs and uPlot charts needed, and a robot update is a
few small websocket messages.

Drawing: each robot is the URDF's visual shapes (``urdf.RobotModel``), each a child of its
link's frame, so a frame of a robot is the poses of its 9 links with shapes, sent together
(``server.atomic``). Robot 0 is the reference
(the measured robot in a replay, the first simulator live); the others are drawn beside it
(``layout="side"``: shifted by ``spacing`` along +y, a drawing offset only) or on top of it as
translucent ghosts (``layout="ghost"``). Plots compare every robot with robot 0 at equal
frame index (replay) or equal stamp (live): the (x, y) gap of the bodies and the per-joint
angle errors of one chosen robot.

``ViewerApp.status`` is an HTML line ``t = ... s, frame N``: it changes with every drawn frame,
which is what ``benchmarks/viewer`` counts in the browser.
"""
from __future__ import annotations

import html
import logging
import threading
import time
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ..layout import JOINT_NAMES
from .meshes import shape_mesh
from .tracks import Track
from .urdf import RobotModel, load_robot, matrix_to_wxyz

__all__ = ["Frame", "RobotDrawing", "ViewerApp", "ROBOT_COLOURS"]

log = logging.getLogger(__name__)

# Body colour per robot (robot 0 first): grey, orange, green, purple, ochre.
ROBOT_COLOURS = [(90, 90, 102), (217, 115, 26), (38, 153, 64), (153, 51, 153), (178, 153, 26)]
_PLOT_COLOURS = ["#d9731a", "#269940", "#993399", "#b2991a", "#1f77b4", "#d62728"]
_JOINT_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                  "#e377c2", "#7f7f7f", "#bcbd22", "#17becf", "#393b79", "#637939"]
_X_NOT_TIME = {"x": {"time": False}}   # uPlot reads x as a date unless told
GHOST_OPACITY = 0.4
ELLIPSE_SIGMA = 2.0        # the ellipse is the 2-sigma contour of the (x, y) covariance
TRAIL_POINTS = 600         # at most this many points per trail (decimated)
TRAIL_EVERY = 10           # replay: redraw the trails every this many frames
ELLIPSE_PERIOD = 0.2       # s: the ellipse's contour is resent at most this often ...
ELLIPSE_RESHAPE = 0.02     # ... and only when the covariance changed by more than this (relative)


@dataclass
class Frame:
    """One robot at one instant: base position (3,), orientation (4,) xyzw, q (12,), optional
    (x, y) covariance (2, 2), time [s]."""

    t: float
    position: np.ndarray
    orientation: np.ndarray
    q: np.ndarray
    cov_xy: np.ndarray | None = None


def _segments(points: np.ndarray) -> np.ndarray:
    """A polyline (n, 3) as line segments (n - 1, 2, 3)."""
    return np.stack([points[:-1], points[1:]], axis=1)


def ellipse_points(centre_xy: np.ndarray, cov: np.ndarray, sigma: float = ELLIPSE_SIGMA,
                   n: int = 48) -> np.ndarray | None:
    """(n + 1, 2) closed contour of the ``sigma`` ellipse of a 2x2 covariance, or None if the
    covariance is not finite, not symmetric positive semi-definite."""
    cov = np.asarray(cov, dtype=np.float64)
    if cov.shape != (2, 2) or not np.all(np.isfinite(cov)):
        return None
    w, v = np.linalg.eigh(0.5 * (cov + cov.T))
    if w.min() < -1e-12:
        return None
    a = np.linspace(0.0, 2 * np.pi, n + 1)
    circle = np.stack([np.cos(a), np.sin(a)], axis=1)
    return centre_xy + sigma * (circle * np.sqrt(np.maximum(w, 0.0))) @ v.T


class RobotDrawing:
    """One LittleDog in the scene under ``/robots/<key>``: shapes, label, trail, ellipse.

    Each link with visuals is a scene frame whose world pose is set per frame; its shapes are
    static children (the URDF's visual origins). (viser's batched meshes, one message per shape
    size, made the client render at about 1 frame per second under software WebGL here.)"""

    def __init__(self, server, model: RobotModel, key: str, label: str, colour: tuple[int, ...],
                 opacity: float | None = None) -> None:
        self.server, self.model, self.key, self.label = server, model, key, label
        self.offset = np.zeros(3)
        base = f"/robots/{key}"
        self.links = list(dict.fromkeys(v.link for v in model.visuals))
        self.frames = {}
        self.handles = []            # everything that shows the robot's body (visibility)
        meshes: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        for link in self.links:
            fr = server.scene.add_frame(f"{base}/{link}", show_axes=False, visible=False)
            self.frames[link] = fr
            self.handles.append(fr)
            for i, v in enumerate(model.visuals):
                if v.link != link:
                    continue
                if v.key not in meshes:
                    meshes[v.key] = shape_mesh(v.kind, v.size)
                verts, faces = meshes[v.key]
                c = colour if link == model.root else tuple(int(round(255 * x))
                                                             for x in v.rgba[:3])
                server.scene.add_mesh_simple(
                    f"{base}/{link}/shape{i}", verts, faces, color=c, opacity=opacity,
                    position=tuple(float(x) for x in v.xyz),
                    wxyz=tuple(float(x) for x in matrix_to_wxyz(v.rotation)),
                    cast_shadow=False, receive_shadow=False)
        # the label rides on the body frame: no message of its own per frame
        self.text = server.scene.add_label(f"{base}/{model.root}/label", label,
                                           position=(0.0, 0.0, 0.22), anchor="bottom-center",
                                           visible=False)
        self.colour = colour
        self.trail = None
        self.ellipse = None
        self._ellipse_cov: np.ndarray | None = None    # the covariance the contour shows
        self._ellipse_due = 0.0

    def show(self, frame: Frame) -> None:
        """Pose the links (call inside ``server.atomic()`` to send them together): one
        vectorised quaternion conversion for all links, plain float tuples to viser."""
        poses = self.model.link_poses(frame.position + self.offset, frame.orientation, frame.q)
        links = list(self.frames)
        wxyz = matrix_to_wxyz(np.stack([poses[k][0] for k in links])).tolist()
        pos = np.stack([poses[k][1] for k in links]).tolist()
        for k, link in enumerate(links):
            fr = self.frames[link]
            fr.wxyz = tuple(wxyz[k])
            fr.position = tuple(pos[k])

    def set_visible(self, on: bool, label: bool = True) -> None:
        """Show or hide the body (and the label with it, if ``label``); hiding also hides the
        trail and ellipse (drawing them again shows them)."""
        for h in self.handles:
            h.visible = on
        self.text.visible = on and label
        if not on:
            for d in (self.trail, self.ellipse):
                if d is not None:
                    d.visible = False

    def show_trail(self, points: np.ndarray | None) -> None:
        """The body path so far, (n, 3) world points (drawn on the ground), or None to hide."""
        if points is None or len(points) < 2:
            if self.trail is not None:
                self.trail.visible = False
            return
        if len(points) > TRAIL_POINTS:
            points = points[np.linspace(0, len(points) - 1, TRAIL_POINTS).astype(int)]
        p = np.array(points, dtype=np.float32) + self.offset.astype(np.float32)
        p[:, 2] = 0.002
        seg = _segments(p)
        if self.trail is None:
            self.trail = self.server.scene.add_line_segments(
                f"/robots/{self.key}/trail", seg, colors=self.colour, thickness=0.006)
        else:
            self.trail.points = seg
            self.trail.visible = True

    def show_ellipse(self, centre: np.ndarray | None, cov: np.ndarray | None) -> None:
        """The (x, y) covariance ellipse around ``centre``, or None/None to hide it. The
        contour is drawn relative to its node, which moves with every frame (one small
        message); the contour itself is resent only when the covariance changed by more than
        ``ELLIPSE_RESHAPE`` (relative), at most every ``ELLIPSE_PERIOD`` s."""
        if centre is None or cov is None:
            if self.ellipse is not None:
                self.ellipse.visible = False
            return
        now = time.monotonic()
        shape_due = (self.ellipse is None or self._ellipse_cov is None
                     or (now >= self._ellipse_due and not np.allclose(
                         cov, self._ellipse_cov, rtol=ELLIPSE_RESHAPE,
                         atol=ELLIPSE_RESHAPE * float(np.abs(self._ellipse_cov).max()))))
        seg = None
        if shape_due:
            pts = ellipse_points(np.zeros(2), cov)
            if pts is None:
                if self.ellipse is not None:
                    self.ellipse.visible = False
                return
            seg = _segments(np.column_stack([pts, np.zeros(len(pts))]).astype(np.float32))
            self._ellipse_cov = np.array(cov, dtype=np.float64)
            self._ellipse_due = now + ELLIPSE_PERIOD
        at = (float(centre[0] + self.offset[0]), float(centre[1] + self.offset[1]), 0.003)
        if self.ellipse is None:
            self.ellipse = self.server.scene.add_line_segments(
                f"/robots/{self.key}/ellipse", seg, colors=(200, 30, 30), thickness=0.004,
                position=at)
            return
        if seg is not None:
            self.ellipse.points = seg
        self.ellipse.position = at
        if not self.ellipse.visible:
            self.ellipse.visible = True


class ViewerApp:
    """The server, the scene and the GUI around a list of robots (labels)."""

    def __init__(self, labels: Sequence[str], *, host: str = "127.0.0.1", port: int = 8080,
                 layout: str = "side", spacing: float = 0.4, trail: bool = True,
                 ellipse: bool = True, plots: bool = True, title: str = "LittleDog",
                 model: RobotModel | None = None) -> None:
        import viser

        if layout not in ("side", "ghost"):
            raise ValueError(f"layout must be side or ghost, got {layout!r}")
        if not labels:
            raise ValueError("no robots to draw")
        self.model = model or load_robot()
        self.labels = list(labels)
        self.lock = threading.RLock()
        self.server = viser.ViserServer(host=host, port=port, label=title, verbose=False)
        s = self.server
        s.gui.configure_theme(show_share_button=False, control_width="large")
        s.scene.set_up_direction("+z")
        # no shadow pass: a third of the rendering work, which matters for software WebGL
        s.scene.configure_default_lights(enabled=True, cast_shadow=False)
        s.scene.add_grid("/ground", width=6.0, height=6.0, plane="xy", cell_size=0.1,
                         section_size=0.5, cell_color=(210, 210, 210),
                         section_color=(150, 150, 150), shadow_opacity=0.0)
        # from the front right: robot 0 leftmost, the others (shifted along +y) to its right,
        # all left of the control panel
        mid = 0.5 * spacing * (len(labels) - 1)
        s.initial_camera.position = (1.3, mid - 0.8, 0.75)
        s.initial_camera.look_at = (0.15, mid + 0.35, 0.0)
        self.robots = [RobotDrawing(s, self.model, f"r{i}", lab,
                                    ROBOT_COLOURS[i % len(ROBOT_COLOURS)])
                       for i, lab in enumerate(labels)]
        self.ghosts = [RobotDrawing(s, self.model, f"g{i}", lab,
                                    ROBOT_COLOURS[i % len(ROBOT_COLOURS)], GHOST_OPACITY)
                       for i, lab in enumerate(labels) if i > 0]
        self.spacing = float(spacing)
        self.frames_drawn = 0
        self._last: list[Frame | None] = [None] * len(labels)
        self._pending_visibility = False
        self._trails: list[list[np.ndarray]] = [[] for _ in labels]
        # GUI
        self.status = s.gui.add_html(self._status_html(None))
        self.gui_layout = s.gui.add_dropdown("layout", ("side", "ghost"), initial_value=layout)
        self.gui_trail = s.gui.add_checkbox("body trail", trail)
        self.gui_ellipse = s.gui.add_checkbox("pose covariance (2 sigma)", ellipse)
        self.gui_layout.on_update(lambda _: self._apply_layout())
        self.gui_trail.on_update(lambda _: self._redraw())
        self.gui_ellipse.on_update(lambda _: self._redraw())
        self.plots = plots and len(labels) > 1
        self.gap_plot = self.joint_plot = self.gui_joint_robot = None
        if self.plots:
            from viser import uplot

            others = self.labels[1:]
            self.gap_plot = s.gui.add_uplot(
                data=(np.zeros(0),) + tuple(np.zeros(0) for _ in others),
                series=(uplot.Series(label="t [s]"),) + tuple(
                    uplot.Series(label=f"{lab} [m]", stroke=_PLOT_COLOURS[i % 6], width=1.5)
                    for i, lab in enumerate(others)),
                title=f"(x,y) gap to {self.labels[0]}", aspect=2.0, scales=_X_NOT_TIME)
            self.gui_joint_robot = s.gui.add_dropdown("joint errors of", tuple(others),
                                                      initial_value=others[0])
            self.joint_plot = s.gui.add_uplot(
                data=(np.zeros(0),) + tuple(np.zeros(0) for _ in JOINT_NAMES),
                series=(uplot.Series(label="t [s]"),) + tuple(
                    uplot.Series(label=n.replace("front_", "F").replace("back_", "B")
                                 .replace("left_", "L ").replace("right_", "R "),
                                 stroke=_JOINT_COLOURS[j], width=1.0)
                    for j, n in enumerate(JOINT_NAMES)),
                title=f"joint angle error to {self.labels[0]} [rad]", aspect=1.4,
                scales=_X_NOT_TIME)
        self._apply_layout()

    # -- addresses --------------------------------------------------------------------------------

    @property
    def port(self) -> int:
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        host = self.server.get_host()
        host = "localhost" if host in ("0.0.0.0", "127.0.0.1", "::") else host
        return f"http://{host}:{self.port}"

    def stop(self) -> None:
        self.server.stop()

    def watched(self) -> bool:
        """A websocket client is connected (viser lists a page under ``get_clients`` only after
        its first camera message; the infra's connection table, viser 1.1.1, has it at once)."""
        conns = getattr(getattr(self.server, "_websock_server", None), "_client_state_from_id",
                        None)
        return bool(conns) if conns is not None else bool(self.server.get_clients())

    # -- drawing -----------------------------------------------------------------------------------

    def _status_html(self, t: float | None) -> str:
        text = ("waiting for robot states" if t is None
                else f"t = {t:.2f} s, frame {self.frames_drawn}")
        names = ", ".join(html.escape(x) for x in self.labels)
        return (f'<div style="font-size:0.85em"><b>{names}</b><br>'
                f'<span id="ldv-status">{text}</span></div>')

    def _apply_layout(self) -> None:
        ghost = self.gui_layout.value == "ghost"
        with self.lock:
            for i, r in enumerate(self.robots):
                r.offset = np.array([0.0, self.spacing * i, 0.0]) if not ghost else np.zeros(3)
            self._visibility()
            self._redraw()

    def _visibility(self) -> None:
        """Robots appear with their first state; ghost layout swaps robots 1.. for ghosts."""
        ghost = self.gui_layout.value == "ghost"
        for i, r in enumerate(self.robots):
            r.set_visible(self._last[i] is not None and not (ghost and i > 0))
        for i, g in enumerate(self.ghosts, start=1):
            g.set_visible(self._last[i] is not None and ghost, label=False)

    def _drawings(self, i: int) -> RobotDrawing:
        if i > 0 and self.gui_layout.value == "ghost":
            return self.ghosts[i - 1]
        return self.robots[i]

    def _redraw(self) -> None:
        with self.lock:
            frames = list(self._last)
            if any(f is not None for f in frames):
                self.draw(frames, count=False)

    def draw(self, frames: Sequence[Frame | None], trails: Sequence[np.ndarray | None] | None
             = None, count: bool = True) -> None:
        """Show one frame per robot (None: keep that robot as it is). ``trails``: each robot's
        body path (n, 3) to show, or None to keep the trail collected from the drawn frames.

        With no browser connected only the newest frames are kept (a page that connects later
        gets them on the next draw): drawing costs the process CPU that a simulator on the same
        cores may need (benchmarks/viewer)."""
        if not self.watched():
            with self.lock:
                for i, f in enumerate(frames):
                    if f is not None:
                        if self._last[i] is None:
                            self._pending_visibility = True
                        self._last[i] = f
            return
        if self._pending_visibility:
            self._pending_visibility = False
            frames = [f if f is not None else last for f, last in zip(frames, self._last)]
            self._last = [None] * len(self._last)
        with self.lock, self.server.atomic():
            t = None
            appeared = False
            for i, f in enumerate(frames):
                if f is None:
                    continue
                d = self._drawings(i)
                d.show(f)
                appeared = appeared or self._last[i] is None
                self._last[i] = f
                t = f.t if t is None else max(t, f.t)
                if self.gui_ellipse.value:
                    d.show_ellipse(f.position, f.cov_xy)
                else:
                    d.show_ellipse(None, None)
            if trails is not None:
                for i, tr in enumerate(trails):
                    self._drawings(i).show_trail(tr if self.gui_trail.value else None)
            if appeared:
                self._visibility()
            if count and t is not None:
                self.frames_drawn += 1
            if t is not None:
                self.status.content = self._status_html(t)

    def set_plots(self, t: np.ndarray, gaps: Sequence[np.ndarray],
                  joint_err: Sequence[np.ndarray]) -> None:
        """Plot data: times (n,), per other robot its (x, y) gap (n,) and joint errors (n, 12);
        the joint plot shows the robot chosen in the GUI."""
        if not self.plots:
            return
        which = self.labels[1:].index(self.gui_joint_robot.value)
        t = np.asarray(t, dtype=np.float64)
        self.gap_plot.data = (t,) + tuple(np.asarray(g, dtype=np.float64) for g in gaps)
        je = np.asarray(joint_err[which], dtype=np.float64).reshape(len(t), len(JOINT_NAMES))
        self.joint_plot.data = (t,) + tuple(je[:, j] for j in range(len(JOINT_NAMES)))


class Player:
    """Replay of tracks with a timeline: play/pause, speed, scrub (a slider of the time)."""

    def __init__(self, app: ViewerApp, tracks: Sequence[Track], rate: float = 50.0,
                 autoplay: bool = True, loop: bool = True) -> None:
        from .tracks import joint_errors, xy_gap

        if len(tracks) != len(app.labels):
            raise ValueError("one track per robot")
        self.app, self.tracks = app, list(tracks)
        self.n = min(len(tr) for tr in tracks)
        self.t = tracks[0].t[: self.n]
        self.rate = float(rate)
        self.loop = loop
        s = app.server
        self.folder = s.gui.add_folder("timeline", order=-1)
        with self.folder:
            self.slider = s.gui.add_slider("t [s]", float(self.t[0]), float(self.t[-1]), 0.01,
                                           float(self.t[0]))
            self.play_button = s.gui.add_button("pause" if autoplay else "play")
            self.speed = s.gui.add_dropdown("speed", ("0.25", "0.5", "1", "2"),
                                            initial_value="1")
        self.playing = autoplay
        self.index = 0
        self._pos = 0.0
        self.slider.on_update(self._on_slider)
        self.play_button.on_click(lambda _: self.toggle())
        ref = tracks[0]
        self.gaps = [xy_gap(tr, ref)[: self.n] for tr in tracks[1:]]
        self.jerr = [joint_errors(tr, ref)[: self.n] for tr in tracks[1:]]
        if app.plots:
            app.set_plots(self.t, self.gaps, self.jerr)
            app.gui_joint_robot.on_update(lambda _: app.set_plots(self.t, self.gaps, self.jerr))
        self._stop = threading.Event()
        self.show(0)
        self.thread = threading.Thread(target=self._run, name="viewer-player", daemon=True)
        self.thread.start()

    def toggle(self) -> None:
        self.playing = not self.playing
        self.play_button.label = "pause" if self.playing else "play"

    def _on_slider(self, event) -> None:
        if event.client is None:       # our own update while playing
            return
        i = int(np.clip(np.searchsorted(self.t, self.slider.value - 1e-9), 0, self.n - 1))
        self._pos = float(i)
        self.show(i)

    def frame(self, i: int, k: int) -> Frame:
        tr = self.tracks[k]
        return Frame(float(tr.t[i]), tr.position[i], tr.orientation[i], tr.q[i],
                     None if tr.cov_xy is None else tr.cov_xy[i])

    def show(self, i: int, trails: bool = True) -> None:
        self.index = i
        frames = [self.frame(i, k) for k in range(len(self.tracks))]
        self.app.draw(frames, [tr.position[: i + 1] for tr in self.tracks] if trails else None)

    def _run(self) -> None:
        period = 1.0 / self.rate
        last = time.perf_counter()
        while not self._stop.wait(max(0.0, period - (time.perf_counter() - last))):
            now = time.perf_counter()
            dt, last = now - last, now
            if not self.playing:
                continue
            self._pos += dt * float(self.speed.value) / 0.01   # frames are 10 ms apart
            if self._pos >= self.n:
                if not self.loop:
                    self._pos = self.n - 1
                    self.toggle()
                else:
                    self._pos = 0.0
            i = int(self._pos)
            if i != self.index:
                self.show(i, trails=i % TRAIL_EVERY == 0 or i < self.index)
                self.slider.value = float(round(self.t[i], 2))

    def close(self) -> None:
        self._stop.set()
        self.thread.join(2.0)
        self.folder.remove()


def serve_forever(app: ViewerApp, until: Callable[[], bool] | None = None) -> None:
    """Block until Ctrl-C / SIGTERM (or ``until()`` is true), then stop the server."""
    try:
        while until is None or not until():
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        app.stop()
