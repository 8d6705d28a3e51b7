"""The ROS 2 standard simulation services (``simulation_interfaces`` 1.5.x, Jazzy) of a simulator.

Served by sim_node and pybullet_node where ``simulation_interfaces`` is importable (a full ROS
install; the pip wheels lack it: then the node says so once at start-up and serves only its
``std_srvs`` services), as ``/tf`` is served where ``tf2_msgs`` is. Names under the node, as
Gazebo serves them under ``/gzserver``:

- ``~/get_simulator_features`` (GetSimulatorFeatures): :data:`FEATURES`, the features below and
  nothing else; ``custom_info`` names the entity and this document;
- ``~/reset_simulation`` (ResetSimulation): the robot back to its initial state, as ``~/reset``
  (``SimulatorCore.reset``). Scopes DEFAULT, ALL and any with STATE reset the state; the
  simulated time goes on (it never goes backwards: ``/clock`` and every stamp are monotonic),
  so SCOPE_TIME is not advertised and a scope without STATE is FEATURE_UNSUPPORTED;
- ``~/step_simulation`` (StepSimulation): only while paused (or stopped): ``steps`` steps with
  the held command, each published as usual, answered when all are done (the call blocks; the
  node's other callbacks wait meanwhile); at most :data:`MAX_STEPS_PER_CALL` per call. Not
  paused: RESULT_OPERATION_FAILED, as the service definition says;
- ``~/get_simulation_state`` / ``~/set_simulation_state`` (GetSimulationState /
  SetSimulationState): PLAYING (stepping: timer ticks or lockstep commands), PAUSED (as
  ``~/pause``), STOPPED (reset, then paused; until the next step or resume). Every transition
  between the three is allowed (STOPPED -> PAUSED leaves the reset robot paused); the target
  state already held is ALREADY_IN_TARGET_STATE; QUITTING, NO_WORLD and LOADING_WORLD are
  FEATURE_UNSUPPORTED; any other value is INCORRECT_TRANSITION. The nodes start PLAYING;
- ``~/get_entity_state`` (GetEntityState): the robot, entity ``littledog`` (or ``base_link``):
  the pose of base_link in odom and its twist in odom (``header.frame_id`` = odom, stamped with
  the simulated time of the last published step): the odometry's pose, and its base_link twist
  rotated into odom. The acceleration is not estimated (zeros). Any other name: NOT_FOUND.

Not advertised, not served: spawning and deleting entities, entity listing, info and bounds,
setting an entity's state, named poses, worlds, the SimulateSteps action, resetting the time.

This module translates requests into calls of ``sim.core.SimulatorCore`` and never imports
``simulation_interfaces`` itself at import time: :func:`interface_types` does, where it exists,
and :class:`SimulationServices` works on whatever request and response objects it is handed
(the real ones, or the stand-ins the tests build from the 1.5.1 definitions).
"""
from __future__ import annotations

from types import SimpleNamespace
from typing import Any, Callable

import numpy as np

from ..layout import ODOM_FRAME
from ..rotations import quat_to_matrix
from . import messages as m
from ._run import one_line

__all__ = ["interface_types", "SimulationServices", "FEATURES", "ENTITY_NAMES",
           "MAX_STEPS_PER_CALL", "SERVICES"]

# the robot as an entity (GetEntityState)
ENTITY_NAMES = ("littledog", "base_link")
# StepSimulation: at most this many steps per call (1000 s simulated), so one call cannot block
# the node for hours
MAX_STEPS_PER_CALL = 100_000
# SimulatorFeatures constants advertised, by name (module doc)
FEATURES = ("ENTITY_STATE_GETTING", "SIMULATION_RESET", "SIMULATION_RESET_STATE",
            "SIMULATION_STATE_GETTING", "SIMULATION_STATE_SETTING", "SIMULATION_STATE_PAUSE",
            "STEP_SIMULATION_SINGLE", "STEP_SIMULATION_MULTIPLE")
