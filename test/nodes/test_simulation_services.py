"""The standard simulation services (``nodes/simulation_services.py``) against the 1.5.1
definitions, without DDS: the pip wheels lack ``simulation_interfaces``, so the request and
response types are stand-ins built from the package's own ``.msg``/``.srv`` files
(``standin_simulation_interfaces``), and the handlers drive a real ``SimulatorCore`` (fake
clock, a backend with a known pose and twist). The node's wiring is checked on both sides:
every service created where the package is importable, none (and one line) where it is not.
"""
from __future__ import annotations

import math
import sys

import numpy as np
import pytest

import standin_simulation_interfaces as standin
from littledog_mlsim.layout import CONTROL_DT_NS, HOME_POSE
from littledog_mlsim.nodes import simulation_services as ss
from littledog_mlsim.nodes.simulator import SimulatorNode
from littledog_mlsim.sim.core import CoreConfig, Logs, SimulatorCore


class Clock:
    def __init__(self) -> None:
        self.t = 10**9

    def monotonic_ns(self) -> int:
        return self.t

    def wall_ns(self) -> int:
        return self.t

    def cpu_ns(self) -> int:
        return self.t


class Body:
    """A backend that moves 1 mm in x per step; facing +y (yaw 90 deg), moving forward at
    0.5 m/s and turning at 0.2 rad/s in base_link."""

    def __init__(self) -> None:
        self.commands: list[np.ndarray] = []
        self.resets = 0
        self.reset()

    def reset(self) -> None:
        self.resets += 1
        self.n = 0
        self._out()

    def step(self, u) -> bool:
        self.commands.append(np.array(u))
        self.n += 1
        self._out()
        return True

    def _out(self) -> None:
        self.state = np.full(33, float(self.n))
        self.q = self.dq = np.zeros(12)
        self.position = np.array([0.001 * self.n, 2.0, 0.14])
        self.orientation = np.array([0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
        self.linear_velocity = np.array([0.5, 0.0, 0.0])
        self.angular_velocity = np.array([0.0, 0.0, 0.2])
        self.pose_covariance = self.twist_covariance = None

    def outputs_finite(self) -> bool:
        return True

    def stats(self) -> dict:
        return {}


@pytest.fixture
def types(monkeypatch):
    standin.install(monkeypatch)
    t = ss.interface_types()
    assert t is not None and t.srv.StepSimulation.Request().steps == 1
    return t


def services(types, step_mode: str = "timer"):
    body, published = Body(), []
    core = SimulatorCore(body, CoreConfig(step_mode=step_mode), lambda ns, u: published.append(ns),
                         clock=Clock(), logs=Logs())
    core.start()
    errors: list[str] = []
    return ss.SimulationServices(types, core, lambda: body, "sim_node", log=errors.append), \
        core, body, published, errors


def call(svc, types, name: str, **request):
    """Call the handler of service ``name`` (e.g. StepSimulation) as rclpy would."""
    srv = getattr(types.srv, name)
    handler = {n: h for n, t, h in svc.endpoints()}[dict((s, n) for n, s, _ in ss.SERVICES)[name]]
    req = srv.Request()
    for k, v in request.items():
        setattr(req, k, v)
    return handler(req, srv.Response())


def test_standin_is_the_1_5_1_definition(types):
    F, S, R = types.msg.SimulatorFeatures, types.msg.SimulationState, types.msg.Result
    assert (F.ENTITY_STATE_GETTING, F.SIMULATION_RESET, F.SIMULATION_RESET_TIME,
            F.STEP_SIMULATION_MULTIPLE, F.STEP_SIMULATION_ACTION) == (10, 20, 21, 32, 33)
    assert (S.STATE_STOPPED, S.STATE_PLAYING, S.STATE_PAUSED, S.STATE_QUITTING) == (0, 1, 2, 3)
    assert (R.RESULT_FEATURE_UNSUPPORTED, R.RESULT_OK, R.RESULT_OPERATION_FAILED) == (0, 1, 4)
    assert types.srv.ResetSimulation.Request.SCOPE_ALL == 255
    assert types.srv.SetSimulationState.Response.INCORRECT_TRANSITION == 103
    assert types.msg.EntityState.FIELDS == ("header", "pose", "twist", "acceleration")
    with pytest.raises(AttributeError):            # misspelt fields fail, as in rosidl
        types.msg.Result().error_msg = "x"


def test_features_are_the_served_ones(types):
    svc, *_ = services(types)
    r = call(svc, types, "GetSimulatorFeatures")
    F = types.msg.SimulatorFeatures
    assert sorted(r.features.features) == sorted([
        F.ENTITY_STATE_GETTING, F.SIMULATION_RESET, F.SIMULATION_RESET_STATE,
        F.SIMULATION_STATE_GETTING, F.SIMULATION_STATE_SETTING, F.SIMULATION_STATE_PAUSE,
        F.STEP_SIMULATION_SINGLE, F.STEP_SIMULATION_MULTIPLE])
    assert r.features.spawn_formats == [] and "littledog" in r.features.custom_info
    # each advertised interface is served; nothing else is
    served = {srv for _, srv, _ in ss.SERVICES}
    assert served == {"GetSimulatorFeatures", "ResetSimulation", "StepSimulation",
                      "GetSimulationState", "SetSimulationState", "GetEntityState"}


def test_state_machine_step_only_while_paused(types):
    svc, core, body, published, _ = services(types)
    S, R = types.msg.SimulationState, types.msg.Result
    SET = types.srv.SetSimulationState.Response

    def state() -> int:
        return call(svc, types, "GetSimulationState").state.state

    def set_state(s: int):
        return call(svc, types, "SetSimulationState", state=S(state=s)).result

    assert state() == S.STATE_PLAYING                      # the nodes start playing
    r = call(svc, types, "StepSimulation", steps=3).result
    assert r.result == R.RESULT_OPERATION_FAILED and "not paused" in r.error_message
    assert body.n == 0 and published == [0]
    assert set_state(S.STATE_PAUSED).result == R.RESULT_OK and state() == S.STATE_PAUSED
    assert set_state(S.STATE_PAUSED).result == SET.ALREADY_IN_TARGET_STATE
    r = call(svc, types, "StepSimulation", steps=3).result      # blocks: done when answered
    assert r.result == R.RESULT_OK
    assert body.n == 3 and published == [0, CONTROL_DT_NS, 2 * CONTROL_DT_NS, 3 * CONTROL_DT_NS]
    np.testing.assert_array_equal(body.commands[-1], HOME_POSE)  # the held command
    # STOPPED: reset and paused; the time goes on one step; stepping is allowed from there
    assert set_state(S.STATE_STOPPED).result == R.RESULT_OK
    assert state() == S.STATE_STOPPED and body.n == 0 and body.resets == 2
    assert published[-1] == 4 * CONTROL_DT_NS and core.paused
    assert set_state(S.STATE_STOPPED).result == SET.ALREADY_IN_TARGET_STATE
    assert call(svc, types, "StepSimulation", steps=1).result.result == R.RESULT_OK
    assert state() == S.STATE_PAUSED and body.n == 1
    assert set_state(S.STATE_PLAYING).result == R.RESULT_OK and state() == S.STATE_PLAYING
    assert not core.paused
    assert set_state(S.STATE_QUITTING).result == R.RESULT_FEATURE_UNSUPPORTED
    assert set_state(77).result == SET.INCORRECT_TRANSITION
    assert state() == S.STATE_PLAYING
    # std_srvs ~/pause and the standard state agree (one core)
    core.set_paused(True)
    assert state() == S.STATE_PAUSED


def test_reset_scopes(types):
    svc, core, body, _, _ = services(types)
    R, Q = types.msg.Result, types.srv.ResetSimulation.Request
    core.set_paused(True)
    core.step_paused(5)
    for scope, code in [(Q.SCOPE_DEFAULT, R.RESULT_OK), (Q.SCOPE_STATE, R.RESULT_OK),
                        (Q.SCOPE_ALL, R.RESULT_OK), (Q.SCOPE_STATE | Q.SCOPE_TIME, R.RESULT_OK),
                        (Q.SCOPE_TIME, R.RESULT_FEATURE_UNSUPPORTED),
                        (Q.SCOPE_SPAWNED, R.RESULT_FEATURE_UNSUPPORTED)]:
        core.step_paused(1)
        resets, t = body.resets, core.sim_time_ns
        r = call(svc, types, "ResetSimulation", scope=scope).result
        assert r.result == code, (scope, r.error_message)
        assert body.resets == resets + (code == R.RESULT_OK)
        assert core.sim_time_ns >= t                           # never backwards
    assert core.paused                                         # a reset keeps the play state


def test_entity_state_pose_and_twist_in_odom(types):
    svc, core, body, _, _ = services(types, "lockstep")
    core.set_paused(True)
    core.step_paused(2)
    r = call(svc, types, "GetEntityState", entity="littledog")
    assert r.result.result == types.msg.Result.RESULT_OK
    st = r.state
    assert st.header.frame_id == "odom"
    assert (st.header.stamp.sec, st.header.stamp.nanosec) == (0, 2 * CONTROL_DT_NS)
    p, o = st.pose.position, st.pose.orientation
    assert [p.x, p.y, p.z] == [0.002, 2.0, 0.14] and o.w == pytest.approx(math.sqrt(0.5))
    # facing +y: forward 0.5 m/s in base_link is +y in odom; the yaw rate is the same
    v, w = st.twist.linear, st.twist.angular
    np.testing.assert_allclose([v.x, v.y, v.z], [0.0, 0.5, 0.0], atol=1e-12)
    np.testing.assert_allclose([w.x, w.y, w.z], [0.0, 0.0, 0.2], atol=1e-12)
    assert call(svc, types, "GetEntityState", entity="base_link").result.result == 1
    r = call(svc, types, "GetEntityState", entity="ground")
    assert r.result.result == types.msg.Result.RESULT_NOT_FOUND and "littledog" in \
        r.result.error_message


def test_bad_requests_are_one_line_answers(types):
    svc, core, body, _, errors = services(types)
    core.set_paused(True)
    R = types.msg.Result
    r = call(svc, types, "StepSimulation", steps=ss.MAX_STEPS_PER_CALL + 1).result
    assert r.result == R.RESULT_OPERATION_FAILED and body.n == 0
    r = call(svc, types, "StepSimulation", steps=float("nan")).result   # not an integer
    assert r.result == R.RESULT_OPERATION_FAILED and "\n" not in r.error_message
    r = call(svc, types, "StepSimulation", steps=-2).result
    assert r.result == R.RESULT_OPERATION_FAILED and "\n" not in r.error_message
    r = call(svc, types, "GetEntityState", entity=None).result
    assert r.result in (R.RESULT_NOT_FOUND, R.RESULT_OPERATION_FAILED)
    assert len(errors) == 2 and body.n == 0                  # logged, nothing stepped


class _Wired:
    """What ``SimulatorNode._serve_simulation_interfaces`` uses of the node."""

    def __init__(self) -> None:
        self.created: list[tuple] = []
        self.lines: list[str] = []
        self.core = SimulatorCore(Body(), CoreConfig(), lambda ns, u: None, clock=Clock())
        self.backend = self.core.backend

    def create_service(self, srv_type, name, handler):
        self.created.append((name, srv_type, handler))

    def get_logger(self):
        lines = self.lines

        class Log:
            info = error = lines.append
        return Log()

    def get_name(self) -> str:
        return "pybullet_node"


def test_node_serves_them_where_importable(types, monkeypatch):
    node = _Wired()
    services = SimulatorNode._serve_simulation_interfaces(node)
    assert services is not None
    assert [(n, t) for n, t, _ in node.created] == [
        (name, getattr(types.srv, srv)) for name, srv, _ in ss.SERVICES]
    assert node.lines == []
    # where simulation_interfaces is missing (the pip wheels): nothing, and one line
    monkeypatch.setitem(sys.modules, "simulation_interfaces", None)
    node = _Wired()
    assert SimulatorNode._serve_simulation_interfaces(node) is None
    assert node.created == [] and len(node.lines) == 1
    assert "simulation_interfaces is not installed" in node.lines[0]
