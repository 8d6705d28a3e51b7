"""sim_node: the learned LittleDog simulator behind the contract topics (docs/interface.md §2, §6).

    sim_node --ros-args -p model_path:=/path/to/model [-p step_mode:=lockstep] ...

Loads a one-step model (``OneStepModel.load``; a missing, corrupt or incompatible model is one
FATAL log line and exit status 2), starts from the initial state and advances one 10 ms step
per timer tick or per command (``step_mode``), each step ``LearnedSimulator.step``: the
model's prediction passed through the projection (default: gated alpha-PROJ, alpha 0.5, with
the radius stored in the model, ``OneStepModel.gate_radius``; ``radius:=0.0`` gives the
paper's plain alpha-PROJ), the pose
integrated from the predicted states as ``integrate_path`` does, covariances from the model's
predictive std (see ``rollout/learned_sim.py`` for the approximation). Topics, services, command
rule, timeout and counters: ``nodes/simulator.py``.

Initial state (``initial_state`` unset, the default): the TrainPool state stored in the model
that is nearest, in alpha-PROJ's normalised distance, to the ideal standing state (body at
HOME_BODY_HEIGHT, level, at rest, joints at HOME_POSE): a real standing state from the data
the model was trained on. ``initial_state`` (33 values, ``layout.STATE_NAMES`` order) replaces
it; ``initial_pose`` = (x, y, yaw) places it in odom.

Knowing when not to trust it: ``~/stats`` also carries ``nn_distance`` (the last prediction's
normalised distance to its nearest TrainPool state, before the projection),
``nn_distance_max`` (over the stats period), ``trust_radius`` (the gate radius: the
projection's, else the model's stored one; 0 = never flagged), ``extrapolating`` (true/false,
the last step) and ``extrapolating_steps`` (since start). A step beyond the trust radius is
warned (throttled by ``log_throttle``) and inflates that step's variances by
``(nn_distance / trust_radius)^2`` in the odometry covariances (``rollout/learned_sim.py``), so
a controller sees extrapolation on the topics alone: the flag in ``~/stats`` and a covariance
that grows faster.

Hot swap: ``~/load_model`` (std_srvs/Trigger) loads the model now at ``model_path`` again (a
trainer replaces that directory atomically, ``trainer_node``'s ``~/train``) and swaps to it
between two steps: the robot carries on from where it is (state, pose, accumulated pose
covariance, step count: ``LearnedSimulator.continue_from``), the projection, its radius, the
trust radius and, when ``initial_state`` is unset, the state later resets return to come from
the new model. The load runs in the node's executor, so no step runs meanwhile (timer mode
catches the missed steps up afterwards, up to 0.5 s). A model that cannot be loaded (missing,
corrupt, incompatible, no TrainPool states) leaves the served model in place and answers
``success: false`` with one line starting ``kept the previous model:``. ``~/stats`` counts
``model_swaps``.

Parameters: ``config/sim.yaml`` (every one is listed there with its default) and
``nodes/simulator.py`` (those shared with pybullet_node).
"""
from __future__ import annotations

import sys
import time
from typing import TYPE_CHECKING, Sequence

import numpy as np
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from ..layout import N_STATE
from ..models.persistence import ModelError
from ..rollout.learned_sim import (MAX_COVARIANCE_EVERY, LearnedSimulator, model_has_variance,
                                   standing_train_state)
from ._run import Param, StartupError, one_line
from .simulator import SimulatorNode, run_simulator

if TYPE_CHECKING:
    from ..models.onestep import OneStepModel

NODE_NAME = "sim_node"
PROJECTIONS = ("none", "bound", "alpha")