# (service name under the node, srv type name, SimulationServices method)
SERVICES = (
    ("~/get_simulator_features", "GetSimulatorFeatures", "get_simulator_features"),
    ("~/reset_simulation", "ResetSimulation", "reset_simulation"),
    ("~/step_simulation", "StepSimulation", "step_simulation"),
    ("~/get_simulation_state", "GetSimulationState", "get_simulation_state"),
    ("~/set_simulation_state", "SetSimulationState", "set_simulation_state"),
    ("~/get_entity_state", "GetEntityState", "get_entity_state"),
)


def interface_types() -> SimpleNamespace | None:
    """``simulation_interfaces``' ``msg`` and ``srv`` modules (``.msg``, ``.srv``), or None where
    the package is not installed (the pip wheels)."""
    try:
        from simulation_interfaces import msg, srv
    except ImportError:
        return None
    return SimpleNamespace(msg=msg, srv=srv)


class SimulationServices:
    """The handlers of :data:`SERVICES` (module doc) for one simulator.

    Args:
        types: ``interface_types()`` (or stand-ins with the same names).
        core: the node's ``SimulatorCore`` (pause, reset, stop, step_paused, sim time).
        backend: returns the backend being stepped now (the learned one can be swapped).
        name: the node's name, for ``custom_info``.
        log: where an unexpected error in a handler is logged (one line).
    """

    def __init__(self, types: Any, core: Any, backend: Callable[[], Any], name: str,
                 log: Callable[[str], None] | None = None) -> None:
        self.types, self.core, self.backend, self.name = types, core, backend, name
        self.log = log
        msg = types.msg
        self.R, self.S = msg.Result, msg.SimulationState
        self.features = [int(getattr(msg.SimulatorFeatures, f)) for f in FEATURES]

    def endpoints(self) -> list[tuple[str, Any, Callable]]:
        """(service name, srv type, handler) of every service, for ``create_service``; each
        handler answers an unexpected error (a malformed request) as RESULT_OPERATION_FAILED
        with one line instead of raising it into the executor, which would end the node."""
        return [(name, getattr(self.types.srv, srv), self._guarded(getattr(self, method)))
                for name, srv, method in SERVICES]

    def _guarded(self, handler: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
        def call(request: Any, response: Any) -> Any:
            try:
                return handler(request, response)
            except Exception as e:  # noqa: BLE001  (bad input must not end a running node)
                text = one_line(e)
                if self.log is not None:
                    self.log(f"{handler.__name__}: {text}")
                if hasattr(response, "result"):
                    self._result(response, self.R.RESULT_OPERATION_FAILED, text)
                return response
        call.__name__ = handler.__name__
        return call

    # -- helpers --------------------------------------------------------------------------------

    def _result(self, response: Any, code: int, text: str = "") -> Any:
        response.result.result = int(code)
        response.result.error_message = text
        return response

    def state(self) -> int:
        """The SimulationState constant the core is in."""
        c = self.core
        if c.stopped:
            return self.S.STATE_STOPPED
        return self.S.STATE_PAUSED if c.paused else self.S.STATE_PLAYING

    # -- handlers ---------------------------------------------------------------------------------

    def get_simulator_features(self, request: Any, response: Any) -> Any:
        f = response.features
        f.features = list(self.features)
        f.spawn_formats = []
        f.custom_info = (f"littledog_mlsim {self.name}: one entity, {ENTITY_NAMES[0]!r} "
                         f"(base_link in {ODOM_FRAME}); the simulated time never goes "
                         f"backwards; docs/ros.md 'Standard simulation services'")
        return response

    def reset_simulation(self, request: Any, response: Any) -> Any:
        srv = self.types.srv.ResetSimulation.Request      # the SCOPE_* constants
        scope = int(request.scope)
        if scope not in (srv.SCOPE_DEFAULT, srv.SCOPE_ALL) and not scope & srv.SCOPE_STATE:
            return self._result(response, self.R.RESULT_FEATURE_UNSUPPORTED,
                                f"scope {scope}: only the state can be reset (SCOPE_STATE, "
                                f"SCOPE_DEFAULT, SCOPE_ALL); the simulated time never goes "
                                f"backwards")
        return self._result(response, self.R.RESULT_OK, self.core.reset())

    def step_simulation(self, request: Any, response: Any) -> Any:
        steps = int(request.steps)
        if not self.core.paused:
            return self._result(response, self.R.RESULT_OPERATION_FAILED,
                                "the simulation is not paused: pause it (set_simulation_state "
                                "PAUSED) before stepping")
        if steps > MAX_STEPS_PER_CALL:
            return self._result(response, self.R.RESULT_OPERATION_FAILED,
                                f"steps {steps} > {MAX_STEPS_PER_CALL} per call: split it")
        diverged = self.core.counters.diverged
        self.core.step_paused(steps)
        text = f"{steps} step(s), t = {self.core.sim_time_ns / 1e9:.2f} s"
        if self.core.counters.diverged > diverged:
            text += " (diverged and reset on the way: see ~/stats)"
        return self._result(response, self.R.RESULT_OK, text)

    def get_simulation_state(self, request: Any, response: Any) -> Any:
        response.state.state = self.state()
        return self._result(response, self.R.RESULT_OK)

    def set_simulation_state(self, request: Any, response: Any) -> Any:
        srv, S = self.types.srv.SetSimulationState.Response, self.S   # its result codes
        target, now = int(request.state.state), self.state()
        if target in (S.STATE_QUITTING, S.STATE_NO_WORLD, S.STATE_LOADING_WORLD):
            return self._result(response, self.R.RESULT_FEATURE_UNSUPPORTED,
                                f"state {target} is not supported: only PLAYING (1), "
                                f"PAUSED (2) and STOPPED (0)")
        if target not in (S.STATE_PLAYING, S.STATE_PAUSED, S.STATE_STOPPED):
            return self._result(response, srv.INCORRECT_TRANSITION,
                                f"unknown state {target}: PLAYING (1), PAUSED (2) or STOPPED (0)")
        if target == now:
            return self._result(response, srv.ALREADY_IN_TARGET_STATE,
                                f"already {_STATE_NAMES[target]}")
        c = self.core
        if target == S.STATE_STOPPED:
            text = c.stop()
        elif target == S.STATE_PAUSED:
            c.set_paused(True)
            c.stopped = False
            text = "paused"
        else:
            text = c.set_paused(False)
        return self._result(response, self.R.RESULT_OK, text)

    def get_entity_state(self, request: Any, response: Any) -> Any:
        if request.entity not in ENTITY_NAMES:
            return self._result(response, self.R.RESULT_NOT_FOUND,
                                f"no entity {request.entity!r}: the one entity is "
                                f"{ENTITY_NAMES[0]!r}")
        b = self.backend()
        st = response.state
        st.header.stamp = m.stamp(self.core.sim_time_ns)
        st.header.frame_id = ODOM_FRAME
        p, o = st.pose.position, st.pose.orientation
        p.x, p.y, p.z = (float(v) for v in b.position)
        o.x, o.y, o.z, o.w = (float(v) for v in b.orientation)
        R = quat_to_matrix(np.asarray(b.orientation, dtype=np.float64))
        v, w = st.twist.linear, st.twist.angular
        v.x, v.y, v.z = (float(a) for a in R @ np.asarray(b.linear_velocity, dtype=np.float64))
        w.x, w.y, w.z = (float(a) for a in R @ np.asarray(b.angular_velocity, dtype=np.float64))
        return self._result(response, self.R.RESULT_OK)


_STATE_NAMES = {0: "STOPPED", 1: "PLAYING", 2: "PAUSED"}
