"""Live robots for the view: subscriptions to simulators' topics, one rclpy context per domain.

A robot is a spec ``[LABEL=][DOMAIN][/NAMESPACE]`` (:func:`parse_specs`): its
``<NAMESPACE>/littledog/joint_states`` and ``<NAMESPACE>/littledog/odom`` in ROS domain DOMAIN
(default ``ROS_DOMAIN_ID``). Robots in one domain share one context, node and executor thread;
each other domain gets its own (``make run`` puts sim_node and pybullet_node in two domains so
both keep the contract's topic names).

Cost to the simulators: a subscription is one more DDS reader of their publishers. By default
it is best-effort and volatile, so a simulator never waits for, retransmits to or keeps history
for the viewer (``--reliable``: reliable + transient-local, which also gets an idle
simulator's last states). No executor runs: the messages wait in the readers' caches
(``READER_DEPTH``) and one thread takes them all ``POLL_RATE`` times per second
(:meth:`LiveSource.poll`), converts and stores them; drawing happens in :class:`LiveView`'s own
thread at ``rate`` frames per second, each time with the newest complete state (joint states
and odometry of the same stamp) of every robot. Measured in ``benchmarks/viewer``.

History: every complete state is kept (up to ``HISTORY`` per robot) for the trails, the plots
(robots compared at equal stamps with robot 0) and :meth:`LiveSource.tracks`, which turns what
was seen into replay tracks (the demo's view after the run).
"""
from __future__ import annotations

import logging
import os
import re
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from ..layout import TOPIC_JOINT_STATES, TOPIC_ODOM
from .scene import Frame, ViewerApp
from .tracks import Track

__all__ = ["SimSpec", "parse_specs", "LiveSource", "LiveView", "HISTORY"]

log = logging.getLogger(__name__)

HISTORY = 120_000          # states kept per robot (20 min at 100 Hz)
PLOT_WINDOW = 2_000        # plots show the last this many common stamps (20 s at 100 Hz)
PLOT_PERIOD = 0.25         # s between plot updates
TRAIL_PERIOD = 0.2         # s between trail updates
POLL_RATE = 50.0           # Hz: the subscriptions are read this often (LiveSource's thread)
READER_DEPTH = 50          # messages a subscription keeps between two polls (0.5 s at 100 Hz)
_SPEC = re.compile(r"^(?:(?P<label>[^=/]+)=)?(?P<domain>\d+)?(?P<ns>/[A-Za-z0-9_/~]*)?$")


@dataclass(frozen=True)
class SimSpec:
    label: str
    domain: int
    namespace: str            # "" or "/name" (no trailing slash)

    def topic(self, name: str) -> str:
        return f"{self.namespace}{name}"

    def describe(self) -> str:
        return f"{self.label} (domain {self.domain}, {self.namespace or '/'}littledog/...)"


def _default_domain() -> int:
    try:
        return int(os.environ.get("ROS_DOMAIN_ID", "0") or 0)
    except ValueError:
        return 0


def parse_specs(texts: Sequence[str]) -> list[SimSpec]:
    """Robot specs (module doc); an empty list means one robot in ROS_DOMAIN_ID, root
    namespace. ValueError on a malformed spec, a domain out of 0..232 or a repeated label."""
    if not texts:
        texts = [""]
    specs: list[SimSpec] = []
    for i, text in enumerate(texts):
        m = _SPEC.match(text.strip())
        if m is None:
            raise ValueError(f"robot spec {text!r}: expected [LABEL=][DOMAIN][/NAMESPACE], e.g. "
                             f"learned=40 or a=/robot1")
        domain = int(m.group("domain")) if m.group("domain") else _default_domain()
        if not 0 <= domain <= 232:
            raise ValueError(f"robot spec {text!r}: ROS domain must be in 0..232")
        ns = (m.group("ns") or "").rstrip("/")
        label = (m.group("label") or "").strip() or (
            ns.strip("/") or (f"domain {domain}" if m.group("domain") else f"robot {i}"))
        specs.append(SimSpec(label, domain, ns))
    labels = [s.label for s in specs]
    if len(set(labels)) != len(labels):
        raise ValueError(f"robot labels must differ, got {', '.join(labels)}")
    return specs


