"""Record -> train -> swap, live over ROS 2 (``make live``).

    python -m littledog_mlsim.apps.live_demo [--out DIR] [--steps 300] [--method lr]

1. ``pybullet_node`` (the robot, lockstep) and ``trainer_node`` (``live:=true``) start in one
   ROS domain D; this process drives the robot with open-loop trots (``gait.trot_commands``),
   one command per step. Before the first session it steps the robot until the trainer says
   it has heard commands, joint states and odometry (``~/record false`` while not recording),
   so no recorded step is lost to discovery.
2. First session: ``/trainer_node/record`` true, a forward trot of ``--steps`` steps, record
   false (the trainer writes the run as moves into ``OUT/live_data``), ``/trainer_node/train``:
   the model is written atomically to ``OUT/live_model``.
3. ``sim_node`` (the learned simulator, lockstep) starts in domain D + 1 on that model and
   trots forward ``--steps // 3`` steps.
4. Second session on the robot: a left turn, recorded and trained on with the first one; the
   trainer replaces ``OUT/live_model`` atomically.
5. ``/sim_node/load_model``: sim_node swaps to the new model without a restart and carries on
   from where its robot was: the demo checks the next step follows on from the last one (same
   time line, the pose continuous), then trots on with the new model (the same trot carried
   across the swap, so the commands do not jump there).

Prints what each stage did and how long it took; every process it starts is stopped at the
end (SIGINT, then SIGKILL). Problems are one line (``live_demo: error: ...``), exit status 1.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .demo import (START_TIMEOUT, STEP_TIMEOUT, Child, DemoError, Log, _Link, _print,
                   _restore_env, _wait, pick_domains)

__all__ = ["LiveResult", "run_live_demo", "main"]

TRAIN_TIMEOUT = 600.0   # s, one ~/train call (an LR fit takes seconds; LGPR on a few moves ~1 min)
CALL_TIMEOUT = 30.0     # s, any other service call
WARMUP_MAX_STEPS = 500  # steps driven at most until the trainer hears the robot


@dataclass
class LiveResult:
    """What ``run_live_demo`` measured."""

    sessions: list[str] = field(default_factory=list)     # the trainer's ~/record answers
    trainings: list[str] = field(default_factory=list)    # the trainer's ~/train answers
    swap: str = ""                                        # sim_node's ~/load_model answer
    steps_before_swap: int = 0
    steps_after_swap: int = 0
    stamp_before_ns: int = 0                              # the last step before the swap
    stamp_after_ns: int = 0                               # the first step after it
    jump_m: float = 0.0                 # |p_after - p_before| across the swap, one step
    median_step_m: float = 0.0          # the median one-step displacement before the swap
    travelled_m: float = 0.0            # |p_before - p_first|: how far a reset would jump back
    warmup_steps: int = 0               # steps driven before the trainer heard every topic
    seconds: dict[str, float] = field(default_factory=dict)


def _trot(move_type: str, n: int, seed: int) -> np.ndarray:
    from ..gait.trot import sample_trot_params, trot_commands

    p = sample_trot_params(move_type, np.random.default_rng(seed))
    from dataclasses import replace
    return trot_commands(replace(p, n_steps=n))


class _Calls:
    """Service calls from one link's node: a ping (an idempotent GetParameters, resent until
    answered) first, so the server has matched our response reader before the calls that
    change things are sent once."""

    def __init__(self, link: _Link, cond: threading.Condition, children: Sequence[Child]) -> None:
        self.link, self.cond, self.children = link, cond, children
        self._clients: dict[tuple[Any, str], Any] = {}

    def ready(self, node_name: str) -> None:
        from rcl_interfaces.srv import GetParameters

        client = self.link.node.create_client(GetParameters, f"/{node_name}/get_parameters")
        end = time.monotonic() + START_TIMEOUT
        while time.monotonic() < end:
            for c in self.children:
                c.check()
            if client.service_is_ready():
                fut = client.call_async(GetParameters.Request(names=[]))
                t = time.monotonic() + 1.0
                while not fut.done() and time.monotonic() < t:
                    time.sleep(0.01)
                if fut.done():
                    return
                client.remove_pending_request(fut)
            else:
                time.sleep(0.05)
        raise DemoError(f"{node_name} did not answer within {START_TIMEOUT:g} s")

    def call(self, srv_type: Any, name: str, request: Any, timeout: float = CALL_TIMEOUT,
             resend: float | None = None) -> Any:
        """One call on the service's client (one per type and name, reused). ``resend``: for
        a request that changes nothing, the seconds after which an unanswered one is sent
        again (a new client's first answer can be lost while the server matches it)."""
        client = self._clients.get((srv_type, name))
        if client is None:
            client = self._clients[(srv_type, name)] = self.link.node.create_client(srv_type,
                                                                                   name)
        end = time.monotonic() + timeout
        while not client.service_is_ready():
            if time.monotonic() > end:
                raise DemoError(f"no service {name}")
            time.sleep(0.02)
        fut = client.call_async(request)
        sent = time.monotonic()
        while not fut.done():
            for c in self.children:
                c.check()
            if time.monotonic() > end:
                raise DemoError(f"{name}: no answer within {timeout:g} s")
            if resend is not None and time.monotonic() - sent > resend:
                client.remove_pending_request(fut)
                fut, sent = client.call_async(request), time.monotonic()
            time.sleep(0.02)
        return fut.result()


def _drive(link: _Link, cond: threading.Condition, cmds: np.ndarray, children: Sequence[Child],
           log_every: int = 0) -> list[int]:
    """Lockstep: each command after the previous step's measurement; returns the stamps."""
    stamps = []
    for u in cmds:
        with cond:
            have = set(link.js) & set(link.odom)
            last = max(have) if have else 0
        link.send(u)
        nxt = last + 10_000_000
        _wait(cond, lambda nxt=nxt: nxt in link.js and nxt in link.odom, STEP_TIMEOUT,
              f"{link.label} step at {nxt / 1e9:.2f} s", children)
        stamps.append(nxt)
    return stamps


def _heard(calls: _Calls, recording: bool) -> dict[str, int]:
    """What trainer_node has heard since it started: its answer to the ``~/record`` request it
    refuses (false while not recording, true while recording; either changes nothing, so an
    unanswered one is sent again)."""
    from std_srvs.srv import SetBool

    from ..nodes.trainer_node import parse_heard

    ans = calls.call(SetBool, "/trainer_node/record", SetBool.Request(data=recording),
                     resend=1.0)
    heard = parse_heard(ans.message)
    if ans.success or heard is None:
        raise DemoError(f"trainer_node's ~/record {str(recording).lower()} did not say what it "
                        f"heard: {ans.message}")
    return heard


def _settled(calls: _Calls, recording: bool, at_least: dict[str, int] | None = None,
             polls: int = 1) -> dict[str, int]:
    """Wait until trainer_node's counts reach ``at_least`` (each kind; a robot step sends one
    of each) and then hold still over ``polls`` consecutive 50 ms waits: the messages of the
    steps driven so far have all arrived. Returns the counts."""
    from ..nodes.trainer_node import heard_text

    end = time.monotonic() + START_TIMEOUT
    heard, still = _heard(calls, recording), 0
    while still < polls:
        time.sleep(0.05)
        again = _heard(calls, recording)
        reached = at_least is None or all(again[k] >= n for k, n in at_least.items())
        still = still + 1 if (again == heard and reached) else 0
        if time.monotonic() > end:
            raise DemoError(f"trainer_node's counts did not settle: {heard_text(again)}"
                            + ("" if at_least is None else f", expected {heard_text(at_least)}"))
        heard = again
    return heard


def _until_heard(link: _Link, cond: threading.Condition, calls: _Calls,
                 children: Sequence[Child]) -> tuple[int, dict[str, int]]:
    """Drive the robot one step at a time (a standing trot's commands, move type S) until
    trainer_node has heard every kind of message, then until its counts hold still (three
    50 ms polls), so that none of these steps reaches a recording started next. Returns the
    steps driven and the counts."""
    end = time.monotonic() + START_TIMEOUT
    cmds = _trot("S", WARMUP_MAX_STEPS, 0)
    k = 0
    heard = _heard(calls, False)
    while min(heard.values()) == 0:
        if k == WARMUP_MAX_STEPS or time.monotonic() > end:
            raise DemoError(f"trainer_node heard no "
                            f"{', '.join(t for t, n in heard.items() if n == 0)} from "
                            f"pybullet_node within {k} steps")
        _drive(link, cond, cmds[k:k + 1], children)
        k += 1
        heard = _heard(calls, False)
    return k, _settled(calls, False, polls=3)


def run_live_demo(out: str | os.PathLike, *, steps: int = 300, method: str = "lr",
                  domain: int | None = None, log: Log = _print) -> LiveResult:
    """The record -> train -> swap loop (module doc); ``out`` gets ``live_data`` (the recorded
    dataset) and ``live_model`` (the model). Stops every process it started."""
    from std_srvs.srv import SetBool, Trigger

    from ..nodes import messages as m

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data, model = (out / "live_data").resolve(), (out / "live_model").resolve()
    if data.exists() or model.exists():
        raise DemoError(f"{out} holds live_data or live_model already: give a new --out")
    if steps < 50:
        raise DemoError(f"--steps must be >= 50, got {steps}")
    d_robot, d_learned = pick_domains(domain)
    r = LiveResult()
    children: list[Child] = []
    links: list[_Link] = []
    cond = threading.Condition()
    saved = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE")
    base_env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONUNBUFFERED="1")
    base_env.setdefault("OPENBLAS_NUM_THREADS", "1")
    t_all = time.perf_counter()

    def start(name: str, params: dict, dom: int, tmpdir: Path) -> Child:
        f = tmpdir / f"{name}.yaml"
        f.write_text(json.dumps({name: {"ros__parameters": params}}))   # JSON is YAML
        c = Child(name, f, dict(base_env, ROS_DOMAIN_ID=str(dom)), tmpdir)
        children.append(c)
        return c

    def link(label: str, node: str, dom: int) -> _Link:
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"   # read by rclpy.init
        try:
            lk = _Link(label, node, dom, cond)
        finally:
            _restore_env(saved)
        links.append(lk)
        return lk

    with tempfile.TemporaryDirectory(prefix="littledog_live_") as tmp:
        tmpdir = Path(tmp)
        try:
            t0 = time.perf_counter()
            start("pybullet_node", {"step_mode": "lockstep", "stats_period": 0.0}, d_robot,
                  tmpdir)
            start("trainer_node", {"live": True, "record_dir": str(data), "out": str(model),
                                   "method": method, "heartbeat": 0.0}, d_robot, tmpdir)
            robot = link("robot", "pybullet_node", d_robot)
            _wait(cond, robot.connected, START_TIMEOUT, "pybullet_node", children)
            calls = _Calls(robot, cond, children)
            calls.ready("trainer_node")
            # the trainer records what reaches its subscriptions (volatile): before the first
            # session the robot steps until the trainer has heard each of its topics, the proof
            # that pybullet_node's publishers have matched its readers (graph counts are not:
            # fresh-clone runs lost their first steps with them; CHANGELOG.md, 2026-11-26 and
            # 2026-11-27)
            r.warmup_steps, settled = _until_heard(robot, cond, calls, children)
            counts = [settled]                  # what the trainer has heard, once settled
            r.seconds["start"] = time.perf_counter() - t0
            log(f"pybullet_node and trainer_node (live, {method}) up in domain {d_robot} in "
                f"{r.seconds['start']:.1f} s (the trainer heard the robot after "
                f"{r.warmup_steps} step(s))")

            def session(move_type: str, seed: int, n: int) -> None:
                t = time.perf_counter()
                ans = calls.call(SetBool, "/trainer_node/record", SetBool.Request(data=True))
                if not ans.success:
                    raise DemoError(f"~/record true: {ans.message}")
                _drive(robot, cond, _trot(move_type, n, seed), children)
                # the last steps' messages may still be on their way to the trainer: wait for
                # one more of each kind per step driven
                counts[0] = _settled(calls, True, {k: v + n for k, v in counts[0].items()})
                ans = calls.call(SetBool, "/trainer_node/record", SetBool.Request(data=False))
                if not ans.success:
                    raise DemoError(f"~/record false: {ans.message}")
                r.sessions.append(ans.message)
                log(f"recorded a {move_type} trot of {n} steps on the robot in "
                    f"{time.perf_counter() - t:.1f} s: {ans.message}")
                t = time.perf_counter()
                ans = calls.call(Trigger, "/trainer_node/train", Trigger.Request(),
                                 timeout=TRAIN_TIMEOUT)
                if not ans.success:
                    raise DemoError(f"~/train: {ans.message}")
                r.trainings.append(ans.message)
                r.seconds[f"train{len(r.trainings)}"] = time.perf_counter() - t
                log(f"trained in {time.perf_counter() - t:.1f} s: {ans.message}")

            session("F", 0, steps)

            t0 = time.perf_counter()
            start("sim_node", {"model_path": str(model), "step_mode": "lockstep",
                               "stats_period": 0.2}, d_learned, tmpdir)
            learned = link("learned", "sim_node", d_learned)
            _wait(cond, learned.connected, START_TIMEOUT, "sim_node", children)
            sim_calls = _Calls(learned, cond, children)
            log(f"sim_node up on that model in domain {d_learned} in "
                f"{time.perf_counter() - t0:.1f} s")
            n_before = max(steps // 3, 20)
            # one trot across the swap: a jump in the commands would move the robot by itself
            trot = _trot("F", 2 * n_before, 1)
            before = _drive(learned, cond, trot[:n_before], children)
            r.steps_before_swap = len(before)

            session("FL", 2, steps)

            t0 = time.perf_counter()
            ans = sim_calls.call(Trigger, "/sim_node/load_model", Trigger.Request())
            if not ans.success:
                raise DemoError(f"~/load_model: {ans.message}")
            r.swap = ans.message
            r.seconds["swap"] = time.perf_counter() - t0
            log(f"sim_node: {ans.message}")
            after = _drive(learned, cond, trot[n_before:], children)
            r.steps_after_swap = len(after)
            with cond:
                p = {t: m.odometry_arrays(learned.odom[t])["position"] for t in before + after}
            r.stamp_before_ns, r.stamp_after_ns = before[-1], after[0]
            r.jump_m = float(np.linalg.norm(p[after[0]][:2] - p[before[-1]][:2]))
            r.median_step_m = float(np.median([np.linalg.norm(p[b][:2] - p[a][:2])
                                               for a, b in zip(before, before[1:])]))
            r.travelled_m = float(np.linalg.norm(p[before[-1]][:2] - p[before[0]][:2]))
            log(f"across the swap: step {r.stamp_before_ns / 1e9:.2f} s -> "
                f"{r.stamp_after_ns / 1e9:.2f} s, the body moved {1000 * r.jump_m:.2f} mm "
                f"(median step before: {1000 * r.median_step_m:.2f} mm, "
                f"{1000 * r.travelled_m:.0f} mm travelled on the first model); "
                f"{r.steps_after_swap} steps on the new model")
        finally:
            for lk in links:
                lk.close()
            for c in reversed(children):
                c.stop()
    r.seconds["total"] = time.perf_counter() - t_all
    log(f"record -> train -> swap done in {r.seconds['total']:.1f} s; data {data}, "
        f"model {model}")
    return r


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="live_demo", description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=None, help="directory for live_data and live_model "
                    "(default: a new one under /tmp)")
    ap.add_argument("--steps", type=int, default=300, help="steps per recording session")
    ap.add_argument("--method", default="lr", help="regressor the trainer fits")
    ap.add_argument("--domain", type=int, default=None, help="ROS domain of the robot side "
                    "(the learned simulator uses the next one)")
    a = ap.parse_args(argv)
    out = a.out or tempfile.mkdtemp(prefix="littledog_live_demo_")
    try:
        run_live_demo(out, steps=a.steps, method=a.method, domain=a.domain)
    except DemoError as e:
        print(f"live_demo: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
