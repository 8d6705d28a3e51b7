"""The pybullet LittleDog: one simulated robot per pybullet DIRECT client.

Timing (docs/interface.md §2): measurement k is taken at t = k * 10 ms, then command k is held
for 10 ms = ``config.substeps`` physics steps. Per physics step: effects' ``substep`` hooks, one
servo update, ``stepSimulation``, one encoder sample.

World reuse and determinism: the robot stands up once per :class:`LittleDogSim` (``settle_time``
of holding HOME_POSE from a pose with the feet just touching the ground) and that settled state is
stored; with ``stand_up=False`` only when a move first starts at home, in a world built again
for it (a replay, which starts from measured states, never stands up).
:meth:`LittleDogSim.reconfigure` builds the world again in the same client for another config,
as a new robot of that config would be. Each :meth:`LittleDogSim.reset` starts from the world
as it was built: restored from a pybullet snapshot taken when it was built (``restoreState``
and a collision pass that drops the last move's contact points), or built again
(``resetSimulation`` and a reload) after a move that may have changed it: one with an effect
that does not declare ``changes_world = False`` (docs/interface.md §5), one cut short inside a
step, or one whose state became non-finite. It then writes the stored (or a given
:class:`InitialState`) state into it, so every move is a pure function of (config, initial
state, commands, effects, seed), whatever ran before in that process; effects may add bodies or
constraints in their ``reset`` without cleaning up.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
import pybullet as p

from ..data.recording import MoveRecording
from ..layout import (CONTROL_DT, CONTROL_DT_NS, DATASET_MOVE_TYPES, HOME_POSE, JOINT_LOWER,
                      JOINT_NAMES, JOINT_UPPER, LEGS, N_JOINTS, UNKNOWN_MOVE_TYPE)
from .config import URDF_PATH, RobotConfig, as_config, per_joint, robot_config
from ..rotations import quat_from_rotvec, quat_multiply, quat_to_matrix
from .sensors import JointEncoders, MotionCapture, twist_from_poses
from .servo import make_servo

__all__ = ["LittleDogSim", "InitialState", "simulate_move", "get_sim", "RobotConfig", "robot_config",
           "OBS_FIELDS"]

FOOT_RADIUS = 0.0103  # m, the URDF's foot sphere
GRAVITY = 9.81
OBS_FIELDS: tuple[str, ...] = ("q", "dq", "position", "orientation", "linear_velocity",
                               "angular_velocity")
#: how a re-simulation's starting state is taken from a recording (:meth:`InitialState.at`)
INITIAL_STATES: tuple[str, ...] = ("measured", "smoothed")


@dataclass(frozen=True)
class InitialState:
    """A full robot state to start a move from (instead of standing up at home).

    position (3,) body origin in odom [m]; orientation (4,) xyzw; q, dq (12,) joint angles [rad]
    and rates [rad/s], contract order; linear_velocity, angular_velocity (3,) of the body in
    base_link [m/s], [rad/s] (the frame the odometry uses). ``reported_dq`` (12,): the rates
    the encoders report at the start, i.e. the state of their rate filter; None: ``dq`` (a
    robot at rest in the filter).
    """

    position: np.ndarray
    orientation: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray
    reported_dq: np.ndarray | None = None

    @classmethod
    def from_recording(cls, rec: MoveRecording, k: int = 0) -> "InitialState":
        """The state measured at step k of a recording.

        Measured values stand in for the true state: the twist is the recording's finite
        difference over the previous step, the joint rates are the filtered encoder rates, and a
        noisy pose may put a foot slightly into (pybullet pushes it out) or above the ground.
        """
        return cls(rec.position[k].copy(), rec.orientation[k].copy(), rec.q[k].copy(),
                   rec.dq[k].copy(), rec.linear_velocity[k].copy(), rec.angular_velocity[k].copy())

    @classmethod
    def smoothed(cls, rec: MoveRecording, k: int, body_half_window: int = 3,
                 joint_half_window: int = 0) -> "InitialState":
        """The state at step k estimated offline from the measurements around it.

        :meth:`from_recording` takes a backward difference of noisy poses for the twist (with
        the measured robot's 0.3 mm and 1 mrad of motion-capture noise, about 0.04 m/s and
        0.14 rad/s of noise on a 10 ms difference) and the
        encoders' low-passed rate for the joint rates (late by the filter's time constant).
        Re-simulated from such a state, a robot's first steps carry that error, and a fit of
        physical parameters to them is biased (errors in the variables). Here the body's pose
        and twist are a local quadratic least-squares fit over the steps k - w .. k + w
        (clipped to the move; w = ``body_half_window``): its value and slope at k. The
        orientation is fitted as the rotation vector relative to the measured one at k, so the
        slope is the angular velocity in base_link. The joints are fitted the same way over
        ``joint_half_window`` steps, or (0, the default) taken as measured: their encoders are
        only quantised, and the filtered rate (a few ms late) is closer to the servo-rate
        motion than any difference over 10 ms steps (``benchmarks/calibrate``). The encoders'
        rate filter starts from the rates recorded at k (``reported_dq``), which is what they
        reported then.
        """
        from ..rotations import quat_conjugate, quat_from_rotvec, rotvec_from_quat
        n1 = rec.q.shape[0]
        if not 0 <= k < n1:
            raise ValueError(f"{rec.name}: step {k} is outside the recording's {n1} measurements")

        def window(w: int) -> tuple[slice, np.ndarray] | None:
            lo, hi = max(0, k - w), min(n1 - 1, k + w)
            if hi - lo < 2:             # too short a move for a quadratic
                return None
            t = (np.arange(lo, hi + 1) - k) * CONTROL_DT
            return slice(lo, hi + 1), np.linalg.pinv(np.stack([np.ones_like(t), t, t * t], 1))

        body = window(body_half_window)
        joints = window(joint_half_window) if joint_half_window > 0 else None
        if body is None or (joint_half_window > 0 and joints is None):
            return cls.from_recording(rec, k)
        sl, fit = body                  # rows 0 and 1 of fit @ y: value and slope at k
        pos, v_world = fit[:2] @ np.asarray(rec.position[sl], float)
        q_k = np.asarray(rec.orientation[k], float)
        orns = np.asarray(rec.orientation[sl], float)
        rel = rotvec_from_quat(quat_multiply(np.broadcast_to(quat_conjugate(q_k), orns.shape),
                                             orns))
        phi, omega = fit[:2] @ rel
        orn = quat_multiply(q_k[None, :], quat_from_rotvec(phi[None, :]))[0]
        if joints is None:
            q, dq = np.asarray(rec.q[k], float).copy(), np.asarray(rec.dq[k], float).copy()
        else:
            q, dq = joints[1][:2] @ np.asarray(rec.q[joints[0]], float)
        r = quat_to_matrix(orn)
        return cls(pos, orn / np.linalg.norm(orn), q, dq, r.T @ v_world, omega,
                   np.asarray(rec.dq[k], float).copy())

    @classmethod
    def at(cls, rec: MoveRecording, k: int, kind: str = "measured") -> "InitialState":
        """The starting state at step k of ``kind`` (:data:`INITIAL_STATES`): ``"measured"``
        (:meth:`from_recording`) or ``"smoothed"`` (:meth:`smoothed`); ValueError otherwise."""
        if kind == "measured":
            return cls.from_recording(rec, k)
        if kind == "smoothed":
            return cls.smoothed(rec, k)
        raise ValueError(f"initial state must be one of {', '.join(INITIAL_STATES)}, "
                         f"got {kind!r}")

    def validated(self) -> "InitialState":
        """The state as float64 vectors, the orientation normalised (arrays that are float64
        vectors already are used as they are: views, read-only where they are); ValueError on
        a wrong shape, NaN or a zero quaternion."""
        shapes = {"position": 3, "orientation": 4, "q": N_JOINTS, "dq": N_JOINTS,
                  "linear_velocity": 3, "angular_velocity": 3}
        out = {}
        for name, n in shapes.items():
            a = np.asarray(getattr(self, name), dtype=float).reshape(-1)
            if a.shape != (n,) or not np.all(np.isfinite(a)):
                raise ValueError(f"InitialState.{name} must be {n} finite numbers, got {a.shape}")
            out[name] = a
        norm = np.linalg.norm(out["orientation"])
        if norm < 1e-6:
            raise ValueError("InitialState.orientation is not a rotation (zero quaternion)")
        out["orientation"] = out["orientation"] / norm
        if self.reported_dq is not None:
            a = np.asarray(self.reported_dq, dtype=float).reshape(-1)
            if a.shape != (N_JOINTS,) or not np.all(np.isfinite(a)):
                raise ValueError(f"InitialState.reported_dq must be {N_JOINTS} finite numbers, "
                                 f"got {a.shape}")
            out["reported_dq"] = a
        return InitialState(**out)


class LittleDogSim:
    """One LittleDog in its own pybullet DIRECT client.

    Attributes for effects (docs/interface.md §5): ``client``, ``robot`` (body id),
    ``joint_indices`` (12 pybullet joint indices, contract order), ``physics_dt``, ``control_dt``,
    ``rng`` (numpy Generator of the current move). Also ``config``, ``time`` [s since reset],
    ``foot_links`` (4 link indices, LEGS order), ``plane`` (ground body id), and
    :meth:`joint_state` (the joints as the last physics step left them, read once per step).

    Use: ``sim.reset(seed=...)``; ``obs = sim.observe()``; ``sim.step(u)``; ... ``sim.close()``.
    """

    def __init__(self, config: RobotConfig | str = "measured", *, stand_up: bool = True) -> None:
        """``stand_up`` False: the settled home stance is found when a move first starts from
        it (:meth:`reset` without ``initial``), not now; a robot only ever started from given
        states (a replay) then never stands up."""
        self.client = p.connect(p.DIRECT)
        self._snapshot = -1              # pybullet state saved as the world was built
        self._configure(as_config(config), stand_up)

    def reconfigure(self, config: RobotConfig | str, *, stand_up: bool = True) -> None:
        """This client's world built again for ``config``: afterwards the robot is what
        ``LittleDogSim(config, stand_up=stand_up)`` would be, move for move, without a new
        pybullet client (a calibration re-simulates robot after robot). A config that fails
        to build closes the robot (``client`` -1) before its error propagates: a robot half
        built for it never passes for it."""
        try:
            self._configure(as_config(config), stand_up)
        except BaseException:
            self.close()
            raise

    def _configure(self, config: RobotConfig, stand_up: bool) -> None:
        self.config = config
        self.physics_dt = self.config.physics_dt
        self.control_dt = CONTROL_DT
        self.substeps = self.config.substeps
        self.rng = np.random.default_rng(0)
        self._servo = make_servo(self.config)
        self._encoders = self._make_encoders()
        # the joints are read after every physics step where the servo or the encoders need it
        self._needs_joints = self._servo.needs_encoders or not self._encoders.exact
        self._js: tuple[np.ndarray, np.ndarray] | None = None   # joint_state(), this step's
        self._mocap = MotionCapture(self.config.mocap_position_std, self.config.mocap_orientation_std,
                                    self.config.sensor_noise, np.random.default_rng(0))
        self._command_hooks: list[Callable] = []
        self._substep_hooks: list[Callable] = []
        self._measure_hooks: list[Callable] = []
        self._step_count = 0
        self._obs: dict[str, np.ndarray] = {}
        self._prev_pose: tuple[np.ndarray, np.ndarray] = (np.zeros(3), np.array([0, 0, 0, 1.0]))
        self._world_as_built = False     # only poses, velocities and contacts changed since
        self._build_world()
        self._home: InitialState | None = self._stand_up() if stand_up else None

    def _home_state(self) -> InitialState:
        """The settled home stance, found now if it was not when the robot was built: in a
        world built again first, exactly as the constructor finds it."""
        if self._home is None:
            self._build_world()
            self._encoders = self._make_encoders()
            self._home = self._stand_up()
        return self._home

    # ----------------------------------------------------------------------------- world set-up
    def _make_encoders(self) -> JointEncoders:
        res = self.config.encoder_resolution
        return JointEncoders(None if res is None else per_joint(res), self.config.rate_filter_hz,
                             self.physics_dt)

    def _build_world(self) -> None:
        """(Re)create ground and robot in this client with the config's dynamics."""
        c, cfg = self.client, self.config
        if self._snapshot >= 0:
            p.removeState(self._snapshot, physicsClientId=c)
            self._snapshot = -1
        p.resetSimulation(physicsClientId=c)
        self._js = None
        p.setGravity(0, 0, -GRAVITY, physicsClientId=c)
        p.setPhysicsEngineParameter(fixedTimeStep=self.physics_dt, numSubSteps=0,
                                    numSolverIterations=cfg.solver_iterations, enableConeFriction=0,
                                    deterministicOverlappingPairs=1, physicsClientId=c)
        plane_shape = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=c)
        self.plane = p.createMultiBody(0, plane_shape, physicsClientId=c)
        p.changeDynamics(self.plane, -1, lateralFriction=cfg.ground_friction, physicsClientId=c)
        self.robot = p.loadURDF(str(URDF_PATH), [0, 0, 0.3], flags=p.URDF_USE_INERTIA_FROM_FILE,
                                physicsClientId=c)
        by_name = {p.getJointInfo(self.robot, j, physicsClientId=c)[1].decode(): j
                   for j in range(p.getNumJoints(self.robot, physicsClientId=c))}
        self.joint_indices = [by_name[n] for n in JOINT_NAMES]
        self.foot_links = [by_name[f"{leg}_foot_fixed"] for leg in LEGS]
        self._apply_mass_model(by_name)
        for link in self.foot_links:
            p.changeDynamics(self.robot, link, lateralFriction=cfg.foot_friction, physicsClientId=c)
        self._servo.start(c, self.robot, self.joint_indices)
        self._snapshot = p.saveState(physicsClientId=c)
        self._world_as_built = True

    def _restore_world(self) -> None:
        """The world as :meth:`_build_world` left it, for a new move: restored from its
        snapshot (poses, velocities, contact points) where nothing else changed since, rebuilt
        otherwise (module doc)."""
        if self._world_as_built and self._snapshot >= 0:
            p.restoreState(self._snapshot, physicsClientId=self.client)
            self._js = None
            # the robot is back in the air where it was built: a collision pass drops the
            # contact points the last move left (their impulses would warm-start the solver)
            p.performCollisionDetection(physicsClientId=self.client)
            self._servo.start(self.client, self.robot, self.joint_indices)
        else:
            self._build_world()

    def _apply_mass_model(self, by_name: dict[str, int]) -> None:
        """Scale link masses/inertias to the config's masses and add the armature."""
        c, cfg = self.client, self.config
        info = p.getDynamicsInfo(self.robot, -1, physicsClientId=c)
        body_scale = cfg.mass_scale * (1.0 if cfg.body_mass is None else cfg.body_mass / info[0])
        if body_scale != 1.0:
            p.changeDynamics(self.robot, -1, mass=info[0] * body_scale,
                             localInertiaDiagonal=[v * body_scale for v in info[2]], physicsClientId=c)
        leg_links = [by_name[f"{leg}_{j}"] for leg in LEGS for j in ("hip_roll", "hip_pitch", "knee")]
        urdf_leg_mass = sum(p.getDynamicsInfo(self.robot, j, physicsClientId=c)[0] for j in leg_links[:3])
        leg_scale = cfg.mass_scale * (1.0 if cfg.leg_mass is None else cfg.leg_mass / urdf_leg_mass)
        armature = np.tile(cfg.armature, len(LEGS))
        for k, j in enumerate(leg_links):
            mass, _, inertia = p.getDynamicsInfo(self.robot, j, physicsClientId=c)[:3]
            inertia = np.array(inertia) * leg_scale
            inertia[0 if k % 3 == 0 else 1] += armature[k]  # hip roll about x, pitch/knee about y
            if leg_scale != 1.0 or armature[k] != 0.0:
                p.changeDynamics(self.robot, j, mass=mass * leg_scale,
                                 localInertiaDiagonal=inertia.tolist(), physicsClientId=c)

    def total_mass(self) -> float:
        """Mass of the robot as pybullet simulates it [kg]."""
        c = self.client
        links = range(-1, p.getNumJoints(self.robot, physicsClientId=c))
        return float(sum(p.getDynamicsInfo(self.robot, j, physicsClientId=c)[0] for j in links))

    def _stand_up(self) -> InitialState:
        """Hold HOME_POSE from feet-on-the-ground for settle_time; return the settled state."""
        c = self.client
        for k, j in enumerate(self.joint_indices):
            p.resetJointState(self.robot, j, HOME_POSE[k], 0.0, physicsClientId=c)
        self._js = None
        p.resetBasePositionAndOrientation(self.robot, [0, 0, 0.3], [0, 0, 0, 1], physicsClientId=c)
        feet = p.getLinkStates(self.robot, self.foot_links, computeForwardKinematics=True,
                               physicsClientId=c)
        lowest = min(s[4][2] for s in feet)
        p.resetBasePositionAndOrientation(self.robot, [0, 0, 0.3 - lowest + FOOT_RADIUS + 5e-4],
                                          [0, 0, 0, 1], physicsClientId=c)
        self._encoders.reset(HOME_POSE, np.zeros(N_JOINTS))
        self._servo.start(c, self.robot, self.joint_indices)
        for _ in range(int(round(self.config.settle_time / self.physics_dt))):
            self._physics_step(HOME_POSE)
        return self.true_state()

    # ----------------------------------------------------------------------------- state access
    def true_state(self) -> InitialState:
        """The simulator's exact state now (velocities in base_link)."""
        c = self.client
        pos, orn = p.getBasePositionAndOrientation(self.robot, physicsClientId=c)
        lin, ang = p.getBaseVelocity(self.robot, physicsClientId=c)
        r = quat_to_matrix(np.array(orn))
        q, dq = self._joint_state()
        return InitialState(np.array(pos), np.array(orn), q, dq, r.T @ np.array(lin), r.T @ np.array(ang))

    def _joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        q, dq, _, _ = zip(*p.getJointStates(self.robot, self.joint_indices,
                                           physicsClientId=self.client))
        return np.array(q), np.array(dq)

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The joints' true angles and rates (12,) each, contract order: as the last physics
        step (or, before a move's first step, the reset) left them, read once and shared by the
        servo's encoders and every plug-in that asks before the next step. The arrays are
        shared and read-only (copy before changing). A plug-in that changes joint states itself
        (``resetJointState`` and the like) in a substep hook calls :meth:`forget_joint_state`
        after; after the reset hooks the joints are read again anyway."""
        if self._js is None:
            q, dq = self._joint_state()
            q.setflags(write=False)
            dq.setflags(write=False)
            self._js = (q, dq)
        return self._js

    def forget_joint_state(self) -> None:
        """Drop the joint state :meth:`joint_state` keeps (the joints were set since)."""
        self._js = None

    def _write_state(self, s: InitialState) -> None:
        c = self.client
        r = quat_to_matrix(s.orientation)
        p.resetBasePositionAndOrientation(self.robot, s.position.tolist(), s.orientation.tolist(),
                                          physicsClientId=c)
        p.resetBaseVelocity(self.robot, (r @ s.linear_velocity).tolist(),
                            (r @ s.angular_velocity).tolist(), physicsClientId=c)
        for k, j in enumerate(self.joint_indices):
            p.resetJointState(self.robot, j, s.q[k], s.dq[k], physicsClientId=c)
        self._js = None

    @property
    def time(self) -> float:
        """Simulated time since the last reset [s]."""
        return self._step_count * self.physics_dt

    # ----------------------------------------------------------------------------- a move
    def reset(self, *, initial: InitialState | None = None, seed: int = 0,
              effects: Sequence[Any] = ()) -> dict[str, np.ndarray]:
        """Start a move: the world as built (:meth:`_restore_world`), the state set, the
        effects reset; return obs at t=0.

        Args:
            initial: state to start from; None = the settled home stance.
            seed: seeds the sensor noise and ``self.rng`` (given to effects), independently.
            effects: plug-ins (docs/interface.md §5), any of reset/command/substep/measure.
        """
        state = self._home_state() if initial is None else initial.validated()
        sensor_seed, effect_seed = np.random.SeedSequence(seed).spawn(2)
        self.rng = np.random.default_rng(effect_seed)
        self._mocap.rng = np.random.default_rng(sensor_seed)
        self._restore_world()
        self._write_state(state)
        self._step_count = 0
        self._encoders.reset(state.q, state.dq, state.reported_dq)
        effects = self._own_effects() + list(effects)
        self._command_hooks = [e.command for e in effects if hasattr(e, "command")]
        self._substep_hooks = [e.substep for e in effects if hasattr(e, "substep")]
        self._measure_hooks = [e.measure for e in effects if hasattr(e, "measure")]
        resets = [e.reset for e in effects if hasattr(e, "reset")]
        # an effect may change the world (a body, a mass, the gravity, a friction), at reset or
        # later: the next move then builds it again; effects that do not say so
        self._world_as_built = all(getattr(e, "changes_world", True) is False for e in effects)
        for hook in resets:
            hook(self)
        self._js = None     # a reset hook may have set the joints
        if resets:   # a reset hook may have moved the body (e.g. onto a floor it has tilted)
            state = self.true_state()
        # The pose one control step earlier (constant-velocity extrapolation), measured, so that
        # the first twist is a finite difference like all later ones.
        r = quat_to_matrix(state.orientation)
        prev_pos = state.position - CONTROL_DT * (r @ state.linear_velocity)
        prev_orn = quat_multiply(state.orientation, quat_from_rotvec(-CONTROL_DT * state.angular_velocity))
        self._prev_pose = self._mocap.measure(prev_pos, prev_orn)
        self._obs = self._measure()
        return self.observe()

    def _own_effects(self) -> list[Any]:
        """The config's own plug-ins, fresh for each move: its command delay."""
        if self.config.command_delay_ms > 0:
            from .effects import SetpointDelay
            return [SetpointDelay(self.config.command_delay_ms)]
        return []

    def observe(self) -> dict[str, np.ndarray]:
        """The measurement taken at the current time (a copy; fields of OBS_FIELDS)."""
        return {k: v.copy() for k, v in self._obs.items()}

    def step(self, u: np.ndarray) -> dict[str, np.ndarray]:
        """Hold desired angles u (12,) for one control step; return the next measurement.

        Raises ValueError on a wrong shape or a non-finite value (nothing is simulated then).
        """
        t = self.time
        u = np.asarray(u, dtype=float)
        if u.shape != (N_JOINTS,) or not np.isfinite(u).all():
            raise ValueError(f"a command must be {N_JOINTS} finite joint angles, got shape {u.shape}")
        for hook in self._command_hooks:
            u = np.asarray(hook(u.copy(), t), dtype=float)
        q_des = np.clip(u, JOINT_LOWER, JOINT_UPPER)
        # a step cut short (a hook raising, an interrupt) leaves forces and torques applied in
        # the world: until the step ends, the next move builds the world again
        as_built, self._world_as_built = self._world_as_built, False
        for s in range(self.substeps):
            for hook in self._substep_hooks:
                hook(self, t + s * self.physics_dt)
            self._physics_step(q_des)
        self._obs = self._measure()
        # a state gone non-finite leaves state a snapshot does not restore: build it again
        self._world_as_built = as_built and all(
            np.isfinite(self._obs[k]).all() for k in ("q", "dq", "position", "orientation"))
        return self.observe()

    def _physics_step(self, q_des: np.ndarray) -> None:
        self._servo.apply(self.client, self.robot, self.joint_indices, q_des, self._encoders)
        p.stepSimulation(physicsClientId=self.client)
        self._step_count += 1
        self._js = None
        if self._needs_joints:
            self._encoders.update(*self.joint_state())

    def _measure(self) -> dict[str, np.ndarray]:
        if self._encoders.exact:  # not sampled every physics step: sample now
            self._encoders.update(*self.joint_state())
        pos, orn = p.getBasePositionAndOrientation(self.robot, physicsClientId=self.client)
        pos_m, orn_m = self._mocap.measure(np.array(pos), np.array(orn))
        lin, ang = twist_from_poses(*self._prev_pose, pos_m, orn_m, CONTROL_DT)
        self._prev_pose = (pos_m, orn_m)
        obs = {"q": self._encoders.position.copy(), "dq": self._encoders.rate.copy(),
               "position": pos_m, "orientation": orn_m, "linear_velocity": lin,
               "angular_velocity": ang}
        t = self.time
        for hook in self._measure_hooks:
            obs = hook(obs, t)
        return obs

    def close(self) -> None:
        """Disconnect the pybullet client."""
        self._js = None
        if self.client >= 0:
            p.disconnect(physicsClientId=self.client)
            self.client = -1

    def __enter__(self) -> "LittleDogSim":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


_SIMS: dict[RobotConfig, LittleDogSim] = {}


def get_sim(robot: str | RobotConfig = "measured") -> LittleDogSim:
    """A process-wide LittleDogSim for this config, created (and stood up) on first use."""
    config = as_config(robot)
    sim = _SIMS.get(config)
    if sim is None or sim.client < 0:
        sim = _SIMS[config] = LittleDogSim(config)
    return sim


def simulate_move(commands: np.ndarray, *, robot: str | RobotConfig = "measured",
                  effects: Sequence[Any] = (), seed: int = 0, name: str = "F_00",
                  move_type: str = "F", initial: InitialState | None = None,
                  start_ns: int = 0) -> MoveRecording:
    """Simulate one move and record it as the robot's sensors see it.

    Args:
        commands: (N, 12) desired joint angles, contract order; command k is held from
            t = k * 10 ms to (k+1) * 10 ms.
        robot: "measured", "nominal" or a RobotConfig.
        effects: effect plug-ins active during the move (see robot/effects.py).
        seed: seeds sensor noise and the effects' rng.
        name, move_type: the recording's bag name and move type (one of layout.MOVE_TYPES, or
            U: the commands of a move of unknown type, e.g. an imported one re-simulated).
        initial: start state; None = standing settled in the home pose.
        start_ns: stamp of measurement 0.
    Returns:
        MoveRecording with N+1 measurements (k = 0..N) and ``cmd`` = the commands as sent
        (before effects altered them).
    """
    cmd = np.array(commands, dtype=float)
    if cmd.ndim != 2 or cmd.shape[1] != N_JOINTS or cmd.shape[0] < 1:
        raise ValueError(f"commands must have shape (N, {N_JOINTS}), got {cmd.shape}")
    if not np.all(np.isfinite(cmd)):
        raise ValueError("commands hold NaN or inf")
    _check_move_type(move_type)
    sim = get_sim(robot)
    obs = [sim.reset(initial=initial, seed=seed, effects=effects)]
    for u in cmd:
        obs.append(sim.step(u))
    return _as_recording(obs, cmd, name, move_type, start_ns)


def simulate_closed_loop(policy: Callable[[dict], np.ndarray], n_steps: int, *,
                         robot: str | RobotConfig = "measured", effects: Sequence[Any] = (),
                         seed: int = 0, name: str = "U_00", move_type: str = UNKNOWN_MOVE_TYPE,
                         initial: InitialState | None = None, start_ns: int = 0) -> MoveRecording:
    """Simulate one move driven by ``policy`` and record it as :func:`simulate_move` does.

    ``policy(measurement)`` is called with each measurement k = 0..n_steps-1 (the dict
    :meth:`LittleDogSim.step` returns) and gives the joint command (12,) held until the next
    one; the recording's ``cmd`` are those commands. A non-finite or misshapen command is a
    ValueError naming its step.
    """
    if int(n_steps) < 1:
        raise ValueError(f"n_steps must be at least 1, got {n_steps}")
    _check_move_type(move_type)
    sim = get_sim(robot)
    obs = [sim.reset(initial=initial, seed=seed, effects=effects)]
    cmd = np.empty((int(n_steps), N_JOINTS))
    for k in range(int(n_steps)):
        u = np.asarray(policy(obs[-1]), dtype=float)
        if u.shape != (N_JOINTS,) or not np.isfinite(u).all():
            raise ValueError(f"the policy's command at step {k} is not {N_JOINTS} finite "
                             f"angles (shape {u.shape}, {int(np.sum(~np.isfinite(u)))} "
                             f"not finite)")
        cmd[k] = u
        obs.append(sim.step(u))
    return _as_recording(obs, cmd, name, move_type, start_ns)


def _check_move_type(move_type: str) -> None:
    if move_type not in DATASET_MOVE_TYPES:
        raise ValueError(f"unknown move type {move_type!r}; expected one of "
                         f"{' '.join(DATASET_MOVE_TYPES)}")


def _as_recording(obs: list, cmd: np.ndarray, name: str, move_type: str,
                  start_ns: int) -> MoveRecording:
    n = cmd.shape[0]
    arrays = {f: np.array([o[f] for o in obs], dtype=float) for f in OBS_FIELDS}
    rec = MoveRecording(name=name, move_type=move_type,
                        stamps_ns=start_ns + CONTROL_DT_NS * np.arange(n + 1, dtype=np.int64),
                        cmd=cmd, **arrays)
    rec.validate()
    return rec
