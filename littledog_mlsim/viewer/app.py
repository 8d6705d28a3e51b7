"""``littledog-mlsim view``: watch simulators live, or replay a move, in the browser.

    littledog-mlsim view --live                                 # ROS_DOMAIN_ID, root namespace
    littledog-mlsim view --live learned=40 pybullet=41          # two domains (as `make run`)
    littledog-mlsim view --live a=/robot1 b=7/robot2 --layout ghost
    littledog-mlsim view --data bags/demo --move F_02 --model bags/demo_lgpr \
        --projection none,alpha --physics nominal               # replay with a timeline
    littledog-mlsim view --bag bags/demo/F_02
    littledog-mlsim view --rollout out/rollout.json [--move BL_15] [--physics nominal]

Prints the address (``http://localhost:PORT``) and serves until Ctrl-C. Everything the page
needs comes from the installed viser wheel (no network). Live sources: ``viewer.live``; replay
tracks: ``viewer.tracks``; the page: ``viewer.scene``; docs/viewer.md.
"""
from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path
from typing import Callable, Sequence

__all__ = ["add_arguments", "run", "main", "ViewError"]

log = logging.getLogger(__name__)

DEFAULT_PORT = 8080


class ViewError(Exception):
    """A user-facing problem: one line, exit status 2."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    src = p.add_argument_group("live (ROS 2)")
    src.add_argument("--live", nargs="*", metavar="[LABEL=][DOMAIN][/NAMESPACE]", default=None,
                     help="subscribe to simulators' /littledog/joint_states and /littledog/odom: "
                          "one spec per robot, e.g. learned=40 pybullet=41 (ROS domains) or "
                          "a=/robot1 b=/robot2 (namespaces); no spec: one robot in "
                          "ROS_DOMAIN_ID, root namespace")
    src.add_argument("--reliable", action="store_true",
                     help="live: subscribe reliable + transient-local (gets an idle simulator's "
                          "last state) instead of best-effort (default: never slows a simulator)")
    rp = p.add_argument_group("replay")
    rp.add_argument("--bag", type=Path, help="a move's bag directory")
    rp.add_argument("--data", type=Path, help="dataset directory (with --move)")
    rp.add_argument("--move", help="move of --data or of the rollout's dataset, e.g. F_02 "
                                   "(default: the first TestPool move)")
    rp.add_argument("--rollout", type=Path,
                    help="a rollout.json (littledog-mlsim rollout): its model, dataset and "
                         "projection, re-run on --move")
    rp.add_argument("--model", type=Path, help="learned simulator to run on the move")
    rp.add_argument("--projection", default=None,
                    help="projection(s) of the learned simulator, comma-separated among none, "
                         "bound, alpha (one robot each; default none, or the rollout's)")
    rp.add_argument("--alpha", type=float, default=None, help="alpha of alpha-PROJ (0.5)")
    rp.add_argument("--radius", type=float, default=None,
                    help="gated alpha-PROJ radius (default 0: plain alpha-PROJ)")
    rp.add_argument("--physics", default=None, metavar="ROBOT|TWIN.json",
                    help="add the physics baseline: a robot name (nominal, measured), a twin "
                         "file (littledog-mlsim calibrate) or a robot config file "
                         "(littledog-mlsim diagnose/reproduce)")
    rp.add_argument("--paused", action="store_true", help="start the replay paused")
    v = p.add_argument_group("view")
    v.add_argument("--host", default="127.0.0.1",
                   help="address to serve on (default 127.0.0.1: this machine only)")
    v.add_argument("--port", type=int, default=DEFAULT_PORT,
                   help=f"port (default {DEFAULT_PORT}; the next free one if taken; 0: any)")
    v.add_argument("--layout", choices=["side", "ghost"], default="side",
                   help="robots side by side (default) or overlaid as translucent ghosts")
    v.add_argument("--spacing", type=float, default=0.4, help="side by side: metres between "
                                                              "robots (default 0.4)")
    v.add_argument("--rate", type=float, default=40.0,
                   help="frames per second sent to the browser (default 40)")
    v.add_argument("--no-trail", action="store_true", help="no body-path trails")
    v.add_argument("--no-ellipse", action="store_true", help="no pose-covariance ellipses")
    v.add_argument("--no-plots", action="store_true", help="no gap / joint-error plots")
    v.add_argument("--duration", type=float, default=None,
                   help="stop after this many seconds (default: serve until Ctrl-C)")


def _replay_plan(a: argparse.Namespace) -> tuple[list[str], Callable[[], list]]:
    """Check the replay arguments and load the inputs (recording, model, robot config); return
    the robots' labels and a function computing their tracks (the rollouts: the slow part,
    done once the page is served)."""
    from .tracks import (learned_track, load_recording, measured_track, physics_track,
                         projection_label, rollout_file_settings)

    model_path, data, move = a.model, a.data, a.move
    projection, alpha, radius = a.projection, a.alpha, a.radius
    if a.rollout is not None:
        r = rollout_file_settings(a.rollout)
        model_path = model_path or Path(r["model"])
        data = data or Path(r["data"])
        move = move or r["move"]
        projection = projection or r["projection"]
        alpha = r["alpha"] if alpha is None else alpha
        radius = r["radius"] if radius is None else radius
    if a.bag is None and data is None:
        raise ViewError("nothing to show: give --live, --bag, --data or --rollout")
    rec = load_recording(a.bag, data, move)
    labels = ["measured"]
    steps: list[Callable[[], object]] = [lambda: measured_track(rec, labels[0])]
    if model_path is not None:
        from ..models.onestep import OneStepModel
        from ..models.persistence import ModelError

        try:
            model = OneStepModel.load(model_path)
        except (ModelError, OSError) as e:
            raise ViewError(f"cannot load model {model_path}: {e}") from None
        kinds = [k.strip() for k in (projection or "none").split(",") if k.strip()]
        bad = [k for k in kinds if k not in ("none", "bound", "alpha")]
        if bad or not kinds:
            raise ViewError(f"--projection: choose among none, bound, alpha (got {projection!r})")
        al = 0.5 if alpha is None else alpha
        for k in kinds:
            rad = (radius or 0.0) if k == "alpha" else 0.0
            label = f"{getattr(model, 'method', 'learned')} " + projection_label(k, al, rad)
            labels.append(label)
            steps.append(lambda k=k, rad=rad, label=label:
                          learned_track(rec, model, k, al, rad, label=label))
    elif projection is not None:
        raise ViewError("--projection needs --model or --rollout")
    if a.physics is not None:
        from ..robot.twin import robot_config_from

        try:
            config = robot_config_from(a.physics)
        except ValueError as e:
            raise ViewError(f"--physics: {e}") from None
        label = f"physics ({Path(str(a.physics)).stem})"
        labels.append(label)
        steps.append(lambda: physics_track(rec, config, label=label))
    log.info("replaying %s: %s", rec.name, ", ".join(labels))
    return labels, lambda: [step() for step in steps]


def run(a: argparse.Namespace, ready=None) -> int:
    """Start the view from parsed arguments; serve until Ctrl-C or ``--duration``."""
    from .scene import Player, ViewerApp, serve_forever

    if a.rate <= 0 or a.spacing < 0:
        raise ViewError("--rate must be > 0 and --spacing >= 0")
    t0 = time.perf_counter()
    live = a.live is not None
    if live and (a.bag or a.data or a.rollout or a.model):
        raise ViewError("--live and a replay (--bag/--data/--rollout/--model) exclude each other")
    common = dict(host=a.host, port=a.port, layout=a.layout, spacing=a.spacing,
                  trail=not a.no_trail, ellipse=not a.no_ellipse, plots=not a.no_plots)
    if live:
        from .live import LiveSource, LiveView, parse_specs

        try:
            specs = parse_specs(a.live)
        except ValueError as e:
            raise ViewError(str(e)) from None
        app = ViewerApp([s.label for s in specs], title="LittleDog live", **common)
        source = LiveSource(specs, reliable=a.reliable)
        view = LiveView(app, source, rate=a.rate)
        closers = [view.close, source.close]
        what = "live: " + ", ".join(s.describe() for s in specs)
    else:
        try:
            labels, compute = _replay_plan(a)
        except ValueError as e:
            raise ViewError(str(e)) from None
        # serve the page first (it says "waiting for robot states"), then run the rollouts
        app = ViewerApp(labels, title="LittleDog replay", **common)
        log.info("page served at %s after %.1f s; computing the tracks", app.url,
                 time.perf_counter() - t0)
        try:
            player = Player(app, compute(), rate=a.rate, autoplay=not a.paused)
        except ValueError as e:
            app.stop()
            raise ViewError(str(e)) from None
        except BaseException:
            app.stop()
            raise
        closers = [player.close]
        what = "replay: " + ", ".join(labels)
    print(f"LittleDog view ({what}) at {app.url} (ready in {time.perf_counter() - t0:.1f} s; "
          f"Ctrl-C to stop)", flush=True)
    if ready is not None:
        ready(app)
    end = None if a.duration is None else time.monotonic() + a.duration
    try:
        serve_forever(app, None if end is None else (lambda: time.monotonic() > end))
    finally:
        for c in closers:
            try:
                c()
            except Exception as e:  # closing must not hide the reason we stop
                log.warning("closing the view: %s", e)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="littledog-mlsim view", description=__doc__.split("\n")[0])
    add_arguments(p)
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        return run(a)
    except ViewError as e:
        print(f"view: error: {' '.join(str(e).split())}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
