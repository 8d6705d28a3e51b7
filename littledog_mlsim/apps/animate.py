"""Side-by-side 3-D animation of one move: the measured robot next to simulated ones (paper VII).

Every panel is rendered from a state sequence s_2..s_N (T, 33) the same way: the world path
(x_w, y_w, yaw) is integrated from the pose measured at k = 1 (``integrate_path`` with
``initial_pose(rec, 1)``, as the rollout metrics do), and the base pose is (x_w, y_w, z_w, roll,
pitch, yaw) with the joint angles q. The measured panel uses the recording's own states
(``prepare_test_move(rec).states``), which integrate back to the recorded odometry.

Rendering: one pybullet DIRECT client holds only the robot (the project's URDF); per frame and
panel it is posed with ``resetBasePositionAndOrientation``/``resetJointState`` and drawn by
``getCameraImage`` with ``ER_TINY_RENDERER`` (CPU, no display). The floor is drawn in 2-D with
Pillow by projecting world points through the same camera matrices (a 10 cm grid, bold every
50 cm) and the robot's pixels (segmentation mask) are pasted over it: a pybullet ground plane
would cost the tiny renderer ~4x the robot's time. On the floor, the measured path so far is red
in every panel and a simulated panel's own path is in its body colour. With
``follow="measured"`` (default) every panel's camera tracks the *measured* body, so a simulator's
drift shows as an offset from the centre; ``follow="own"`` tracks each panel's own body. The
camera looks from a fixed world direction (the robot's right side, 30 degrees behind its
initial heading), so turns show. Labels (name, time after s_1, current (x, y) error to the
measured path) are drawn with Pillow. Frames are every ``step = round(100 / fps)``-th state and
last step x 10 ms, so the GIF plays in real time (at 100 / step fps, = fps when fps divides 100).
"""
from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pybullet as p
from PIL import Image, ImageDraw, ImageFont

from ..data.states import initial_pose, integrate_path
from ..data.recording import MoveRecording
from ..layout import CONTROL_DT, JOINT_NAMES, N_STATE, S
from ..robot.config import URDF_PATH
from ..rotations import rpy_to_quat
from ..rollout.simulate import prepare_test_move

__all__ = ["animate_move", "panel_poses", "MEASURED_LABEL"]

MEASURED_LABEL = "measured"
_MEASURED_PATH = (210, 30, 30)   # colour of the measured path on the floor
_GIF_COLOURS = 96                # palette size per frame
# Body tint per panel (measured first); legs keep the URDF's colours.
_TINTS = [(0.35, 0.35, 0.4, 1.0), (0.85, 0.45, 0.1, 1.0), (0.15, 0.6, 0.25, 1.0),
          (0.6, 0.2, 0.6, 1.0), (0.7, 0.6, 0.1, 1.0)]


def _rgb(rgba: tuple) -> tuple[int, int, int]:
    return tuple(int(round(255 * v)) for v in rgba[:3])  # type: ignore[return-value]


def panel_poses(rec: MoveRecording, states: np.ndarray) -> dict[str, np.ndarray]:
    """Base poses and joint angles of a state sequence s_2..s_N of ``rec``.

    Returns ``position`` (T, 3) [m], ``orientation`` (T, 4) xyzw, ``q`` (T, 12) [rad] and
    ``finite`` (T,) bool; rows after the first non-finite one repeat the last finite pose.
    """
    s = np.asarray(states, dtype=np.float64)
    if s.ndim != 2 or s.shape[1] != N_STATE:
        raise ValueError(f"states must be (T, {N_STATE}), got {s.shape}")
    with np.errstate(over="ignore", invalid="ignore"):
        path = integrate_path(s, *initial_pose(rec, 1))             # x, y, yaw at k = 2..N
        pos = np.column_stack([path[:, 0], path[:, 1], s[:, S.z_w]])
        orn = rpy_to_quat(np.column_stack([s[:, S.roll_pitch], path[:, 2]]))
    q = s[:, S.q].copy()
    finite = np.isfinite(pos).all(1) & np.isfinite(orn).all(1) & np.isfinite(q).all(1)
    finite = np.cumprod(finite).astype(bool)                        # stays False once broken
    if not finite[0]:
        raise ValueError("the first state to animate is not finite")
    last = np.maximum.accumulate(np.where(finite, np.arange(len(finite)), 0))
    return {"position": pos[last], "orientation": orn[last], "q": q[last], "finite": finite}


