"""Effect plug-ins: unmodelled physics switched on while recording (docs/interface.md §5).

An effect is any object implementing some of

- ``reset(sim)`` at the start of a move; ``sim`` exposes ``client`` (pybullet client id),
  ``robot`` (body id), ``joint_indices`` (12, contract order), ``physics_dt``, ``control_dt`` and
  ``rng`` (the move's numpy Generator). The world is rebuilt before every move, so an effect may
  add bodies/constraints or change dynamics here without undoing it.
- ``command(u, t) -> u``: the 12 desired angles (contract order) as the servo will receive them;
  t = k * control_dt [s since the move started].
- ``substep(sim, t)``: before every physics step (forces, torques, terrain). Joint torques sent with
  pybullet TORQUE_CONTROL here add to the servo's torque (pybullet accumulates applied torques
  until the step and then clears them); external forces likewise last one physics step.
- ``measure(obs, t) -> obs``: what the sensors report; ``obs`` maps ``q``, ``dq`` (12,),
  ``position`` (3,), ``orientation`` (4, xyzw), ``linear_velocity``, ``angular_velocity``
  (3, base_link) to arrays.

Effects are listed in a YAML file, a list of ``{class: "package.module:ClassName", params: {...}}``
where the class may also be ``path/to/file.py:ClassName`` (relative to the YAML file's directory,
or absolute); :func:`load_effects` builds them. Joints are addressed by contract names
(``front_left_knee``), leg names (``front_left``), or groups: ``all``, ``hip_rolls``,
``hip_pitches``, ``knees``, ``hips`` (roll and pitch), ``front``, ``back``, ``left``, ``right``.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from collections import deque
from pathlib import Path
from typing import Any, Iterable

import numpy as np
import pybullet as p
import yaml

from ..layout import JOINT_NAMES, LEGS, N_JOINTS

HOOKS: tuple[str, ...] = ("reset", "command", "substep", "measure")


def _group_mask(name: str) -> np.ndarray | None:
    joints = np.array(JOINT_NAMES)
    kinds = {"hip_rolls": "hip_roll", "hip_pitches": "hip_pitch", "knees": "knee"}
    if name == "all":
        return np.ones(N_JOINTS, dtype=bool)
    if name in kinds:
        return np.char.endswith(joints, "_" + kinds[name])
    if name == "hips":
        return ~np.char.endswith(joints, "_knee")
    if name in ("front", "back"):
        return np.char.startswith(joints, name + "_")
    if name in ("left", "right"):
        return np.array([f"_{name}_" in j for j in joints])
    if name in LEGS:
        return np.char.startswith(joints, name + "_")
    if name in JOINT_NAMES:
        return joints == name
    return None


def resolve_joints(spec: str | Iterable[str] | None) -> np.ndarray:
    """Indices (sorted, into contract order) of the joints named by ``spec`` (None = all)."""
    if spec is None:
        return np.arange(N_JOINTS)
    names = [spec] if isinstance(spec, str) else list(spec)
    mask = np.zeros(N_JOINTS, dtype=bool)
    for n in names:
        m = _group_mask(str(n))
        if m is None:
            raise ValueError(f"unknown joint or joint group {n!r}")
        mask |= m
    return np.flatnonzero(mask)


def _values(value: float | Iterable[float], n: int, what: str) -> np.ndarray:
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.size == 1:
        return np.full(n, float(v[0]))
    if v.size != n:
        raise ValueError(f"{what}: expected 1 or {n} values, got {v.size}")
    return v


class CommandDelay:
    """Delays the desired angles of some joints by a whole number of 10 ms control steps.

    Before ``steps`` commands have arrived, the first command of the move is repeated (the robot
    was standing still holding it).
    """

    def __init__(self, steps: int, joints: str | list[str] | None = None) -> None:
        if int(steps) != steps or steps < 0:
            raise ValueError(f"CommandDelay: steps must be a non-negative integer, got {steps!r}")
        self.steps = int(steps)
        self.joints = resolve_joints(joints)
        self._history: deque[np.ndarray] = deque()

    def reset(self, sim: Any) -> None:
        self._history.clear()

    def command(self, u: np.ndarray, t: float) -> np.ndarray:
        if not self._history:
            self._history.extend(u.copy() for _ in range(self.steps))
        self._history.append(u.copy())
        delayed = self._history.popleft()
        out = u.copy()
        out[self.joints] = delayed[self.joints]
        return out


class JointFriction:
    """Joint friction torque -(coulomb * tanh(dq / smoothing) + viscous * dq) on some joints.

    Args:
        coulomb: Coulomb friction [N m], one value or one per selected joint.
        viscous: viscous friction [N m s/rad], one value or one per selected joint.
        joints: joint names/groups (None = all).
        smoothing: velocity [rad/s] over which the Coulomb term goes smoothly through zero.
    """

    def __init__(self, coulomb: float | list[float] = 0.05, viscous: float | list[float] = 0.0,
                 joints: str | list[str] | None = None, smoothing: float = 0.05) -> None:
        self.joints = resolve_joints(joints)
        self.coulomb = _values(coulomb, len(self.joints), "JointFriction.coulomb")
        self.viscous = _values(viscous, len(self.joints), "JointFriction.viscous")
        if smoothing <= 0:
            raise ValueError("JointFriction: smoothing must be positive")
        self.smoothing = float(smoothing)
        self._ids: list[int] = []

    def reset(self, sim: Any) -> None:
        self._ids = [sim.joint_indices[j] for j in self.joints]

    def torque(self, dq: np.ndarray) -> np.ndarray:
        """Friction torque [N m] for the selected joints' rates dq (n_selected,)."""
        return -(self.coulomb * np.tanh(dq / self.smoothing) + self.viscous * dq)

    def substep(self, sim: Any, t: float) -> None:
        states = p.getJointStates(sim.robot, self._ids, physicsClientId=sim.client)
        dq = np.array([s[1] for s in states])
        p.setJointMotorControlArray(sim.robot, self._ids, p.TORQUE_CONTROL,
                                    forces=self.torque(dq), physicsClientId=sim.client)


