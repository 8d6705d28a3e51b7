"""What the viewer replays: one robot's poses over time (a :class:`Track`), from a bag, a
learned simulator or the physics baseline, all aligned like the rollout metrics (plain NumPy).

Alignment (as ``rollout.simulate`` and ``animate``): a move's measurements k = 0..N; the learned
simulator and the physics baseline start in the state measured at k = 1 and get the recorded
u_1..u_{N-1}; every track holds k = 2..N at t = k * 10 ms, so frame i of every track is the same
instant.

- measured: the recorded odometry pose and joint angles;
- learned: :class:`..rollout.learned_sim.LearnedSimulator` (exactly what ``sim_node`` steps,
  with any projection), also giving the (x, y) pose covariance when the model has a std;
- physics: ``baseline.physics_rollout`` (the pybullet robot of a config replaying the
  commands), posed like ``animate.panel_poses``.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..data.recording import MoveRecording
from ..layout import CONTROL_DT, N_JOINTS

__all__ = ["Track", "measured_track", "learned_track", "physics_track", "xy_gap",
           "joint_errors", "load_recording", "rollout_file_settings"]


@dataclass
class Track:
    """One robot over T frames: time [s], base position (T, 3), orientation (T, 4) xyzw, joint
    angles (T, 12) in JOINT_NAMES order, optional (x, y) pose covariance (T, 2, 2)."""

    label: str
    t: np.ndarray
    position: np.ndarray
    orientation: np.ndarray
    q: np.ndarray
    cov_xy: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = self.t.shape[0]
        for name, width in (("position", 3), ("orientation", 4), ("q", N_JOINTS)):
            a = getattr(self, name)
            if a.shape != (n, width):
                raise ValueError(f"track {self.label}: {name} has shape {a.shape}, expected "
                                 f"({n}, {width})")
        if self.cov_xy is not None and self.cov_xy.shape != (n, 2, 2):
            raise ValueError(f"track {self.label}: cov_xy has shape {self.cov_xy.shape}")

    def __len__(self) -> int:
        return int(self.t.shape[0])


def _times(n: int) -> np.ndarray:
    return (np.arange(n) + 2) * CONTROL_DT            # measurements k = 2..N


def measured_track(rec: MoveRecording, label: str = "measured") -> Track:
    """The recording's own odometry and joint angles at k = 2..N."""
    n = rec.n_steps - 1
    if n < 1:
        raise ValueError(f"{rec.name}: a replay needs at least 2 commands, got {rec.n_steps}")
    return Track(label, _times(n), np.asarray(rec.position[2:], dtype=np.float64),
                 np.asarray(rec.orientation[2:], dtype=np.float64),
                 np.asarray(rec.q[2:], dtype=np.float64))


def learned_track(rec: MoveRecording, model: Any, projection: str = "none", alpha: float = 0.5,
                  radius: float = 0.0, label: str | None = None,
                  use_variance: bool = True) -> Track:
    """The learned simulator stepped through the move as sim_node steps it (module doc)."""
    from ..rollout.learned_sim import LearnedSimulator, model_has_variance
    from ..rollout.simulate import prepare_test_move

    tm = prepare_test_move(rec)
    proj = model.projection(projection, alpha=alpha, radius=radius)
    use_var = bool(use_variance) and model_has_variance(model)
    prepare = getattr(model, "prepare", None)
    if prepare is not None:
        prepare(return_std=use_var)
    sim = LearnedSimulator(model, proj, tm.s0, np.array([tm.pose0.x0, tm.pose0.y0,
                                                         tm.pose0.yaw0]), use_var)
    n = tm.n_steps
    pos, orn, q = np.empty((n, 3)), np.empty((n, 4)), np.empty((n, N_JOINTS))
    cov = np.full((n, 2, 2), np.nan) if use_var else None
    last = 0
    for i, u in enumerate(tm.actions):
        if not sim.step(u) or not sim.outputs_finite():
            break                      # diverged: hold the last finite pose
        pos[i], orn[i], q[i] = sim.position, sim.orientation, sim.q
        if cov is not None and sim.pose_covariance is not None:
            cov[i] = sim.pose_covariance.reshape(6, 6)[:2, :2]
        last = i + 1
    if last == 0:
        raise ValueError(f"{rec.name}: the learned simulator diverged at its first step")
    for a in (pos, orn, q) + ((cov,) if cov is not None else ()):
        a[last:] = a[last - 1]
    if label is None:
        label = f"{getattr(model, 'method', 'learned')} " + projection_label(projection, alpha,
                                                                             radius)
    return Track(label, _times(n), pos, orn, q, cov)


