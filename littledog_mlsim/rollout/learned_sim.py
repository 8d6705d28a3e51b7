"""The learned simulator as a stepping object: state, integrated pose and covariance (no rclpy).

``sim_node`` (``nodes/sim_node.py``) is a ROS shell around :class:`LearnedSimulator`, which lives
here with the rollout because it is plain NumPy. A step is the computation of
``rollout.simulate.step`` and ``data.states.integrate_path`` written out for one robot (the
model and projection are the same calls; ``test/rollout/test_learned_sim.py`` checks the node's
output equals the core's rollout), so that it costs little besides them.

A model whose feature set goes beyond the paper's 45 (``model.feature_set``: lagged commands and
states, friction terms, the play operator, the heading, ...; models from ``diagnose`` or
``train --features``) is stepped through a ``FeatureHistory`` started at the initial state and
pose and restarted on every ``reset``, exactly as ``rollout`` does; a plain model is stepped
without one, as before.

One step (``step(u)``): s_{t+1} = projection(model(s_t, u_t)) (as ``rollout.simulate.step``,
the call ``rollout`` makes for each of its steps), then the pose as ``integrate_path`` gives it
for the one new state from the previous (x, y, yaw) and (roll, pitch) = s_t[roll, pitch]:
yaw += dyaw, (x, y) += R(roll_t, pitch_t, yaw_t)[:2] d_b; z = z_w; roll, pitch from s_{t+1}. The
twist in base_link is the finite difference of the last two poses (``twist_from_poses``), the
definition the pybullet robot and the recorded odometry use.

Covariance (when the model gives a predictive std, i.e. ``predict(X, return_std=True)``; LR
gives its homoscedastic residual std, GPs their predictive std), an approximation stated here:

- the std is the model's one-step predictive std of s_{t+1} at the fed-back (predicted,
  projected) s_t; it is not propagated through the dynamics (no Jacobians), per-step errors are
  taken as independent, and the projection is taken not to change the variance;
- pose x, y: the per-step covariances of the body displacement, rotated into odom, summed over
  the steps since the (re)start: Sigma_xy += A diag(var dx_b, var dy_b, var dz_b) A^T with
  A = R(roll_t, pitch_t, yaw_t)[:2]; yaw: var_yaw += var dyaw. Cross terms between yaw and
  position errors (a heading error swinging later displacements) are ignored, so the x, y
  variance is a lower bound on long rollouts;
- pose z, roll, pitch: they are state elements, so their variance is this step's predictive
  variance of z_w, roll, pitch (not summed);
- twist (base_link): diag(var dx_b, var dy_b, var dz_b) / dt^2 and
  diag(var droll, var dpitch, var dyaw) / dt^2 (Euler-angle rates standing in for body rates);
- the pose covariance rows/columns are (x, y, z, rot x, rot y, rot z) as the message defines;
  roll/pitch/yaw variances go on the diagonal of the rotation block, no cross terms.

Without a std (``use_variance=False`` or a model that has none) both covariances are None
("unknown", -1 in [0] on the wire).

The std every k steps (``covariance_every`` k > 1, sim_node's parameter of that name): the
model's std is computed on the first step after a (re)start and then on every k-th step; the
steps between predict the mean alone (the same mean, bit for bit) and take the last computed
per-step variance as theirs, inflated by their own ``(d / r)^2`` where they extrapolate. The
covariances are then those of a variance that lags the state by up to k - 1 steps;
``benchmarks/sim_node_20x/std_tail`` measures what that changes in the published covariance and
in the step's time.

Knowing when not to trust it: every step also gives ``nn_distance``, the normalised distance
(alpha-PROJ's metric) of the model's prediction, before the projection, to its nearest TrainPool
state: taken from the alpha projection's own nearest-neighbour search (no second search), or
from a search of its own for the other projections.

The gate's shortcut (gated alpha-PROJ with a clustered model, LGPR; ``gate_shortcut``): the
cluster that the step's features select (the one whose local GP predicts) also names a few
hundred TrainPool states, those its training rows lead to. If the nearest of them is inside the
gate, so is the nearest of all, and the gate leaves the prediction alone whichever it is: the
exact search over the whole TrainPool is skipped and the state is bit for bit the same. Before
the cluster's states, the state the last step was measured to and the three recorded after it
are tried: a robot following a recorded motion is often still near them. The
step's ``nn_distance`` is then the distance to that cluster state, an upper bound on the exact
one that is itself within the radius (so ``extrapolating`` is the same too); outside the gate
the search is exact as before. ``benchmarks/sim_node_20x`` has the share of such steps and the
time saved. With ``trust_radius`` r > 0 (sim_node: the
gate radius) a step whose ``nn_distance`` d exceeds r is *extrapolating*: the prediction left
the region the data covers as well as held-out real moves are covered. Then every variance of
that step is multiplied by ``(d / r)^2`` before it enters the covariances (the summed x, y, yaw
increments included, so the pose covariance keeps the extra uncertainty afterwards). Counters
for the statistics: ``stats()``.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..layout import CONTROL_DT, HOME_BODY_HEIGHT, HOME_POSE, N_ACTION, N_STATE, S, wrap_angle
from ..robot.sensors import twist_from_poses
from ..rotations import rpy_to_matrix, rpy_to_matrix1, rpy_to_quat, rpy_to_quat1
from ..projection import AlphaProjection, Projection
from .simulate import _predict, model_feature_set

__all__ = ["LearnedSimulator", "home_state", "standing_train_state", "model_has_variance",
           "gate_candidates", "recent_states"]


def home_state() -> np.ndarray:
    """The ideal standing state (33,): HOME_BODY_HEIGHT, level, at rest, joints at HOME_POSE."""
    s = np.zeros(N_STATE)
    s[S.z_w] = HOME_BODY_HEIGHT
    s[S.q] = HOME_POSE
    return s


def standing_train_state(train_states: np.ndarray, projection: Projection | None = None
                         ) -> np.ndarray:
    """The TrainPool state nearest to ``home_state()`` (alpha-PROJ's normalised distance).

    Uses ``projection``'s nearest-neighbour search if it is an alpha projection over the same
    states, otherwise builds one.
    """
    if not isinstance(projection, AlphaProjection):
        projection = AlphaProjection(train_states)
    i = int(projection.nearest(home_state()[None])[0])
    return projection.train_states[i].copy()


def model_has_variance(model: Any) -> bool:
    """True if the model declares a predictive std (``supports_std``: the regressor contract,
    ``docs/architecture.md``), so that ``predict(X, return_std=True)`` works."""
    return bool(getattr(model, "supports_std", False))


def gate_candidates(model: Any, projection: Projection, enabled: bool = True):
    """``(CandidateGroups, label)`` for the gate's shortcut (``AlphaProjection.project_distance``
    ``candidates``): the TrainPool states of each of the model's clusters and the function
    giving the cluster of feature rows; (None, None) when off, the projection is not a gated
    alpha-PROJ or the model has no usable clusters (``OneStepModel.state_clusters``)."""
    if not (enabled and isinstance(projection, AlphaProjection) and projection.radius > 0):
        return None, None
    clusters = getattr(model, "state_clusters", None)
    clusters = clusters() if clusters is not None else None
    if clusters is None:
        return None, None
    groups, label = clusters
    return projection.candidate_groups(groups), label


MAX_COVARIANCE_EVERY = 100   # covariance_every: the std at least once a second
RECENT = np.arange(4)   # the last step's TrainPool state and its next three in recorded order


def recent_states(last: np.ndarray) -> np.ndarray:
    """(n, 4) first candidates of the gate's shortcut: the TrainPool state each robot's last
    distance was measured to and the three recorded after it (-1: none yet)."""
    return np.where(last[:, None] >= 0, last[:, None] + RECENT, -1)


def _as_vector(a, n: int, what: str) -> np.ndarray:
    v = np.asarray(a, dtype=np.float64).reshape(-1)
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what} must be {n} finite numbers, got {v.size}")
    return v


class LearnedSimulator:
    """One learned LittleDog: ``reset()``, ``step(u)``, then read the attributes below.

    Args:
        model: ``predict(X) -> (n, 33)`` raw (``OneStepModel``). A model whose feature set goes
            beyond the paper's 45 (lagged commands, friction terms, ... from ``diagnose`` or
            ``train --features``) is stepped through a ``FeatureHistory`` started at the
            initial state and pose and restarted on every ``reset``, exactly as ``rollout``
            does, so the node serves it like the baseline.
        projection: applied to every prediction (``OneStepModel.projection(...)``).
        initial_state: s_0 (33,).
        initial_pose: (x, y, yaw) of the body in odom at t = 0.
        use_variance: fill the covariances from ``predict(..., return_std=True)``.
        trust_radius: r > 0: steps whose prediction is further than r from the TrainPool are
            extrapolating (module doc: flagged, variances inflated); 0: never flagged.
        monitor: the nearest-neighbour search for ``nn_distance`` when ``projection`` is not
            alpha-PROJ (an ``AlphaProjection`` over the TrainPool; None: no distance, NaN).
        gate_shortcut: with a gated alpha-PROJ and a clustered model (LGPR,
            ``OneStepModel.state_clusters``), skip the exact search for predictions whose
            cluster's TrainPool states already put them inside the gate (module doc; the states
            are bit for bit the same).
        covariance_every: compute the std on every k-th step only and hold it in between
            (module doc); 1: every step.

    Attributes after ``reset``/``step``: ``state`` (33,), ``q``, ``dq`` (12,); ``position``
    (3,), ``orientation`` (4,) xyzw, ``linear_velocity``, ``angular_velocity`` (3,) in
    base_link; ``pose_covariance``, ``twist_covariance`` (36,) or None; ``steps`` since the
    last reset; ``nn_distance`` of the last step's prediction (NaN before the first step),
    ``extrapolating`` (bool, the last step).
    """

    def __init__(self, model: Any, projection: Projection, initial_state: np.ndarray,
                 initial_pose=(0.0, 0.0, 0.0), use_variance: bool = True,
                 trust_radius: float = 0.0, monitor: AlphaProjection | None = None,
                 gate_shortcut: bool = True, covariance_every: int = 1) -> None:
        self.model = model
        self.projection = projection
        self.initial_state = _as_vector(initial_state, N_STATE, "initial_state")
        self.initial_pose = _as_vector(initial_pose, 3, "initial_pose (x, y, yaw)")
        self.use_variance = bool(use_variance)
        self.dt = CONTROL_DT
        self.feature_set = model_feature_set(model)
        self.trust_radius = float(trust_radius)
        if isinstance(covariance_every, bool) or int(covariance_every) != covariance_every \
                or not 1 <= covariance_every <= MAX_COVARIANCE_EVERY:
            raise ValueError(f"covariance_every must be an integer from 1 to "
                             f"{MAX_COVARIANCE_EVERY}, got {covariance_every!r}")
        self.covariance_every = int(covariance_every)
        if not (np.isfinite(self.trust_radius) and self.trust_radius >= 0):
            raise ValueError(f"trust_radius must be finite and >= 0, got {trust_radius}")
        self._search = projection if isinstance(projection, AlphaProjection) else monitor
        self._candidates, self._label = gate_candidates(model, projection, gate_shortcut)
        self._index = np.full(1, -1, dtype=np.int64)    # TrainPool state of the last distance
        self._last = np.full(1, -1, dtype=np.int64)     # ... kept for the next step
        self._x = np.empty((1, N_STATE + N_ACTION))      # the feature row of a plain model
        self.extrapolating_steps = 0                      # since start (not reset)
        self._window_max = float("nan")                  # max nn_distance since stats()
        self.reset()

    # -- state

    def reset(self) -> None:
        """Back to the initial state and pose; the accumulated covariance restarts at zero."""
        s = self.initial_state.copy()
        x, y, yaw = self.initial_pose
        self.state = s
        self._xy_yaw = np.array([x, y, yaw])
        self._sigma_xy = np.zeros((2, 2))
        self._var_yaw = 0.0
        self.steps = 0
        self._history = (None if self.feature_set is None
                         else self.feature_set.history(s, np.array([x, y, yaw])))
        # The pose one step earlier, from s_0's own deltas, so the first twist is a finite
        # difference like all later ones.
        rpy_prev = np.array([s[S.roll], s[S.pitch], yaw]) - s[S.d_rpy]
        prev_pos = np.array([x, y, s[S.z_w]]) - rpy_to_matrix(rpy_prev) @ s[S.d_b]
        self._prev_pose = (prev_pos, rpy_to_quat(rpy_prev))
        self.nn_distance = float("nan")
        self.extrapolating = False
        self._last[0] = -1
        self._held_var = None           # the last computed per-step variance (covariance_every)
        self._since_std = 0             # steps since it was computed
        self._set_outputs(None)

    def continue_from(self, other: "LearnedSimulator") -> None:
        """Take over ``other``'s robot where it is (a model swap): state, pose, the previous
        pose (so the next twist is a finite difference as before), the accumulated x, y and yaw
        variances, the outputs as last published, the step count and the extrapolation
        counters. The initial state and pose
        for later resets stay this simulator's own. A model with a feature history
        (``feature_set``) gets ``other``'s history if it has the same feature set, else a new
        one started at the current state and pose (its lags filled with that state, as at a
        reset)."""
        self.state = other.state.copy()
        self._xy_yaw = other._xy_yaw.copy()
        self._prev_pose = (other._prev_pose[0].copy(), other._prev_pose[1].copy())
        self._sigma_xy = other._sigma_xy.copy()
        self._var_yaw = other._var_yaw
        self.steps = other.steps
        self.nn_distance, self.extrapolating = other.nn_distance, other.extrapolating
        self.extrapolating_steps = other.extrapolating_steps
        self._held_var, self._since_std = None, 0      # this model's std on the next step
        if self.feature_set is None:
            self._history = None
        elif other._history is not None and other.feature_set == self.feature_set:
            self._history = other._history.copy()
        else:
            self._history = self.feature_set.history(self.state, self._xy_yaw.copy())
        self._set_outputs(None)
        if self.use_variance and other.pose_covariance is not None:   # this step's, as published
            self.pose_covariance = other.pose_covariance.copy()
            self.twist_covariance = other.twist_covariance.copy()

    def step(self, u: np.ndarray) -> bool:
        """Advance 10 ms with desired joint angles u (12,). False (nothing changed) if the
        prediction is not finite (a diverged model).

        The same computation as ``rollout.simulate.step`` (feature row, prediction, projection,
        history) and ``integrate_path`` for one state, written out for one robot so that a step
        costs little besides the model and the projection (``benchmarks/sim_node_10x``)."""
        u = np.asarray(u, dtype=np.float64)
        history = self._history
        undo = None if history is None else history.copy()
        if history is None:
            X = self._x
            X[0, :N_STATE] = self.state
            X[0, N_STATE:] = u
        else:
            X = np.atleast_2d(history.features(u))
        held = self._held_var
        fresh = self.use_variance and (held is None or self._since_std + 1 >= self.covariance_every)
        with np.errstate(over="ignore", invalid="ignore"):
            mean, std = _predict(self.model, X, fresh)
            if self._candidates is not None:
                nxt, d = self.projection.project_distance(
                    mean, (self._candidates, self._label(X), recent_states(self._last)),
                    self._index)
            elif self._search is self.projection:
                nxt, d = self.projection.project_distance(mean)
            else:
                nxt = self.projection(mean)
                d = (self._search.distance(mean) if self._search is not None
                     and np.all(np.isfinite(mean)) else np.full(1, np.nan))
        nxt, d = nxt[0], float(d[0])
        if std is not None:
            std = std[0]
        if not np.all(np.isfinite(nxt)) or (std is not None and not np.all(np.isfinite(std))):
            self._history = undo
            return False
        prev_state, (x0, y0, yaw0) = self.state, self._xy_yaw
        yaw = yaw0 + nxt[S.dyaw]
        R = rpy_to_matrix1(float(prev_state[S.roll]), float(prev_state[S.pitch]),
                            float(yaw0))[:2]
        dp = R @ nxt[S.d_b]
        xy_yaw = np.array([x0 + dp[0], y0 + dp[1], wrap_angle(yaw)])
        if not np.all(np.isfinite(xy_yaw)):
            self._history = undo
            return False
        if history is not None:
            history.push(nxt[None])
        self._prev_pose = (self.position, self.orientation)
        if self._candidates is not None:      # the next step's first candidates
            self._last[0] = self._index[0]
        self.nn_distance = d
        r = self.trust_radius
        self.extrapolating = r > 0 and d > r
        if self.extrapolating:
            self.extrapolating_steps += 1
        if not d <= self._window_max:     # also replaces NaN
            self._window_max = d
        if std is not None:
            var = self._held_var = std * std
            self._since_std = 0
        elif self.use_variance:
            var = held
            self._since_std += 1
        if self.use_variance:
            if self.extrapolating:
                var = var * (d / r) ** 2
            self._sigma_xy = self._sigma_xy + (R * var[S.d_b]) @ R.T
            self._var_yaw += var[S.dyaw]
            std = var
        self.state, self._xy_yaw = nxt, xy_yaw
        self.steps += 1
        self._set_outputs(std)
        return True

    # -- outputs

    @property
    def q(self) -> np.ndarray:
        """Joint angles (12,) of the current state."""
        return self.state[S.q]

    @property
    def dq(self) -> np.ndarray:
        """Joint rates (12,) of the current state."""
        return self.state[S.dq]

    def _set_outputs(self, var: np.ndarray | None) -> None:
        """The published outputs from the state, the pose and this step's variances."""
        s = self.state
        x, y, yaw = self._xy_yaw
        self.position = np.array([x, y, s[S.z_w]])
        self.orientation = rpy_to_quat1(float(s[S.roll]), float(s[S.pitch]), float(yaw))
        self.linear_velocity, self.angular_velocity = twist_from_poses(
            self._prev_pose[0], self._prev_pose[1], self.position, self.orientation, self.dt)
        if not self.use_variance:
            self.pose_covariance = self.twist_covariance = None
            return
        if var is None:
            var = np.zeros(N_STATE)
        pose = np.zeros((6, 6))
        pose[:2, :2] = self._sigma_xy
        pose[2, 2] = var[S.z_w]
        pose[3, 3], pose[4, 4] = var[S.roll], var[S.pitch]
        pose[5, 5] = self._var_yaw
        twist = np.zeros((6, 6))
        twist[np.arange(3), np.arange(3)] = var[S.d_b] / self.dt**2
        twist[np.arange(3, 6), np.arange(3, 6)] = var[S.d_rpy] / self.dt**2
        self.pose_covariance, self.twist_covariance = pose.reshape(36), twist.reshape(36)

    def stats(self) -> dict[str, Any]:
        """``~/stats`` entries of this backend (``sim.backend.Backend.stats``): ``nn_distance``
        (last step), ``nn_distance_max`` (since the last call), ``trust_radius``,
        ``extrapolating`` (last step, true/false) and ``extrapolating_steps`` (since start)."""
        out = {"nn_distance": f"{self.nn_distance:.3f}",
               "nn_distance_max": f"{self._window_max:.3f}",
               "trust_radius": f"{self.trust_radius:.3f}",
               "extrapolating": "true" if self.extrapolating else "false",
               "extrapolating_steps": self.extrapolating_steps}
        self._window_max = float("nan")
        return out

    def outputs_finite(self) -> bool:
        """True if every value the node would publish is finite."""
        parts = [self.state, self.position, self.orientation, self.linear_velocity,
                 self.angular_velocity]
        if self.pose_covariance is not None:
            parts += [self.pose_covariance, self.twist_covariance]
        return all(np.all(np.isfinite(p)) for p in parts)