class _Robot:
    """Newest states of one robot: pending messages by stamp, complete states in a history."""

    def __init__(self, spec: SimSpec) -> None:
        self.spec = spec
        self.lock = threading.Lock()
        self.q: dict[int, np.ndarray] = {}
        self.odom: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray | None]] = {}
        self.stamps: deque[int] = deque(maxlen=HISTORY)
        self.pos: deque[np.ndarray] = deque(maxlen=HISTORY)
        self.orn: deque[np.ndarray] = deque(maxlen=HISTORY)
        self.qs: deque[np.ndarray] = deque(maxlen=HISTORY)
        self.cov: deque[np.ndarray | None] = deque(maxlen=HISTORY)
        self.latest: Frame | None = None
        self.received = 0        # complete states taken since the start (restarts included)
        self.bad = 0
        from ..nodes.messages import joint_state_arrays, stamp_ns

        self._joint_state_arrays, self._stamp_ns = joint_state_arrays, stamp_ns

    def _complete(self, ns: int) -> None:
        if ns in self.q and ns in self.odom:
            q = self.q.pop(ns)
            pos, orn, cov = self.odom.pop(ns)
            if self.stamps and ns <= self.stamps[-1]:
                if ns < self.stamps[-1]:      # the simulator restarted or went back: new story
                    for d in (self.stamps, self.pos, self.orn, self.qs, self.cov):
                        d.clear()
                else:
                    return
            self.stamps.append(ns)
            self.pos.append(pos)
            self.orn.append(orn)
            self.qs.append(q)
            self.cov.append(cov)
            self.received += 1
            self.latest = Frame(ns / 1e9, pos, orn, q, cov)
            for d in (self.q, self.odom):     # drop halves that can no longer complete
                if len(d) > 20:
                    for k in [k for k in d if k < ns]:
                        del d[k]

    def on_joint_states(self, msg: Any) -> None:
        try:
            q = self._joint_state_arrays(msg)[0]
        except (ValueError, IndexError):
            self.bad += 1
            return
        if not np.all(np.isfinite(q)):
            self.bad += 1
            return
        with self.lock:
            ns = self._stamp_ns(msg.header.stamp)
            self.q[ns] = q
            self._complete(ns)

    def on_odom(self, msg: Any) -> None:
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        pos = np.array([p.x, p.y, p.z])
        orn = np.array([o.x, o.y, o.z, o.w])
        if not (np.isfinite(pos).all() and np.isfinite(orn).all()
                and float(orn @ orn) > 0.25):     # |orn| > 0.5
            self.bad += 1
            return
        c = msg.pose.covariance
        cov = None
        if c[0] >= 0.0:                  # -1 in [0]: unknown
            cov = np.array([[c[0], c[1]], [c[6], c[7]]])
            if not np.all(np.isfinite(cov)):
                cov = None
        with self.lock:
            ns = self._stamp_ns(msg.header.stamp)
            self.odom[ns] = (pos, orn, cov)
            self._complete(ns)


