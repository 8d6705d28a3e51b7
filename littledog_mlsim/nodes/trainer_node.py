"""trainer_node: build a one-step model from a dataset of bags, one shot (docs/interface.md §6).

    trainer_node --ros-args -p data:=bags/default -p out:=/tmp/model -p method:=lr
    trainer_node --ros-args --params-file config/trainer.yaml -p method:=lgpr \
        -p 'method_params:="{cluster_size: 500, n_jobs: 2}"'

A ROS shell around the core's ``models.train.train_from_dataset`` (the same training as
``littledog-mlsim train``): the TrainPool bags of ``data``, the paper's features and responses,
``method`` with the constructor arguments ``method_params`` (a YAML mapping in a string: quote it
inside ``-p``), at most ``max_samples`` samples (0: the method's default cap, e.g. 2000 for
gpr), then ``OneStepModel.save``. The core's progress lines (and a regressor's ``verbose``
output) are forwarded to the ROS log, plus a "still fitting" line every ``heartbeat`` s.

The save is atomic (``models.persistence``): an existing model at ``out`` is replaced only by a
complete new one; any failure (a bad bag, a bad parameter, a failing fit, SIGINT/SIGTERM)
leaves it untouched. Exit status: 0 when the model is written, 1 when training failed (one
FATAL line naming the cause, e.g. the bag and topic), 2 for a bad parameter, 130 when
interrupted.

Recorded bags directly: set ``bags`` (a list of rosbag2 directories, ``.mcap``/``.db3`` files or
ROS 1 bags, as ``littledog-mlsim import`` takes them) instead of ``data``; the node imports them
first (``data.importer.import_bags``, options in ``import_options``, a YAML mapping of the
``ImportOptions`` fields such as ``"{cmd_topic: /ctrl/cmd, test_fraction: 0.0}"``) into
``import_out`` (kept) or a temporary directory (removed), then trains on that dataset. A bag that
cannot be imported is one FATAL line naming bag, topic and message (exit 1), and no model is
written.

    trainer_node --ros-args -p 'bags:=[/logs/run1, /logs/run2.mcap]' -p out:=/tmp/model

One-shot: no ``~/train`` service; the node exits when the model is written. Parameters:
``config/trainer.yaml``.
"""
from __future__ import annotations

import sys
import threading
import time
from typing import Any, Sequence

import numpy as np
import rclpy
import yaml
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_srvs.srv import SetBool, Trigger

from ._run import ConfiguredNode, Param, StartupError, one_line, run_node
from .recording import TopicRecording, move_recording
from .simulator import SIM_QOS

# live recording: reliable with a deep queue like bag_recorder, but volatile: only what arrives
# while recording
LIVE_QOS = QoSProfile(history=SIM_QOS.history, depth=1000, reliability=SIM_QOS.reliability,
                      durability=DurabilityPolicy.VOLATILE)

NODE_NAME = "trainer_node"