class _Scene:
    """A DIRECT pybullet client holding only the robot, for rendering.

    The ground is not a pybullet body: a full-screen plane costs the tiny renderer ~4x the
    robot's time, so the floor (grid, paths) is drawn in 2-D by projecting world points with the
    same camera matrices, and the robot's pixels (segmentation mask) are pasted on top.
    """

    GRID_STEP = 0.1    # m between floor lines (bolder every 0.5 m)
    GRID_HALF = 1.2    # m: floor drawn within this distance of the camera target
    SKY = (214, 226, 238)
    FLOOR = (236, 236, 230)

    def __init__(self, size: tuple[int, int]) -> None:
        self.w, self.h = size
        self.c = p.connect(p.DIRECT)
        c = self.c
        self.robot = p.loadURDF(str(URDF_PATH), [0, 0, 0.2], useFixedBase=True, physicsClientId=c)
        by_name = {p.getJointInfo(self.robot, j, physicsClientId=c)[1].decode(): j
                   for j in range(p.getNumJoints(self.robot, physicsClientId=c))}
        self.joints = [by_name[n] for n in JOINT_NAMES]
        self.proj = p.computeProjectionMatrixFOV(fov=50, aspect=self.w / self.h, nearVal=0.02,
                                                 farVal=6.0, physicsClientId=c)
        self._P = np.array(self.proj).reshape(4, 4).T
        self._tint: tuple | None = None

    def pose(self, position: np.ndarray, orientation: np.ndarray, q: np.ndarray) -> None:
        p.resetBasePositionAndOrientation(self.robot, position.tolist(), orientation.tolist(),
                                          physicsClientId=self.c)
        for j, a in zip(self.joints, q.tolist()):
            p.resetJointState(self.robot, j, a, 0.0, physicsClientId=self.c)

    def tint(self, rgba: tuple) -> None:
        if rgba != self._tint:
            p.changeVisualShape(self.robot, -1, rgbaColor=list(rgba), physicsClientId=self.c)
            self._tint = rgba

    def camera(self, target: np.ndarray, cam_yaw_deg: float) -> list[float]:
        """View matrix looking at ``target`` (x, y) from a fixed world direction."""
        return p.computeViewMatrixFromYawPitchRoll(
            cameraTargetPosition=[float(target[0]), float(target[1]), 0.08], distance=0.75,
            yaw=cam_yaw_deg, pitch=-22.0, roll=0.0, upAxisIndex=2, physicsClientId=self.c)

    def project(self, view: list[float], pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (n, 2) of world points (n, 3) and whether each is in front (n,)."""
        M = self._P @ np.array(view).reshape(4, 4).T
        clip = pts @ M[:, :3].T + M[:, 3]
        front = clip[:, 3] > 0.03
        ndc = clip[:, :2] / np.where(front, clip[:, 3], 1.0)[:, None]
        return np.stack([(ndc[:, 0] + 1) * 0.5 * self.w, (1 - ndc[:, 1]) * 0.5 * self.h], 1), front

    def _polylines(self, d: ImageDraw.ImageDraw, view, lines: np.ndarray, fill,
                   width: int) -> None:
        """Draw world polylines ``lines`` (L, n, 3), projected at once; parts behind are dropped."""
        if lines.shape[0] == 0 or lines.shape[1] < 2:
            return
        L, n = lines.shape[:2]
        xy, front = self.project(view, lines.reshape(-1, 3))
        xy, front = xy.reshape(L, n, 2), front.reshape(L, n)
        for pts, ok in zip(xy, front):
            if ok.all():
                d.line(pts.ravel().tolist(), fill=fill, width=width)
                continue
            # split at points behind the camera; draw each visible run as one polyline
            for run in np.split(np.arange(n), np.flatnonzero(~ok)):
                run = run[ok[run]]
                if len(run) > 1:
                    d.line(pts[run].ravel().tolist(), fill=fill, width=width)

    def floor(self, view, target: np.ndarray, paths: list[tuple[np.ndarray, tuple]]) -> Image.Image:
        """Background: floor grid around ``target`` and ground paths [(xy (n, 2), colour)]."""
        img = Image.new("RGB", (self.w, self.h), self.SKY)
        d = ImageDraw.Draw(img)
        g, r = self.GRID_STEP, self.GRID_HALF
        n = int(round(r / g))
        ix, iy = np.round(np.asarray(target[:2], dtype=float) / g).astype(int)
        cx, cy = ix * g, iy * g
        # floor polygon, clipped by dense sampling of its edges
        corners = np.array([[cx - r, cy - r, 0], [cx + r, cy - r, 0], [cx + r, cy + r, 0],
                            [cx - r, cy + r, 0]])
        edge = np.concatenate([np.linspace(corners[i], corners[(i + 1) % 4], 40) for i in range(4)])
        xy, front = self.project(view, edge)
        if front.any():
            d.polygon(xy[front].ravel().tolist(), fill=self.FLOOR)
        # grid lines x = const and y = const, (2n + 1) each, sampled at 25 points
        k = np.arange(-n, n + 1)
        s = np.linspace(-r, r, 25)
        lines = np.zeros((2, 2 * n + 1, s.size, 3))
        lines[0, :, :, 0], lines[0, :, :, 1] = (cx + k * g)[:, None], cy + s[None, :]
        lines[1, :, :, 0], lines[1, :, :, 1] = cx + s[None, :], (cy + k * g)[:, None]
        is_bold = np.stack([(ix + k) % 5 == 0, (iy + k) % 5 == 0])
        self._polylines(d, view, lines[~is_bold], (200, 200, 196), 1)
        self._polylines(d, view, lines[is_bold], (150, 150, 150), 2)
        for xy_path, colour in paths:
            if len(xy_path) > 1:
                pts = np.zeros((1, len(xy_path), 3))
                pts[0, :, :2] = xy_path
                self._polylines(d, view, pts, colour, 2)
        return img

    def render(self, view, background: Image.Image) -> Image.Image:
        """The robot drawn by the tiny renderer over ``background``."""
        _, _, rgba, _, seg = p.getCameraImage(self.w, self.h, view, self.proj,
                                              renderer=p.ER_TINY_RENDERER, shadow=0,
                                              physicsClientId=self.c)
        rgb = np.asarray(rgba, dtype=np.uint8).reshape(self.h, self.w, 4)[:, :, :3]
        mask = np.asarray(seg).reshape(self.h, self.w) >= 0
        out = np.array(background)
        out[mask] = rgb[mask]
        return Image.fromarray(out)

    def close(self) -> None:
        p.disconnect(physicsClientId=self.c)


def _font(size: int):
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1
        return ImageFont.load_default()


def animate_move(rec_measured: MoveRecording, predicted_states_by_label: Mapping[str, np.ndarray],
                 out_path: str | Path, fps: int = 25, size: tuple[int, int] = (320, 240), *,
                 follow: str = "measured", max_frames: int | None = None) -> dict[str, Any]:
    """Write a side-by-side GIF of one move: the measured robot, then one panel per label.

    Args:
        rec_measured: the recording (measurements k = 0..N).
        predicted_states_by_label: {label: (N - 1, 33) predicted s_2..s_N}, e.g. a learned
            rollout and ``baseline.physics_rollout``; panels in this order after "measured".
        out_path: the ``.gif`` to write (overwritten).
        fps: frames per second; every ``round(100 / fps)``-th state is a frame.
        size: (width, height) of one panel in pixels.
        follow: "measured" (all cameras track the measured body) or "own".
        max_frames: render at most this many frames (from the start), for quick looks.
    Returns:
        {"path", "n_frames", "n_panels", "labels", "size", "image_size", "fps", "frame_step",
         "duration_s", "wall_s", "ms_per_panel_frame"}.
    """
    t_start = time.perf_counter()
    out_path = Path(out_path)
    if out_path.suffix.lower() != ".gif":
        raise ValueError(f"animate_move writes a .gif (no ffmpeg for video), got {out_path}")
    if follow not in ("measured", "own"):
        raise ValueError(f"follow must be 'measured' or 'own', got {follow!r}")
    if fps < 1 or fps > 100:
        raise ValueError(f"fps must be in 1..100, got {fps}")
    if MEASURED_LABEL in predicted_states_by_label:
        raise ValueError(f"label {MEASURED_LABEL!r} is reserved for the recording")
    truth = prepare_test_move(rec_measured).states
    labels = [MEASURED_LABEL, *predicted_states_by_label]
    panels = [panel_poses(rec_measured, truth)]
    for lab, st in predicted_states_by_label.items():
        if np.shape(st) != truth.shape:
            raise ValueError(f"{lab}: states have shape {np.shape(st)}, expected {truth.shape} "
                             f"(s_2..s_N of {rec_measured.name})")
        panels.append(panel_poses(rec_measured, st))
    step = max(1, int(round(1.0 / (fps * CONTROL_DT))))
    frames_k = list(range(0, truth.shape[0], step))
    if max_frames is not None:
        frames_k = frames_k[:max_frames]
    # pybullet's camera yaw 0 looks along +y from -y: yaw0 - 30 deg is the robot's right side,
    # 30 deg behind it.
    cam_yaw = math.degrees(initial_pose(rec_measured, 1).yaw0) - 30.0
    w, h = size
    font, small = _font(max(10, h // 14)), _font(max(9, h // 18))
    scene = _Scene(size)
    images: list[Image.Image] = []
    t_render = 0.0
    try:
        meas = panels[0]
        for k in frames_k:
            frame = Image.new("RGB", (w * len(panels), h))
            for i, (lab, pan) in enumerate(zip(labels, panels)):
                scene.pose(pan["position"][k], pan["orientation"][k], pan["q"][k])
                scene.tint(_TINTS[i % len(_TINTS)])
                target = meas["position"][k] if follow == "measured" else pan["position"][k]
                view = scene.camera(target, cam_yaw)
                t0 = time.perf_counter()
                paths = [(meas["position"][:k + 1, :2], _MEASURED_PATH)]
                if i > 0:
                    paths.append((pan["position"][:k + 1, :2], _rgb(_TINTS[i % len(_TINTS)])))
                panel = scene.render(view, scene.floor(view, target, paths))
                t_render += time.perf_counter() - t0
                d = ImageDraw.Draw(panel)
                d.text((6, 4), lab, fill=(0, 0, 0), font=font)
                d.text((6, 4 + h // 12), f"t = {(k + 1) * CONTROL_DT:.2f} s", fill=(40, 40, 40),
                       font=small)
                if i > 0:
                    if pan["finite"][k]:
                        err = float(np.hypot(*(pan["position"][k, :2] - meas["position"][k, :2])))
                        msg, col = f"xy error {err:.3f} m", (40, 40, 40)
                    else:
                        msg, col = "diverged (frozen)", (200, 0, 0)
                    d.text((6, 4 + 2 * h // 12), msg, fill=col, font=small)
                frame.paste(panel, (i * w, 0))
                if i > 0:
                    ImageDraw.Draw(frame).line([(i * w, 0), (i * w, h)], fill=(255, 255, 255),
                                               width=2)
            images.append(frame.quantize(colors=_GIF_COLOURS, method=Image.Quantize.FASTOCTREE,
                                         dither=Image.Dither.NONE))
    finally:
        scene.close()
    out_path.parent.mkdir(parents=True, exist_ok=True)
    duration_ms = int(round(1000.0 * step * CONTROL_DT))
    images[0].save(out_path, save_all=True, append_images=images[1:], duration=duration_ms,
                   loop=0, optimize=False)
    return {"path": str(out_path), "n_frames": len(images), "n_panels": len(panels),
            "labels": labels, "size": [w, h], "image_size": [w * len(panels), h], "fps": fps,
            "frame_step": step, "duration_s": round(len(images) * duration_ms / 1000.0, 3),
            "wall_s": round(time.perf_counter() - t_start, 2),
            "ms_per_panel_frame": round(1000.0 * t_render / max(1, len(images) * len(panels)), 1)}