class _Domain:
    """One rclpy context and node in a ROS domain, read by polling (no executor).

    The subscriptions have no callback work: :meth:`poll` takes every message waiting in their
    reader caches (depth ``READER_DEPTH``) and hands them to the robots. A poll per drawn frame
    replaces an executor wake-up per message, which was most of the view's CPU
    (benchmarks/viewer)."""

    def __init__(self, domain: int, robots: Sequence[_Robot], reliable: bool) -> None:
        import rclpy
        from nav_msgs.msg import Odometry
        from rclpy.context import Context
        from rclpy.node import Node
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from rclpy.signals import SignalHandlerOptions
        from sensor_msgs.msg import JointState

        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=READER_DEPTH,
                         reliability=(ReliabilityPolicy.RELIABLE if reliable
                                      else ReliabilityPolicy.BEST_EFFORT),
                         durability=(DurabilityPolicy.TRANSIENT_LOCAL if reliable
                                     else DurabilityPolicy.VOLATILE))
        self.domain = domain
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain,
                   signal_handler_options=SignalHandlerOptions.NO)
        try:
            # no parameter services or rosout: nothing would serve them (no executor)
            self.node = Node(f"viewer_{os.getpid()}_{domain}", context=self.context,
                             start_parameter_services=False, enable_rosout=False)
            self.subs = []
            self.readers: list[tuple[Any, Callable[[Any], None]]] = []
            for r in robots:
                for msg_type, topic, handler in (
                        (JointState, TOPIC_JOINT_STATES, r.on_joint_states),
                        (Odometry, TOPIC_ODOM, r.on_odom)):
                    sub = self.node.create_subscription(msg_type, r.spec.topic(topic),
                                                        _never_called, qos)
                    self.subs.append(sub)
                    self.readers.append((sub, handler))
        except Exception:
            rclpy.try_shutdown(context=self.context)
            raise
        self.lock = threading.Lock()

    def poll(self) -> int:
        """Take every waiting message of every subscription, oldest first; returns how many."""
        n = 0
        with self.lock:
            for sub, handler in self.readers:
                try:
                    with sub.handle:
                        while True:
                            got = sub.handle.take_message(sub.msg_type, False)
                            if got is None:
                                break
                            handler(got[0])
                            n += 1
                except Exception as e:   # destroyed under us (closing), or a bad message
                    if not self.context.ok():
                        return n
                    log.warning("viewer: taking a message in domain %d: %s", self.domain, e)
        return n

    def publishers(self) -> int:
        """Fewest publishers matched by one of this domain's subscriptions."""
        return min(s.get_publisher_count() for s in self.subs)

    def close(self) -> None:
        import rclpy

        with self.lock:
            try:
                self.node.destroy_node()
            finally:
                rclpy.try_shutdown(context=self.context)


def _never_called(msg: Any) -> None:
    """The subscriptions' callback: no executor runs them (:meth:`_Domain.poll` takes)."""


