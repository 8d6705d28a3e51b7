"""The view of ``make run VIEW=1`` (``python -m littledog_mlsim.apps.demo --view``).

Before the replay: a live view of pybullet_node (robot 0, the reference) and sim_node, each in
its own ROS domain, with localhost discovery as the demo uses. After the report: the same page
turns into a replay of everything it received (a timeline to scrub), served until Ctrl-C.
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
            self.source = LiveSource(specs)
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
        """The view's subscriptions have matched both simulators' publishers (the demo waits
        for this before its first command, so that the view sees the whole run)."""
        return self.source.connected()

    def serve_replay(self) -> None:
        """Stop the live view, replay what was received, serve until Ctrl-C or SIGTERM
        (the demo turns SIGTERM into KeyboardInterrupt)."""
        if self.live is not None:
            self.live.close()
            self.live = None
        try:
            tracks = self.source.tracks()
        except ValueError as e:
            self.log(f"view: {e}")
            tracks = None
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
