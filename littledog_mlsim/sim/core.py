"""The simulator's scheduling rules as a plain class: no rclpy, an injected clock.

:class:`SimulatorCore` owns what both simulator nodes do between a command arriving and a
measurement going out, independent of the transport:

- **command rule** (:func:`.command.check_command`): names matched, bad length / NaN / inf
  rejected (counted per reason, warned at most once per ``log_throttle`` s), out-of-limit
  angles clipped and used;
- **timer mode**: one step per ``period = 10 ms / real_time_factor`` on the clock's monotonic
  time, each with the newest valid command received before it (zero-order hold; older ones are
  counted as ``cmd_superseded``). Steps missed by late ticks are run late, at most
  ``steps_per_tick`` (2..50, default ``STEPS_PER_TICK`` = 2) per tick, so the transport
  takes the commands that arrived in between (a burst of steps on one held command would hand
  a learned model a staircase of set-points it never saw); ticks on time drain the backlog by
  ``steps_per_tick - 1`` each; a backlog beyond ``MAX_CATCH_UP`` (0.5 s of steps) is skipped
  (``steps_skipped``). Until the first command the robot is commanded ``stand_command``;
- **timeout** (timer mode): after ``cmd_timeout`` s without a valid command, ``hold`` keeps the
  last command or ``stand`` commands ``stand_command``; logged once per timeout and once when
  commands resume;
- **lockstep mode**: exactly one step per accepted command, at once;
- **pause**: no steps and no time; lockstep commands received while paused are dropped
  (``cmd_dropped_paused``), timer-mode ones still update the held command;
- **step while paused** (:meth:`SimulatorCore.step_paused`): n steps at once with the held
  command (timer mode: the newest command received, as a tick would take it), published as
  usual; refused unless paused;
- **stop**: a reset, then paused (``stopped`` until the next step or resume): the
  ``simulation_interfaces`` STOPPED state;
- **reset**: back to the initial state; the simulated time advances one step and the initial
  state goes out at that stamp; the held command returns to ``stand_command``;
- **divergence**: a step the backend cannot make finite is discarded, the backend is reset
  (time still advances one step), ``diverged`` is counted and logged (throttled);
- **extrapolation**: a backend that says a step left the data (``extrapolating``, with
  ``nn_distance`` and ``trust_radius``: the learned simulator) gets a warning, throttled like
  the command warnings;
- **counters and timing statistics** (:meth:`SimulatorCore.stats`), and the optional per-step
  latency log.

Every step's measurement is handed to the ``publish(ns, u)`` callable with its simulated time
``start_ns + k * 10 ms`` (never backwards) and the command applied for the step that ended
there (None for the initial state and after a reset); the transport reads the outputs from
the backend (:class:`..sim.backend.Backend`). The nodes (``nodes/simulator.py``) only wire
topics, services and parameters to this class; the unit tests drive it with a fake clock.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Protocol

import numpy as np

from ..fileio import atomic_write_text
from ..layout import CONTROL_DT_NS, HOME_POSE, JOINT_NAMES, N_JOINTS
from .backend import Backend
from .command import check_command

__all__ = ["Clock", "SystemClock", "CoreConfig", "Counters", "SimulatorCore", "Throttle",
           "STEP_MODES", "TIMEOUT_ACTIONS", "MAX_CATCH_UP", "STEPS_PER_TICK"]

STEP_MODES = ("timer", "lockstep")
TIMEOUT_ACTIONS = ("hold", "stand")
MAX_CATCH_UP = 50   # timer mode: at most this many missed steps (0.5 s) are run late
STEPS_PER_TICK = 2  # timer mode, default: steps one tick runs at most (CoreConfig.steps_per_tick)

_log = logging.getLogger(__name__)


class Clock(Protocol):
    """The three clocks the core reads (all integer nanoseconds)."""

    def monotonic_ns(self) -> int:
        """Schedule, timeout and throttling (steady)."""

    def wall_ns(self) -> int:
        """Timestamps of the latency statistics (system clock, comparable with DDS receive
        times)."""

    def cpu_ns(self) -> int:
        """CPU time of the calling thread (the step's CPU cost)."""


class SystemClock:
    """The process's real clocks."""

    monotonic_ns = staticmethod(time.monotonic_ns)
    wall_ns = staticmethod(time.time_ns)
    cpu_ns = staticmethod(time.thread_time_ns)


class Throttle:
    """At most one log line per key and ``period`` seconds, counting the suppressed ones."""

    def __init__(self, log: Callable[[str], None], period: float,
                 now_ns: Callable[[], int] = time.monotonic_ns) -> None:
        self.log, self.period_ns, self.now_ns = log, int(period * 1e9), now_ns
        self._last: dict[str, int] = {}
        self._suppressed: dict[str, int] = {}

    def __call__(self, key: str, text: str) -> None:
        now = self.now_ns()
        last = self._last.get(key)
        if last is not None and now - last < self.period_ns:
            self._suppressed[key] = self._suppressed.get(key, 0) + 1
            return
        n = self._suppressed.pop(key, 0)
        self._last[key] = now
        self.log(text + (f" ({n} more since the last such message)" if n else ""))


@dataclass(frozen=True)
class CoreConfig:
    """The scheduling parameters (the nodes' shared parameters of the same names)."""

    step_mode: str = "timer"
    real_time_factor: float = 1.0
    start_ns: int = 0
    cmd_timeout: float = 0.5
    cmd_timeout_action: str = "hold"
    stand_command: np.ndarray = field(default_factory=lambda: HOME_POSE.copy())
    log_throttle: float = 2.0
    steps_per_tick: int = STEPS_PER_TICK

    def __post_init__(self) -> None:
        if self.step_mode not in STEP_MODES:
            raise ValueError(f"step_mode must be one of {', '.join(STEP_MODES)}, "
                             f"got {self.step_mode!r}")
        if self.cmd_timeout_action not in TIMEOUT_ACTIONS:
            raise ValueError(f"cmd_timeout_action must be one of {', '.join(TIMEOUT_ACTIONS)}, "
                             f"got {self.cmd_timeout_action!r}")
        if not (self.real_time_factor > 0 and np.isfinite(self.real_time_factor)) \
                or not self.cmd_timeout >= 0 or not self.start_ns >= 0 \
                or not self.log_throttle >= 0:
            raise ValueError("real_time_factor must be > 0, and cmd_timeout, start_time, "
                             "log_throttle >= 0")
        if not (isinstance(self.steps_per_tick, (int, np.integer))
                and 2 <= self.steps_per_tick <= MAX_CATCH_UP):   # 1 would never drain
            raise ValueError(f"steps_per_tick must be an integer in 2..{MAX_CATCH_UP}, "
                             f"got {self.steps_per_tick!r}")
        stand = np.asarray(self.stand_command, dtype=np.float64)
        if stand.shape != (N_JOINTS,) or not np.all(np.isfinite(stand)):
            raise ValueError(f"stand_command must be {N_JOINTS} finite joint angles")
        object.__setattr__(self, "stand_command", check_command(JOINT_NAMES, stand).u)

    @property
    def period_ns(self) -> int:
        """Timer mode: wall time between two steps."""
        return int(round(CONTROL_DT_NS / self.real_time_factor))


@dataclass
class Counters:
    steps: int = 0
    cmd_received: int = 0
    cmd_accepted: int = 0
    cmd_clipped: int = 0
    cmd_rejected_names: int = 0
    cmd_rejected_length: int = 0
    cmd_rejected_nonfinite: int = 0
    cmd_superseded: int = 0
    cmd_dropped_paused: int = 0
    cmd_timeouts: int = 0
    steps_skipped: int = 0
    diverged: int = 0
    resets: int = 0

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)

    @property
    def bad(self) -> int:
        """Rejected commands plus diverged steps (the statistics' WARN level)."""
        return (self.cmd_rejected_names + self.cmd_rejected_length
                + self.cmd_rejected_nonfinite + self.diverged)