PARAMS: tuple[Param, ...] = (
    Param("data", "", "dataset directory (bags + dataset.yaml) whose TrainPool is trained on "
          "(required)"),
    Param("out", "", "model directory to write (replaced atomically if it holds a model)"),
    Param("method", "lr", "regression method of the one-step model",
          "lr | lwpr | gpr | sor | lgpr"),
    Param("method_params", "{}", "the method's hyperparameters as a YAML mapping, e.g. "
          "\"{cluster_size: 500, n_jobs: 2}\" (constructor arguments of the estimator; may "
          "also set target)"),
    Param("target", "delta", "response the regressor learns: delta = s_{t+1} - s_t, next = "
          "s_{t+1}", "delta | next"),
    Param("max_samples", 0, "train on at most this many samples, a seeded random subset "
          "(0: the method's default cap, models.train.DEFAULT_MAX_TRAIN)", ">= 0"),
    Param("seed", 0, "seeds the max_samples subset and the regressor's random_state"),
    Param("heartbeat", 30.0, "seconds between 'still fitting' log lines (0: none)", ">= 0"),
    Param("bags", Parameter.Type.STRING_ARRAY, "recorded bags to import and train on instead of "
          "data (rosbag2 directories, .mcap/.db3 files, ROS 1 .bag files; docs/import.md)"),
    Param("import_options", "{}", "options of the import of bags as a YAML mapping of "
          "data.importer.ImportOptions fields, e.g. \"{cmd_topic: /ctrl/cmd, test_fraction: 0.0}\""),
    Param("import_out", "", "dataset directory the bags are imported into (kept; must not "
          "exist); empty: a temporary directory, removed after training"),
    Param("live", False, "serve ~/record and ~/train instead of training once: record the "
          "live topics into record_dir, train on them on request"),
    Param("record_dir", "", "live: dataset directory the recordings go into (created; "
          "recordings already there are kept and trained on)"),
    Param("cmd_topic", "/pybullet_node/cmd_applied", "live: JointState topic of the applied "
          "commands, stamped at the start of their step (as bag_recorder's)"),
    Param("move_steps", 400, "live: a recording is cut into moves of at most this many steps "
          "(4 s, the paper's move length)", ">= 10"),
    Param("storage", "mcap", "live: rosbag2 storage plugin of the recorded bags",
          "mcap | sqlite3"),
)

# live recordings: moves shorter than this many steps are left out
MIN_MOVE_STEPS = 10

# live: the kinds of message recorded; the refusals of ``~/record`` (false while not recording,
# true while recording) answer how many of each arrived since the node started (``heard_text``),
# so a caller can see that every publisher reaches the trainer before it records (a volatile
# subscription keeps only what arrives after its publisher has matched it), and that the last
# messages it sent have arrived before it stops a recording
HEARD = ("command", "joint state", "odometry")


def heard_text(heard: dict[str, int]) -> str:
    """``"heard: 3 command, 3 joint state, 3 odometry"``; ``parse_heard`` reads it back."""
    return "heard: " + ", ".join(f"{heard[k]} {k}" for k in HEARD)


def parse_heard(text: str) -> dict[str, int] | None:
    """The counts in a ``heard_text`` inside ``text``, or None if it holds none."""
    import re

    m = re.search(r"heard: " + ", ".join(rf"(\d+) {k}" for k in HEARD), text)
    return None if m is None else {k: int(v) for k, v in zip(HEARD, m.groups())}


class TrainingError(Exception):
    """Training failed (bad data, failing fit): one FATAL line, exit status 1."""


