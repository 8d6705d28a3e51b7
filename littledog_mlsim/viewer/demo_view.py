"""The view of ``make run VIEW=1`` (``python -m littledog_mlsim.apps.demo --view``).

Before the replay: a live view of pybullet_node (robot 0, the reference) and sim_node, each in
its own ROS domain, with localhost discovery as the demo uses. After the report: the same page
turns into a replay of everything it received (a timeline to scrub), served until Ctrl-C.

The subscriptions are reliable and transient-local (``LiveSource(reliable=True)``), unlike the
live view's best-effort default: the demo's simulators run in lockstep, so they are idle until
the first command and have published only their initial state (measurement 0, at start-up,
kept by their transient-local publishers). A transient-local subscription gets that state as
soon as DDS delivers to it, so :meth:`DemoView.ready` turns true only once messages really
arrive from both simulators, and the demo waits for it before its first command (matching in
the ROS graph, :meth:`DemoView.connected`, comes before delivery: a short run could be over
before the view received anything). The simulators' publishers are keep-last (depth 10):
DDS drops a slow reliable reader's oldest unacknowledged samples instead of blocking the
writer, so the view still never holds up a step.
"""
from __future__ import annotations

import os
import time
from typing import Callable

from .live import LiveSource, LiveView, SimSpec
from .scene import Player, ViewerApp

__all__ = ["DemoView"]


class DemoView:
    def __init__(self, learned_domain: int, pybullet_domain: int, port: int = 8080,
                 host: str = "127.0.0.1", log: Callable[[str], None] = print) -> None:
        specs = [SimSpec("pybullet", pybullet_domain, ""), SimSpec("learned", learned_domain, "")]
        self.log = log
        self.app = ViewerApp([s.label for s in specs], host=host, port=port,
                             title="LittleDog: make run")
        saved = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE")
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"   # read by rclpy.init
        try:
            self.source = LiveSource(specs, reliable=True)
        except Exception:
            self.app.stop()
            raise
        finally:
            if saved is None:
                os.environ.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
            else:
                os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = saved
        self.live: LiveView | None = LiveView(self.app, self.source)
        self.player: Player | None = None
        log(f"view: open {self.app.url} to watch pybullet_node and sim_node live")

    def connected(self) -> bool:
        """The view's subscriptions have matched both simulators' publishers in the ROS graph
        (not yet proof that messages arrive: :meth:`ready`)."""
        return self.source.connected()

    def ready(self) -> bool:
        """The view has received at least one complete state from each simulator (their
        initial states, module doc); the demo waits for this before its first command, so
        that the view sees the whole run."""
        return self.source.ready()

    def serve_replay(self) -> None:
        """Stop the live view, replay what was received, serve until Ctrl-C or SIGTERM
        (the demo turns SIGTERM into KeyboardInterrupt)."""
        if self.live is not None:
            self.live.close()
            self.live = None
        self.source.poll()            # anything still waiting in the readers
        try:
            tracks = self.source.tracks()
        except ValueError as e:
            self.log(f"view: {e}")
            tracks = None
        else:
            t = tracks[0].t
            self.log(f"view: received {t.size} states of both simulators, t = {t[0]:.2f} to "
                     f"{t[-1]:.2f} s")
        self.source.close()
        if tracks is not None:
            self.player = Player(self.app, tracks)
        self.log(f"view: replay of the run at {self.app.url} (Ctrl-C to stop)")
        try:
            while True:
                time.sleep(0.5)
        except KeyboardInterrupt:     # the expected end
            pass

    def close(self) -> None:
        if self.live is not None:
            self.live.close()
        if self.player is not None:
            self.player.close()
        self.source.close()
        self.app.stop()