class Payload:
    """A point mass rigidly fixed to the body at ``offset`` (base_link frame) [kg], [m]."""

    def __init__(self, mass: float, offset: list[float] | tuple[float, float, float] = (0.0, 0.0, 0.0),
                 radius: float = 0.02) -> None:
        if mass <= 0:
            raise ValueError(f"Payload: mass must be positive, got {mass}")
        self.mass = float(mass)
        self.offset = _values(offset, 3, "Payload.offset")
        self.radius = float(radius)
        self.body = -1

    def reset(self, sim: Any) -> None:
        c = sim.client
        pos, orn = p.getBasePositionAndOrientation(sim.robot, physicsClientId=c)
        world, _ = p.multiplyTransforms(pos, orn, self.offset.tolist(), [0, 0, 0, 1])
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=self.radius, physicsClientId=c)
        self.body = p.createMultiBody(self.mass, shape, basePosition=world, baseOrientation=orn,
                                      physicsClientId=c)
        lin, ang = p.getBaseVelocity(sim.robot, physicsClientId=c)
        p.resetBaseVelocity(self.body, lin, ang, physicsClientId=c)
        p.setCollisionFilterGroupMask(self.body, -1, 0, 0, physicsClientId=c)  # no contacts
        cid = p.createConstraint(sim.robot, -1, self.body, -1, p.JOINT_FIXED, [0, 0, 0],
                                 self.offset.tolist(), [0, 0, 0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=1e4, physicsClientId=c)


class ConstantWind:
    """A constant horizontal force in odom on the body's centre of mass [N].

    Being fixed in the world, its effect in the body frame depends on the robot's heading.
    """

    def __init__(self, force_xy: list[float] | tuple[float, float]) -> None:
        f = _values(force_xy, 2, "ConstantWind.force_xy")
        self.force = np.array([f[0], f[1], 0.0])

    def substep(self, sim: Any, t: float) -> None:
        pos, _ = p.getBasePositionAndOrientation(sim.robot, physicsClientId=sim.client)
        p.applyExternalForce(sim.robot, -1, self.force.tolist(), pos, p.WORLD_FRAME,
                             physicsClientId=sim.client)


# ----------------------------------------------------------------------------- loading from YAML
def _import_class(spec: str, base_dir: Path) -> type:
    module_part, sep, class_name = spec.rpartition(":")
    if not sep or not module_part or not class_name:
        raise ValueError("class must look like 'package.module:ClassName' or 'path/file.py:ClassName'")
    if module_part.endswith(".py") or "/" in module_part or "\\" in module_part:
        path = Path(module_part).expanduser()
        path = path if path.is_absolute() else base_dir / path
        if not path.is_file():
            raise ValueError(f"file {str(path)!r} not found")
        mod_name = "littledog_effect_" + hashlib.sha1(str(path.resolve()).encode()).hexdigest()[:12]
        module = sys.modules.get(mod_name)
        if module is None:
            loader_spec = importlib.util.spec_from_file_location(mod_name, path)
            if loader_spec is None or loader_spec.loader is None:
                raise ValueError(f"cannot import {str(path)!r}")
            module = importlib.util.module_from_spec(loader_spec)
            try:
                loader_spec.loader.exec_module(module)
            except Exception as exc:  # the user's file failed to import
                raise ValueError(f"importing {str(path)!r} failed: {type(exc).__name__}: {exc}") from exc
            sys.modules[mod_name] = module
    else:
        try:
            module = importlib.import_module(module_part)
        except Exception as exc:
            raise ValueError(f"cannot import module {module_part!r}: {type(exc).__name__}: {exc}") from exc
    cls = getattr(module, class_name, None)
    if not isinstance(cls, type):
        raise ValueError(f"{module_part!r} has no class {class_name!r}")
    return cls


def build_effect(entry: Any, base_dir: Path | str = ".") -> Any:
    """One effect from a mapping ``{class: ..., params: {...}}`` (see module docs)."""
    if not isinstance(entry, dict) or "class" not in entry:
        raise ValueError("expected a mapping with a 'class' key")
    unknown = set(entry) - {"class", "params"}
    if unknown:
        raise ValueError(f"unknown keys {sorted(unknown)} (allowed: class, params)")
    spec = entry["class"]
    if not isinstance(spec, str):
        raise ValueError("'class' must be a string")
    params = entry.get("params") or {}
    if not isinstance(params, dict):
        raise ValueError("'params' must be a mapping")
    cls = _import_class(spec, Path(base_dir))
    try:
        effect = cls(**params)
    except Exception as exc:
        raise ValueError(f"{cls.__name__}(**params) failed: {type(exc).__name__}: {exc}") from exc
    if not any(callable(getattr(effect, h, None)) for h in HOOKS):
        raise ValueError(f"{cls.__name__} implements none of {', '.join(HOOKS)}")
    return effect


def load_effects(path: str | Path) -> list[Any]:
    """Effects listed in a YAML file (a list of ``{class, params}``; empty file = none).

    Raises:
        ValueError: one line naming the file and the offending entry.
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        reason = " ".join(str(exc).split())
        raise ValueError(f"{path}: cannot read effects: {reason}") from exc
    if data is None:
        return []
    if isinstance(data, dict) and set(data) == {"effects"}:
        data = data["effects"] or []
    if not isinstance(data, list):
        raise ValueError(f"{path}: expected a YAML list of {{class, params}} entries")
    effects = []
    for i, entry in enumerate(data):
        label = entry.get("class") if isinstance(entry, dict) else None
        try:
            effects.append(build_effect(entry, path.parent))
        except ValueError as exc:
            name = f" ({label!r})" if label else ""
            reason = " ".join(str(exc).split())
            raise ValueError(f"{path}: effect #{i + 1}{name}: {reason}") from None
    return effects