class TrainerNode(ConfiguredNode):
    CONFIG_FILE = "trainer.yaml"

    def __init__(self) -> None:
        super().__init__(NODE_NAME, PARAMS)

    def settings(self) -> dict[str, Any]:
        """Parameters checked; StartupError (exit 2) on a bad one."""
        from ..models.train import METHOD_NAMES, make_estimator

        s = {p.name: self.param(p.name) for p in PARAMS}
        s["bags"] = list(s["bags"] or [])
        if s["live"]:
            if not s["record_dir"] or not s["out"]:
                raise StartupError("live: set the parameters record_dir (dataset directory of "
                                   "the recordings) and out (model directory)")
            if s["data"] or s["bags"]:
                raise StartupError("live: the data are the recordings in record_dir; leave "
                                   "data and bags unset")
            if s["move_steps"] < MIN_MOVE_STEPS:
                raise StartupError(f"move_steps must be >= {MIN_MOVE_STEPS}")
            from ..data.bags import STORAGES
            if s["storage"] not in STORAGES:
                raise StartupError(f"storage must be one of {', '.join(STORAGES)}")
            s["data"] = s["record_dir"]
        elif (not s["data"] and not s["bags"]) or not s["out"]:
            raise StartupError("set the parameters data (dataset directory) or bags (recorded "
                               "bags), and out (model directory)")
        if s["data"] and s["bags"]:
            raise StartupError("set data or bags, not both")
        s["import_options"] = _import_options(s["import_options"])
        if s["method"] not in METHOD_NAMES:
            raise StartupError(f"method must be one of {', '.join(METHOD_NAMES)}, got "
                               f"{s['method']!r}")
        try:
            params = yaml.safe_load(s["method_params"]) or {}
        except yaml.YAMLError as e:
            raise StartupError(f"method_params is not YAML: {one_line(e)}") from None
        if not isinstance(params, dict):
            raise StartupError("method_params must be a YAML mapping, e.g. \"{max_iter: 50}\"")
        s["method_params"] = params
        try:   # fail on a bad option before reading any bag
            make_estimator(s["method"], {k: v for k, v in params.items() if k != "target"})
        except (TypeError, ValueError) as e:
            raise StartupError(one_line(e)) from None
        if s["max_samples"] < 0 or s["heartbeat"] < 0:
            raise StartupError("max_samples and heartbeat must be >= 0")
        return s

    def train(self) -> None:
        """Fit with the core and save; TrainingError on any failure (nothing written then)."""
        self.fit_and_save(self.settings())

    def fit_and_save(self, s: dict[str, Any]) -> str:
        """Train with settings ``s`` and write the model atomically; returns the last log
        line. TrainingError (one line) on any failure: nothing is written then."""
        import contextlib

        from ..models.train import train_from_dataset

        log = self.get_logger()
        done = threading.Event()
        t0 = time.perf_counter()
        if s["heartbeat"] > 0:
            def beat() -> None:
                while not done.wait(s["heartbeat"]):
                    log.info(f"still working on {s['method']} "
                             f"({time.perf_counter() - t0:.0f} s)")
            threading.Thread(target=beat, daemon=True).start()
        tmp = None
        try:
            if s["bags"]:
                s["data"], tmp = self._import(s)
            with contextlib.redirect_stderr(_LogLines(log.info)):
                model = train_from_dataset(
                    s["data"], s["method"], options=s["method_params"],
                    max_train_samples=s["max_samples"] or None, seed=s["seed"],
                    progress=True, target=s["target"])
        except (ValueError, OSError, np.linalg.LinAlgError, MemoryError) as e:
            # DatasetError, BagError (naming bag and topic), ModelError are ValueErrors
            raise TrainingError(one_line(e)) from None
        finally:
            done.set()
            if tmp is not None:
                import shutil
                shutil.rmtree(tmp, ignore_errors=True)
        log.info(f"writing {s['out']}")
        try:
            model.save(s["out"])
        except (ValueError, OSError) as e:
            raise TrainingError(f"cannot write the model: {one_line(e)}") from None
        text = (f"wrote {s['method']} model to {s['out']} ({model.info.get('n_train', '?')} "
                f"samples from {model.info.get('n_moves', '?')} moves, "
                f"{time.perf_counter() - t0:.1f} s in all)")
        log.info(text)
        return text


    # -- live: ~/record and ~/train ---------------------------------------------------------------

    def run(self) -> int:
        """The node's work: train once, or (``live``) serve ~/record and ~/train until
        SIGINT/SIGTERM (exit status 0; a recording under way is written first)."""
        if not self.param("live"):
            self.train()
            return 0
        self._start_live(self.settings())
        try:
            while rclpy.ok(context=self.context):
                rclpy.spin_once(self, timeout_sec=0.1)
        except KeyboardInterrupt:
            if self.recording:
                self.get_logger().info(self.stop_recording())
            self.get_logger().info("stopped")
        return 0

    def _start_live(self, s: dict[str, Any]) -> None:
        from pathlib import Path

        from ..data.dataset import INDEX_FILE, read_index

        self.s = s
        self.record_dir = Path(s["record_dir"])
        self.entries: list = []
        if (self.record_dir / INDEX_FILE).is_file():
            try:
                self.entries = list(read_index(self.record_dir).entries)
            except ValueError as e:
                raise StartupError(f"record_dir {self.record_dir}: {one_line(e)}") from None
        elif self.record_dir.exists() and any(self.record_dir.iterdir()):
            raise StartupError(f"record_dir {self.record_dir} exists and is not a dataset "
                               f"(no {INDEX_FILE})")
        self.rec = TopicRecording()
        self.recording = False
        self.heard = dict.fromkeys(HEARD, 0)     # messages received per kind, recording or not
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import JointState

        from ..layout import TOPIC_JOINT_STATES, TOPIC_ODOM
        self.create_subscription(JointState, s["cmd_topic"],
                                 self._keep(self.rec.add_command, "command"), LIVE_QOS)
        self.create_subscription(JointState, TOPIC_JOINT_STATES,
                                 self._keep(self.rec.add_joint_state, "joint state"), LIVE_QOS)
        self.create_subscription(Odometry, TOPIC_ODOM,
                                 self._keep(self.rec.add_odometry, "odometry"), LIVE_QOS)
        self.create_service(SetBool, "~/record", self._on_record)
        self.create_service(Trigger, "~/train", self._on_train)
        self.get_logger().info(
            f"live: ~/record true|false records {TOPIC_JOINT_STATES}, {TOPIC_ODOM} and "
            f"{s['cmd_topic']} into {self.record_dir} ({len(self.entries)} moves there now); "
            f"~/train fits {s['method']} on them and writes {s['out']}")

    def _keep(self, add, what: str):
        def keep(msg) -> None:
            self.heard[what] += 1
            if not self.recording:
                return
            try:
                add(msg)
            except ValueError as e:
                self.get_logger().warning(f"ignored a {what}: {one_line(e)}",
                                          throttle_duration_sec=2.0)
        return keep

    def _on_record(self, request: SetBool.Request, response: SetBool.Response):
        if request.data:
            if self.recording:
                response.success, response.message = (False, f"already recording; "
                                                                  f"{heard_text(self.heard)}")
            else:
                self.rec.clear()
                self.recording = True
                response.success, response.message = True, "recording"
                self.get_logger().info("recording")
            return response
        if not self.recording:
            response.success, response.message = False, f"not recording; {heard_text(self.heard)}"
            return response
        try:
            response.message = self.stop_recording()
            response.success = True
        except (ValueError, OSError) as e:
            response.success, response.message = False, f"recording lost: {one_line(e)}"
            self.get_logger().error(response.message)
        return response

    def stop_recording(self) -> str:
        """Stop recording and write the recorded runs as moves ``U_NN`` of at most
        ``move_steps`` steps (shorter than MIN_MOVE_STEPS: left out) into ``record_dir``, each
        bag and then the index atomically; returns one line saying what was written."""
        from ..data.bags import move_type_from_name, write_bag
        from ..data.dataset import BagEntry, write_index
        from ..layout import UNKNOWN_MOVE_TYPE, bag_name

        self.recording = False
        written, short = [], 0
        numbers = [int(e.name.split("_")[1]) for e in self.entries
                   if move_type_from_name(e.name) == UNKNOWN_MOVE_TYPE]
        k = max(numbers, default=-1) + 1
        self.record_dir.mkdir(parents=True, exist_ok=True)
        for run in self.rec.runs(self.s["move_steps"]):
            if len(run) - 1 < MIN_MOVE_STEPS:
                short += 1
                continue
            name = bag_name(UNKNOWN_MOVE_TYPE, k)
            write_bag(self.record_dir / name,
                      move_recording(self.rec, run, name, UNKNOWN_MOVE_TYPE),
                      storage=self.s["storage"])
            self.entries.append(BagEntry(name, UNKNOWN_MOVE_TYPE, "train"))
            written.append(f"{name} ({len(run) - 1} steps)")
            k += 1
        what = self.rec.summary()
        self.rec.clear()
        if written:
            write_index(self.record_dir, self.entries,
                        info={"source": "trainer_node live recording",
                              "cmd_topic": self.s["cmd_topic"], "storage": self.s["storage"]})
        text = (f"recorded {', '.join(written) if written else 'nothing usable'} from {what}"
                + (f"; left out {short} run(s) shorter than {MIN_MOVE_STEPS} steps"
                   if short else "")
                + f"; {self.record_dir} holds {len(self.entries)} moves")
        self.get_logger().info(text)
        return text

    def _on_train(self, request: Trigger.Request, response: Trigger.Response):
        if self.recording:
            response.success, response.message = False, "recording: stop it first (~/record false)"
        elif not self.entries:
            response.success, response.message = False, (f"nothing recorded in "
                                                          f"{self.record_dir} yet")
        else:
            try:
                response.message = self.fit_and_save(dict(self.s))
                response.success = True
            except TrainingError as e:
                response.success, response.message = False, f"training failed, no model " \
                                                            f"written: {e}"
                self.get_logger().error(response.message)
        return response

    def _import(self, s: dict[str, Any]) -> tuple[str, str | None]:
        """Import ``bags`` into a dataset; (dataset path, temporary directory to remove)."""
        import tempfile
        from pathlib import Path

        from ..data.importer import import_bags

        log = self.get_logger()
        tmp = None
        if s["import_out"]:
            out = Path(s["import_out"])
        else:
            tmp = tempfile.mkdtemp(prefix="trainer_import.")
            out = Path(tmp) / "data"
        try:
            r = import_bags(s["bags"], out, s["import_options"])
        except BaseException:
            if tmp is not None:
                import shutil
                shutil.rmtree(tmp, ignore_errors=True)
            raise
        log.info(f"imported {r.n_moves} moves ({r.n_train} TrainPool / {r.n_test} TestPool) "
                 f"from {len(r.report['bags'])} bag(s), {r.n_messages} messages, into {out}")
        return str(out), tmp