class LiveSource:
    """The robots of ``specs``, subscribed (module doc); a thread reads the subscriptions
    ``poll_rate`` times per second (:meth:`_Domain.poll`)."""

    def __init__(self, specs: Sequence[SimSpec], reliable: bool = False,
                 poll_rate: float = POLL_RATE) -> None:
        if not poll_rate > 0:
            raise ValueError(f"poll_rate must be > 0, got {poll_rate}")
        self.specs = list(specs)
        self.robots = [_Robot(s) for s in self.specs]
        self.domains: list[_Domain] = []
        self.period = 1.0 / poll_rate
        self._stop = threading.Event()
        self.thread: threading.Thread | None = None
        try:
            for d in dict.fromkeys(s.domain for s in self.specs):
                self.domains.append(_Domain(d, [r for r in self.robots if r.spec.domain == d],
                                            reliable))
        except Exception:
            self.close()
            raise
        self.thread = threading.Thread(target=self._run, name="viewer-poll", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            t0 = time.perf_counter()
            self.poll()
            self._stop.wait(max(0.0, self.period - (time.perf_counter() - t0)))

    def poll(self) -> int:
        """Read every waiting message now (the thread does this each period)."""
        return sum(d.poll() for d in self.domains)

    def latest(self) -> list[Frame | None]:
        out = []
        for r in self.robots:
            with r.lock:
                out.append(r.latest)
        return out

    def connected(self) -> bool:
        """Every subscription matched at least one publisher. Matching is what the ROS graph
        says; DDS may deliver to a new subscription only some time later, so this does not
        mean that anything was received yet (:meth:`ready` does)."""
        return all(d.publishers() >= 1 for d in self.domains)

    def received(self) -> list[int]:
        """Complete states (joint states and odometry of one stamp) taken so far from each
        robot, in the order of ``specs``; counts only grow (also over a simulator restart)."""
        out = []
        for r in self.robots:
            with r.lock:
                out.append(r.received)
        return out

    def ready(self) -> bool:
        """Every robot has delivered at least one complete state: the subscriptions do not
        only match, messages actually arrive through them."""
        return all(n >= 1 for n in self.received())

    def trails(self, points: int = 600) -> list[np.ndarray | None]:
        out: list[np.ndarray | None] = []
        for r in self.robots:
            with r.lock:
                n = len(r.pos)
                if n < 2:
                    out.append(None)
                    continue
                idx = np.unique(np.linspace(0, n - 1, min(n, points)).astype(int))
                out.append(np.array([r.pos[i] for i in idx]))
        return out

    def _arrays(self, r: _Robot, last: int | None = None):
        with r.lock:
            n = len(r.stamps)
            lo = 0 if last is None else max(0, n - last)
            st = np.fromiter((r.stamps[i] for i in range(lo, n)), dtype=np.int64, count=n - lo)
            pos = np.array([r.pos[i] for i in range(lo, n)]).reshape(-1, 3)
            orn = np.array([r.orn[i] for i in range(lo, n)]).reshape(-1, 4)
            q = np.array([r.qs[i] for i in range(lo, n)]).reshape(-1, 12)
            cov = [r.cov[i] for i in range(lo, n)]
        return st, pos, orn, q, cov

    def comparison(self, last: int = PLOT_WINDOW):
        """Times [s] of the stamps every robot has (within the last ``last`` of robot 0), the
        (x, y) gap of each other robot to robot 0 and its joint errors (n, 12)."""
        ref = self._arrays(self.robots[0], last)
        common = ref[0]
        others = [self._arrays(r, last + 200) for r in self.robots[1:]]
        for o in others:
            common = np.intersect1d(common, o[0])
        i0 = np.searchsorted(ref[0], common)
        gaps, jerr = [], []
        for o in others:
            j = np.searchsorted(o[0], common)
            gaps.append(np.linalg.norm(o[1][j, :2] - ref[1][i0, :2], axis=1))
            jerr.append(o[3][j] - ref[3][i0])
        return common / 1e9, gaps, jerr

    def tracks(self) -> list[Track]:
        """What was seen, as replay tracks over the stamps every robot has."""
        arrays = [self._arrays(r) for r in self.robots]
        common = arrays[0][0]
        for a in arrays[1:]:
            common = np.intersect1d(common, a[0])
        if common.size < 2:
            raise ValueError("fewer than 2 states seen from every robot: nothing to replay")
        out = []
        for r, (st, pos, orn, q, cov) in zip(self.robots, arrays):
            j = np.searchsorted(st, common)
            c = None
            if all(cov[i] is not None for i in j):
                c = np.array([cov[i] for i in j])
            out.append(Track(r.spec.label, common / 1e9, pos[j], orn[j], q[j], c))
        return out

    def close(self) -> None:
        self._stop.set()
        if self.thread is not None:
            self.thread.join(5.0)
        for d in self.domains:
            try:
                d.close()
            except Exception as e:
                log.warning("closing the subscriptions of domain %d: %s", d.domain, e)
        self.domains = []


class LiveView:
    """Draws the newest state of every robot at up to ``rate`` frames per second."""

    def __init__(self, app: ViewerApp, source: LiveSource, rate: float = 40.0) -> None:
        self.app, self.source, self.rate = app, source, float(rate)
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name="viewer-live", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        period = 1.0 / self.rate
        seen: list[float | None] = [None] * len(self.source.robots)
        next_plot = next_trail = 0.0
        while not self._stop.is_set():
            t0 = time.perf_counter()
            try:
                if not self.app.watched():      # nobody looks: keep only the newest states
                    self.app.draw(self.source.latest(), count=False)
                    self._stop.wait(period)
                    continue
                frames = self.source.latest()
                new = [f if f is not None and f.t != s else None for f, s in zip(frames, seen)]
                trails = None
                if t0 >= next_trail and any(n is not None for n in new):
                    trails = self.source.trails() if self.app.gui_trail.value else \
                        [None] * len(frames)
                    next_trail = t0 + TRAIL_PERIOD
                if any(n is not None for n in new):
                    self.app.draw(new, trails)
                    seen = [f.t if f is not None else None for f in frames]
                if self.app.plots and t0 >= next_plot:
                    t, gaps, jerr = self.source.comparison()
                    if t.size:
                        self.app.set_plots(t, gaps, jerr)
                    next_plot = t0 + PLOT_PERIOD
            except Exception as e:   # a drawing problem must not end the view
                log.warning("viewer: %s", e)
            self._stop.wait(max(0.0, period - (time.perf_counter() - t0)))

    def close(self) -> None:
        self._stop.set()
        self.thread.join(2.0)