@dataclass
class StepTimes:
    """Per-step timestamps (ns): command received (wall, -1 = held command), step start and
    published (wall), CPU time of the step; at most ``max_len`` steps are kept."""

    received: list[int] = field(default_factory=list)
    start: list[int] = field(default_factory=list)
    published: list[int] = field(default_factory=list)
    cpu: list[int] = field(default_factory=list)
    max_len: int = 1_000_000

    def add(self, received: int, start: int, published: int, cpu: int) -> None:
        if len(self.start) < self.max_len:
            self.received.append(received)
            self.start.append(start)
            self.published.append(published)
            self.cpu.append(cpu)

    def csv(self) -> str:
        rows = "".join(f"{r},{s},{p},{c}\n" for r, s, p, c in
                       zip(self.received, self.start, self.published, self.cpu, strict=True))
        return "cmd_received_ns,step_start_ns,published_ns,step_cpu_ns\n" + rows


@dataclass
class Logs:
    """Where the core's messages go (the node passes its rclpy logger's methods)."""

    info: Callable[[str], None] = _log.info
    warning: Callable[[str], None] = _log.warning
    error: Callable[[str], None] = _log.error


class SimulatorCore:
    """The simulator's rules (module doc) around a :class:`Backend`.

    Args:
        backend: what is stepped; already at its initial state.
        config: the scheduling parameters.
        publish: ``publish(ns, u)`` sends the backend's current outputs stamped ``ns``; ``u``
            is the command applied in the step that ended at ``ns`` (None: initial state).
        clock: :class:`SystemClock` or a fake one for tests.
        logs: info/warning/error callables.
    """

    def __init__(self, backend: Backend, config: CoreConfig,
                 publish: Callable[[int, np.ndarray | None], None],
                 clock: Clock | None = None, logs: Logs | None = None) -> None:
        self.backend = backend
        self.config = config
        self.publish = publish
        self.clock: Clock = clock or SystemClock()
        self.logs = logs or Logs()
        self.counters = Counters()
        self.times = StepTimes()
        self.throttle = Throttle(self.logs.warning, config.log_throttle, self.clock.monotonic_ns)
        self._error_throttle = Throttle(self.logs.error, 2.0, self.clock.monotonic_ns)
        self.lockstep = config.step_mode == "lockstep"
        self.k = 0                        # step index of the published state
        self.paused = False
        self.stopped = False              # reset and paused, no step since (stop())
        self.held = config.stand_command.copy()
        self._fresh: tuple[np.ndarray, int] | None = None   # (u, received ns) not used yet
        self._last_cmd_ns: int | None = None                # monotonic ns of the last accepted
        self._timeout_ns = int(round(config.cmd_timeout * 1e9))
        self.timed_out = False
        self._period_ns = config.period_ns
        self._tick0: int | None = None    # schedule origin, set by the first tick
        self._ticks_done = 0
        self._stats_index = 0
        self._stats_mono = self.clock.monotonic_ns()
        self._stats_k = 0

    # -- time ---------------------------------------------------------------------------------

    @property
    def sim_time_ns(self) -> int:
        """Simulated time of the last published measurement."""
        return self.config.start_ns + self.k * CONTROL_DT_NS

    def start(self) -> None:
        """Publish measurement 0 (the initial state)."""
        self.publish(self.sim_time_ns, None)

    # -- commands -----------------------------------------------------------------------------

    def on_command(self, names, positions, received_ns: int | None = None) -> None:
        """One ``/littledog/cmd`` message (``received_ns``: its receive time on the wall clock;
        None = now). Lockstep: steps at once if accepted and not paused."""
        if received_ns is None:
            received_ns = self.clock.wall_ns()
        c = self.counters
        c.cmd_received += 1
        chk = check_command(names, positions)
        if chk.u is None:
            name = f"cmd_rejected_{chk.reason}"
            setattr(c, name, getattr(c, name) + 1)
            self.throttle(chk.reason, f"rejected a command ({chk.reason}): {chk.detail}; "
                                      f"holding the previous command")
            return
        c.cmd_accepted += 1
        if chk.reason == "clipped":
            c.cmd_clipped += 1
            self.throttle("clipped", f"clipped a command to the joint limits: {chk.detail}")
        if self.lockstep:
            if self.paused:
                c.cmd_dropped_paused += 1
                self.throttle("paused", "paused: dropped a lockstep command")
                return
            self.held = chk.u
            self._advance(chk.u, received_ns, self.clock.wall_ns())
            return
        if self._fresh is not None:
            c.cmd_superseded += 1
            self.throttle("flood", "commands arrive faster than the step rate: only the "
                                   "newest one before each step is used")
        self._fresh = (chk.u, received_ns)
        self._last_cmd_ns = self.clock.monotonic_ns()
        if self.timed_out:
            self.timed_out = False
            self.logs.info("commands resumed")

    # -- timer mode ---------------------------------------------------------------------------

    def on_tick(self) -> int:
        """Run steps due by now on the core's own schedule (timer mode); returns how many ran.
        One normally; after late ticks the missed ones too, at most ``steps_per_tick`` per
        call (the rest on the next calls, which the transport makes as soon as its timer is
        due again, taking the commands received in between), so the average rate holds while
        the node has the time for it; a backlog beyond ``MAX_CATCH_UP`` is skipped (in
        sustained overload the backlog stays there and the steps it cannot run are skipped).
        Lockstep mode: nothing."""
        if self.lockstep:
            return 0
        now = self.clock.monotonic_ns()
        if self._tick0 is None:
            self._tick0 = now - self._period_ns
        due = (now - self._tick0 + self._period_ns // 2) // self._period_ns
        behind = due - self._ticks_done
        if behind <= 0:
            return 0
        if behind > MAX_CATCH_UP:
            skipped = behind - MAX_CATCH_UP
            self.counters.steps_skipped += skipped
            self.throttle("skipped", f"fell {behind * self._period_ns / 1e6:.0f} ms behind the "
                                     f"step schedule: skipped {skipped} step(s)")
            self._ticks_done += skipped
            behind = MAX_CATCH_UP
        run = min(behind, self.config.steps_per_tick)
        self._ticks_done += run
        if self.paused:
            self._ticks_done = due        # no steps while paused, and no backlog after it
            return 0
        for _ in range(run):
            self._timer_step()
        return run

    def _timer_step(self) -> None:
        start = self.clock.wall_ns()
        if self._fresh is not None:
            u, received = self._fresh
            self._fresh = None
            self.held = u
        else:
            received = -1
            if self._last_cmd_ns is not None and self._timeout_ns > 0 and not self.timed_out \
                    and self.clock.monotonic_ns() - self._last_cmd_ns > self._timeout_ns:
                self.timed_out = True
                self.counters.cmd_timeouts += 1
                if self.config.cmd_timeout_action == "stand":
                    self.held = self.config.stand_command.copy()
                    what = "commanding stand_command"
                else:
                    what = "holding the last command"
                self.logs.warning(f"no valid command for {self.config.cmd_timeout:g} s: {what}")
        self._advance(self.held, received, start)

    def _advance(self, u: np.ndarray, received: int, start: int) -> None:
        """Step the backend with u and publish the new measurement (or reset on divergence)."""
        clock = self.clock
        cpu0 = clock.cpu_ns()
        b = self.backend
        if not (b.step(u) and b.outputs_finite()):
            self.counters.diverged += 1
            self._error_throttle("diverged", "the simulator produced a non-finite state: "
                                             "discarded the step and reset to the initial state")
            b.reset()
        elif getattr(b, "extrapolating", False):
            self.throttle("extrapolating", f"extrapolating: the prediction is "
                                           f"{b.nn_distance:.2f} from the nearest TrainPool "
                                           f"state, beyond the trust radius "
                                           f"{b.trust_radius:.2f} (covariance inflated)")
        self.k += 1
        self.counters.steps += 1
        self.stopped = False
        self.publish(self.config.start_ns + self.k * CONTROL_DT_NS, u)
        self.times.add(received, start, clock.wall_ns(), clock.cpu_ns() - cpu0)

    # -- services -----------------------------------------------------------------------------

    def reset(self) -> str:
        """Back to the initial state now (one step of simulated time); returns the message."""
        self.backend.reset()
        self.counters.resets += 1
        self.held = self.config.stand_command.copy()
        self._fresh = None
        self._last_cmd_ns = None
        self.timed_out = False
        self.k += 1
        self.publish(self.sim_time_ns, None)
        text = f"reset to the initial state at t = {self.sim_time_ns / 1e9:.2f} s"
        self.logs.info(text)
        return text

    def set_paused(self, paused: bool) -> str:
        """Pause (True) or resume; returns ``paused``/``running`` or ``already ...``."""
        was, self.paused = self.paused, bool(paused)
        if not self.paused:
            self.stopped = False
        state = "paused" if self.paused else "running"
        if was != self.paused:
            self.logs.info(state)
            return state
        return f"already {state}"

    def stop(self) -> str:
        """Reset and pause (``stopped`` until the next step or resume); returns the message."""
        self.set_paused(True)
        text = self.reset()
        self.stopped = True
        return f"stopped: {text}"

    def step_paused(self, n: int) -> int:
        """Run ``n`` steps now while paused, each with the held command (timer mode: the
        newest command received first, as a tick takes it; no timeout rule: no wall time
        passes in a paused simulation). Every step is published as usual. Returns the steps
        run; ValueError (one line) if not paused or ``n`` is negative."""
        if not self.paused:
            raise ValueError("the simulation is not paused: pause it before stepping")
        n = int(n)
        if n < 0:
            raise ValueError(f"steps must be >= 0, got {n}")
        for _ in range(n):
            start = self.clock.wall_ns()
            received = -1
            if self._fresh is not None:
                (u, received), self._fresh = self._fresh, None
                self.held = u
            self._advance(self.held, received, start)
        return n

    # -- statistics ---------------------------------------------------------------------------

    def stats(self) -> tuple[dict[str, Any], int]:
        """The statistics since the last call (``~/stats`` values) and the level (0 OK,
        1 WARN: a command was rejected or a step diverged). Keys: ``step_mode``, ``paused``,
        ``sim_time``, the counters, ``rate_hz`` and ``real_time_factor`` (simulated s per wall
        s) over the window, ``step_ms_p50/p99/max`` (step start to published),
        ``step_cpu_ms_p50/p99`` and ``latency_ms_p50/p99`` (command received to published),
        then the backend's own (``Backend.stats``)."""
        values: dict[str, Any] = {"step_mode": self.config.step_mode, "paused": self.paused,
                                  "sim_time": f"{self.sim_time_ns / 1e9:.2f}"}
        values.update(self.counters.as_dict())
        values.update(self._window())
        extra = getattr(self.backend, "stats", None)
        if extra is not None:
            values.update(extra())
        return values, 1 if self.counters.bad else 0

    def _window(self) -> dict[str, Any]:
        t = self.times
        i0, i1 = self._stats_index, len(t.start)
        now = self.clock.monotonic_ns()
        span = max(now - self._stats_mono, 1) / 1e9
        steps = self.counters.steps - self._stats_k
        self._stats_index, self._stats_mono, self._stats_k = i1, now, self.counters.steps
        out: dict[str, Any] = {"rate_hz": f"{steps / span:.2f}",
                               "real_time_factor": f"{steps * CONTROL_DT_NS / 1e9 / span:.3f}"}
        if i1 > i0:
            start = np.asarray(t.start[i0:i1])
            pub = np.asarray(t.published[i0:i1])
            rec = np.asarray(t.received[i0:i1])
            step_ms = (pub - start) / 1e6
            cpu_ms = np.asarray(t.cpu[i0:i1]) / 1e6
            p = np.percentile
            out.update(step_ms_p50=f"{p(step_ms, 50):.3f}", step_ms_p99=f"{p(step_ms, 99):.3f}",
                       step_ms_max=f"{step_ms.max():.3f}",
                       step_cpu_ms_p50=f"{p(cpu_ms, 50):.3f}",
                       step_cpu_ms_p99=f"{p(cpu_ms, 99):.3f}")
            have = rec >= 0
            if have.any():
                lat = (pub[have] - rec[have]) / 1e6
                out.update(latency_ms_p50=f"{p(lat, 50):.3f}", latency_ms_p99=f"{p(lat, 99):.3f}")
        return out

    def write_latency_log(self, path: str) -> None:
        """The per-step timings as CSV (atomically): cmd_received_ns (-1: held command),
        step_start_ns, published_ns (wall clock), step_cpu_ns."""
        atomic_write_text(path, self.times.csv())