class SimNode(SimulatorNode):
    CONFIG_FILE = "sim.yaml"
    PARAMS = (
        Param("model_path", "", "model directory written by trainer_node or "
              "`littledog-mlsim train` (required)"),
        Param("projection", "alpha", "projection applied to every predicted state",
              "none | bound | alpha"),
        Param("alpha", 0.5, "alpha of alpha-PROJ: s := (1 - alpha) s + alpha q, q the nearest "
              "TrainPool state", "0 <= alpha <= 1"),
        Param("radius", Parameter.Type.DOUBLE, "gated alpha-PROJ: leave a predicted state "
              "within this normalised distance of its nearest TrainPool state alone and pull "
              "only the excess (unset: the model's own radius, the 0.9 quantile of its "
              "TrainPool's leave-move-out distances; 0: plain alpha-PROJ)",
              ">= 0, finite; projection alpha only"),
        Param("nn_method", "auto", "alpha-PROJ nearest-neighbour search (projection."
              "NearestNeighbour; exact either way)", "auto | pca | brute | kdtree"),
        Param("initial_state", Parameter.Type.DOUBLE_ARRAY, "initial state s_0, 33 values in "
              "layout.STATE_NAMES order (unset: the model's TrainPool state nearest the home "
              "stance)", "33 finite values"),
        Param("initial_pose", [0.0, 0.0, 0.0], "initial x [m], y [m], yaw [rad] of the body "
              "in odom", "3 finite values"),
        Param("publish_covariance", True, "fill the odometry covariances from the model's "
              "predictive std (false, or a model without one: -1 in [0], unknown)"),
        Param("covariance_precision", "float32", "LGPR's std from float32 Cholesky factors "
              "(half the memory traffic of a step; the std changes by about 1e-5 relative on "
              "the paper-size model, more where the variance is far below the prior: "
              "docs/simulator.md) or float64 (as `evaluate` computes it); the mean is the same "
              "either way", "float32 | float64"),
        Param("covariance_every", 1, "compute the model's std on every k-th step only and "
              "hold it in between (the mean is the same; the covariance lags the state by up "
              "to k - 1 steps: docs/simulator.md); 1: every step",
              f"integer 1..{MAX_COVARIANCE_EVERY}"),
    )

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        sim = self.backend
        self.create_service(Trigger, "~/load_model", self._on_load_model)
        self.get_logger().info(self._describe(sim)
                               + (f", defaults from {self.config_path}" if self.config_path
                                  else ""))

    def _describe(self, sim: LearnedSimulator) -> str:
        return (f"{self.model.method} model {self.param('model_path')} "
                f"({self.model.info.get('n_train', '?')} training samples), projection "
                f"{sim.projection.describe()} (radius: {self.radius_source}), step_mode "
                f"{self.step_mode}, covariance "
                f"{'from the model' if sim.use_variance else 'unknown'}"
                + (f" (its std every {sim.covariance_every} steps)"
                   if sim.use_variance and sim.covariance_every > 1 else ""))

    def make_backend(self) -> LearnedSimulator:
        path = self.param("model_path")
        if not path:
            raise StartupError("no model: set the parameter model_path")
        sim, self.model, self.radius_source = self.build_simulator(path)
        self.swaps = 0
        return sim

    def extra_stats(self) -> dict[str, object]:
        return {"model_swaps": self.swaps}

    # -- hot swap ---------------------------------------------------------------------------------

    def _on_load_model(self, request: Trigger.Request, response: Trigger.Response):
        """``~/load_model``: swap to the model now at ``model_path`` (module doc)."""
        response.success, response.message = self.load_model(self.param("model_path"))
        return response

    def load_model(self, path: str) -> tuple[bool, str]:
        """Load the model at ``path`` and swap to it between two steps, the robot carrying on
        from its current state (``LearnedSimulator.continue_from``). Any failure keeps the model
        being served; returns (success, one line)."""
        t0 = time.perf_counter()
        try:
            sim, model, radius_source = self.build_simulator(path)
        except StartupError as e:
            text = f"kept the previous model: {one_line(e)}"
            self.get_logger().error(text)
            return False, text
        except Exception as e:  # noqa: BLE001  (a broken model file must not end the node)
            text = f"kept the previous model: cannot load model {path}: {one_line(e)}"
            self.get_logger().error(text)
            return False, text
        old = self.backend
        sim.continue_from(old)
        # the executor runs this callback between two steps: the core steps the new simulator
        # from the next step on
        self.backend = self.core.backend = sim
        self.model, self.radius_source = model, radius_source
        self.swaps += 1
        text = (f"swapped at t = {self.core.sim_time_ns / 1e9:.2f} s to {self._describe(sim)} "
                f"(loaded in {time.perf_counter() - t0:.2f} s)")
        self.get_logger().info(text)
        return True, text

    def build_simulator(self, path: str) -> tuple[LearnedSimulator, "OneStepModel", str]:
        """(simulator, model, where its radius comes from) for the model at ``path`` with this
        node's parameters; StartupError (one line) for a missing, corrupt or incompatible
        model or a bad parameter."""
        from ..models.onestep import OneStepModel

        try:
            model = OneStepModel.load(path)
        except ModelError as e:
            raise StartupError(f"cannot load model: {e}") from None
        except OSError as e:
            raise StartupError(f"cannot load model {path}: {e}") from None
        from ..projection import NearestNeighbour

        if self.param("nn_method") not in NearestNeighbour.METHODS:
            raise StartupError(f"parameter nn_method must be one of "
                               f"{', '.join(NearestNeighbour.METHODS)}")
        kind = self.param("projection")
        if kind not in PROJECTIONS:
            raise StartupError(f"parameter projection must be one of {', '.join(PROJECTIONS)}, "
                               f"got {kind!r}")
        radius = self.param("radius")
        if radius is None:             # the model's own gate (alpha-PROJ only)
            radius, radius_source = (model.gate_radius() if kind == "alpha"
                                     else (0.0, "not gated"))
        else:
            radius_source = "the radius parameter"
        try:   # the projection checks radius (finite, >= 0, alpha only)
            projection = model.projection(kind, alpha=self.param("alpha"),
                                          nn_method=self.param("nn_method"),
                                          radius=radius)
        except ValueError as e:
            raise StartupError(f"projection {kind}: {e}") from None
        s0 = self.param("initial_state")
        if s0 is None:
            if model.train_states is None:
                raise StartupError(f"{path} holds no TrainPool states: set initial_state")
            s0 = standing_train_state(model.train_states, projection)
        s0 = np.asarray(s0, dtype=np.float64)
        if s0.shape != (N_STATE,) or not np.all(np.isfinite(s0)):
            raise StartupError(f"initial_state must be {N_STATE} finite values, got {s0.size}")
        pose = np.asarray(self.param("initial_pose"), dtype=np.float64)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise StartupError("initial_pose must be 3 finite values: x, y, yaw")
        use_var = bool(self.param("publish_covariance"))
        if use_var and not model_has_variance(model):
            use_var = False
        precision = self.param("covariance_precision")
        if precision not in ("float32", "float64"):
            raise StartupError(f"parameter covariance_precision must be float32 or float64, "
                               f"got {precision!r}")
        every = self.param("covariance_every")
        if not 1 <= every <= MAX_COVARIANCE_EVERY:
            raise StartupError(f"parameter covariance_every must be an integer from 1 to "
                               f"{MAX_COVARIANCE_EVERY}, got {every}")
        prepare = getattr(model, "prepare", None)
        if prepare is not None:   # one-time work (variance factors) out of the 10 ms loop
            prepare(return_std=use_var, variance_dtype=precision)
        # extrapolation: beyond the gate radius (the model's own if the projection has none)
        trust = getattr(projection, "radius", 0.0) or float((model.gate or {}).get("radius", 0.0))
        monitor = None
        if kind != "alpha" and model.train_states is not None:
            from ..projection import AlphaProjection
            monitor = AlphaProjection(model.train_states, alpha=0.0,
                                      nn_method=self.param("nn_method"))
            monitor.nn.prepare()
        nn = getattr(projection, "nn", None)
        if nn is not None:
            nn.prepare()              # the search index now, not inside the first step
        try:
            sim = LearnedSimulator(model, projection, s0, pose, use_var, trust_radius=trust,
                                   monitor=monitor,
                                   covariance_every=every)
        except ValueError as e:
            raise StartupError(f"cannot serve model {path}: {one_line(e)}") from None
        return sim, model, radius_source


def main(args: Sequence[str] | None = None) -> int:
    return run_simulator(SimNode, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