def physics_track(rec: MoveRecording, config: Any = "nominal", label: str = "physics") -> Track:
    """The pybullet robot ``config`` (a RobotConfig or a robot name) replaying the move."""
    from ..apps.animate import panel_poses
    from ..robot.baseline import physics_rollout
    from ..robot.config import as_config

    states = physics_rollout(rec, as_config(config))
    p = panel_poses(rec, states)
    return Track(label, _times(states.shape[0]), p["position"], p["orientation"], p["q"])


def projection_label(kind: str, alpha: float = 0.5, radius: float = 0.0) -> str:
    """Short name of a projection: "none", "BOUND", "alpha 0.5", "alpha 0.5 r 1.2"."""
    if kind == "alpha":
        return f"alpha {alpha:g}" + (f" r {radius:.3g}" if radius else "")
    return {"bound": "BOUND"}.get(kind, kind)


def xy_gap(track: Track, ref: Track) -> np.ndarray:
    """(T,) distance [m] in the ground plane between two tracks' bodies, frame by frame."""
    n = min(len(track), len(ref))
    return np.linalg.norm(track.position[:n, :2] - ref.position[:n, :2], axis=1)


def joint_errors(track: Track, ref: Track) -> np.ndarray:
    """(T, 12) joint-angle differences [rad] track - ref, frame by frame."""
    n = min(len(track), len(ref))
    return track.q[:n] - ref.q[:n]


def load_recording(bag: str | os.PathLike | None = None, data: str | os.PathLike | None = None,
                   move: str | None = None) -> MoveRecording:
    """A bag directory, or the move ``move`` of the dataset ``data`` (default: its first
    TestPool move); ValueError with one line on anything missing or malformed."""
    from ..data.bags import move_type_from_name, read_bag

    if bag is not None:
        path = Path(bag)
        if not path.is_dir():
            raise ValueError(f"{path}: no such bag directory")
        try:
            mt = move_type_from_name(path.name)
        except ValueError:
            mt = "S"          # a bag not named <TYPE>_<NN>: the type only labels the move
        return read_bag(path, move_type=mt)
    if data is None:
        raise ValueError("give a bag, or a dataset and a move")
    from ..data.dataset import read_index

    index = read_index(data)
    entries = index.entries
    if move is None:
        tests = [e for e in entries if e.split == "test"]
        if not (tests or entries):
            raise ValueError(f"{data}: no moves")
        entry = (tests or entries)[0]
    else:
        found = [e for e in entries if e.name == move]
        if not found:
            raise ValueError(f"{data}: no move {move} in dataset.yaml")
        entry = found[0]
    return read_bag(Path(data) / entry.name, move_type=entry.move_type)


def rollout_file_settings(path: str | os.PathLike) -> dict[str, Any]:
    """Model, dataset, projection, alpha, radius and first move of a ``rollout.json`` written
    by ``littledog-mlsim rollout`` (it holds metrics, not states: the viewer re-runs the move)."""
    path = Path(path)
    if path.is_dir():
        path = path / "rollout.json"
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"{path}: not a readable rollout.json: {e}") from None
    if not isinstance(doc, dict) or not doc.get("model") or not doc.get("data"):
        raise ValueError(f"{path}: not a rollout.json (no model/data entries)")
    moves: Sequence[Any] = doc.get("per_move") or []
    return {"model": doc["model"], "data": doc["data"],
            "projection": doc.get("projection") if doc.get("projection") in
            ("none", "bound", "alpha") else "alpha",
            "alpha": float(doc.get("alpha") or 0.5), "radius": float(doc.get("radius") or 0.0),
            "move": moves[0]["name"] if moves and isinstance(moves[0], dict)
            and "name" in moves[0] else None}