def _import_options(text: str):
    """ImportOptions from the YAML mapping of the import_options parameter (StartupError)."""
    from dataclasses import fields

    from ..data.importer import ImportOptions

    try:
        d = yaml.safe_load(text) or {}
    except yaml.YAMLError as e:
        raise StartupError(f"import_options is not YAML: {one_line(e)}") from None
    if not isinstance(d, dict):
        raise StartupError("import_options must be a YAML mapping, e.g. \"{test_fraction: 0.0}\"")
    known = {f.name for f in fields(ImportOptions)}
    bad = sorted(set(d) - known)
    if bad:
        raise StartupError(f"unknown import option(s) {', '.join(bad)}; known: "
                           f"{', '.join(sorted(known))}")
    for k in ("cmd_joint_order", "move_types"):
        if k in d:
            d[k] = tuple(d[k]) if isinstance(d[k], (list, tuple)) else (d[k],)
    try:
        opts = ImportOptions(**d)
        opts.check()
    except (TypeError, ValueError) as e:
        raise StartupError(f"import_options: {one_line(e)}") from None
    return opts


class _LogLines:
    """A text stream that sends each complete line to a logger (the core prints progress)."""

    def __init__(self, log: Any) -> None:
        self.log, self.buf = log, ""

    def write(self, text: str) -> int:
        self.buf += text
        *lines, self.buf = self.buf.split("\n")
        for line in lines:
            if line.strip():
                self.log(line.rstrip())
        return len(text)

    def flush(self) -> None:
        pass


def main(args: Sequence[str] | None = None) -> int:
    # No rclpy signal handlers: SIGINT/SIGTERM must interrupt the fit (and end the live loop).
    return run_node(NODE_NAME, TrainerNode, TrainerNode.run, args,
                    failures={TrainingError: (1, "training failed, no model written: {}")},
                    interrupted=(130, "interrupted, no model written"))


if __name__ == "__main__":
    sys.exit(main())
