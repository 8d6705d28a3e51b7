"""viewer_node: the live browser view as a ROS 2 node (``ros2 run littledog_mlsim viewer_node``).

    viewer_node                                              # this domain, root namespace
    viewer_node --ros-args -p robots:="['pybullet=41', 'learned=40']" -p port:=8090
    viewer_node --ros-args -p robots:="['a=/robot1', 'b=/robot2']" -p layout:=ghost

Subscribes to each robot's ``/littledog/joint_states`` and ``/littledog/odom`` (the spec
syntax and the subscription cost: ``viewer/live.py``) and serves the page (``viewer/scene.py``);
logs the address; runs until SIGINT/SIGTERM. Same view as ``littledog-mlsim view --live``.
A bad parameter (spec, layout, rate, port) is one FATAL line and exit status 2.
"""
from __future__ import annotations

import sys
from typing import Sequence

import rclpy

from ._run import ConfiguredNode, Param, StartupError, run_node

NODE_NAME = "viewer_node"


class ViewerNode(ConfiguredNode):
    PARAMS = (
        Param("robots", [""], "robots to draw, each [LABEL=][DOMAIN][/NAMESPACE] (e.g. "
              "learned=40, a=/robot1); '' = this node's domain, root namespace",
              "strings; labels must differ"),
        Param("host", "127.0.0.1", "address to serve the page on (0.0.0.0: every interface)"),
        Param("port", 8080, "HTTP/websocket port (the next free one if taken; 0: any)",
              "0..65535"),
        Param("layout", "side", "side: robots side by side; ghost: overlaid, translucent",
              "side | ghost"),
        Param("spacing", 0.4, "side by side: metres between robots", ">= 0"),
        Param("rate", 40.0, "frames per second sent to the browser", "> 0"),
        Param("reliable", False, "subscribe reliable + transient-local instead of best-effort"),
        Param("trail", True, "draw each robot's body path"),
        Param("ellipse", True, "draw the (x, y) pose covariance (2 sigma) when published"),
        Param("plots", True, "plot the (x, y) gap and joint errors to the first robot"),
    )

    def __init__(self) -> None:
        super().__init__(NODE_NAME, self.PARAMS)
        from ..viewer.live import LiveSource, LiveView, parse_specs
        from ..viewer.scene import ViewerApp

        try:
            specs = parse_specs([s for s in self.param("robots")] or [""])
        except ValueError as e:
            raise StartupError(str(e)) from None
        layout = self.param("layout")
        if layout not in ("side", "ghost"):
            raise StartupError(f"parameter layout must be side or ghost, got {layout!r}")
        rate, spacing, port = self.param("rate"), self.param("spacing"), self.param("port")
        if not rate > 0 or not spacing >= 0 or not 0 <= port <= 65535:
            raise StartupError("parameters: rate must be > 0, spacing >= 0, port in 0..65535")
        self.app = ViewerApp([s.label for s in specs], host=self.param("host"), port=port,
                             layout=layout, spacing=spacing, trail=self.param("trail"),
                             ellipse=self.param("ellipse"), plots=self.param("plots"),
                             title="LittleDog live")
        try:
            self.source = LiveSource(specs, reliable=self.param("reliable"))
        except Exception:
            self.app.stop()
            raise
        self.view = LiveView(self.app, self.source, rate=rate)
        self.get_logger().info(f"LittleDog view at {self.app.url}: "
                               + ", ".join(s.describe() for s in specs))

    def close(self) -> None:
        self.view.close()
        self.source.close()
        self.app.stop()


def _work(node: ViewerNode) -> None:
    try:
        rclpy.spin(node)
    finally:
        node.close()


def main(args: Sequence[str] | None = None) -> int:
    return run_node(NODE_NAME, ViewerNode, _work, args, rclpy_signals=True)


if __name__ == "__main__":
    sys.exit(main())
