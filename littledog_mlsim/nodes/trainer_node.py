"""trainer_node: build a one-step model from a dataset of bags, one shot (CONTRACT.md section 6).

    trainer_node --ros-args -p data:=bags/default -p out:=/tmp/model -p method:=lr
    trainer_node --ros-args --params-file config/trainer.yaml -p method:=lgpr \
        -p method_params:="{cluster_size: 500, n_jobs: 2}"

Reads the dataset's bags of ``split`` (and ``types``) with ``load_moves``, forms the paper's
features and responses (``features_responses``), fits ``OneStepModel.fit(<method>(**params))``
and saves it with ``OneStepModel.save``, logging each stage (and every ``heartbeat`` seconds
while fitting). The save is atomic (``models.persistence``): an existing model at ``out`` is
replaced only by a complete new one; any failure (a bad bag, a bad parameter, a failing fit,
an interrupt) leaves it untouched. Exit status: 0 when the model is written, 1 when training
failed (one FATAL line), 2 for a bad parameter, 130 when interrupted.

One-shot: no ``~/train`` service; the node exits when the model is written. Parameters:
``config/trainer.yaml``.
"""
from __future__ import annotations

import signal
import sys
import threading
import time
from typing import Any, Sequence

import numpy as np
import rclpy
import yaml
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.exceptions import ParameterUninitializedException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions

from .simulator import Param, StartupError, load_config_defaults

NODE_NAME = "trainer_node"

PARAMS: tuple[Param, ...] = (
    Param("data", "", "dataset directory (bags + dataset.yaml) to train on (required)"),
    Param("out", "", "model directory to write (replaced atomically if it holds a model)"),
    Param("method", "lr", "regression method of the one-step model (models.persistence "
          "registry)", "lr | lwpr | gpr | sor | lgpr"),
    Param("method_params", "{}", "the method's hyperparameters as a YAML mapping, e.g. "
          "\"{cluster_size: 500, n_jobs: 2}\" (constructor arguments of the estimator)"),
    Param("target", "delta", "response the regressor learns: delta = s_{t+1} - s_t, next = "
          "s_{t+1}", "delta | next"),
    Param("split", "train", "bags to train on: the TrainPool (train), the TestPool (test) or "
          "both (all)", "train | test | all"),
    Param("types", Parameter.Type.STRING_ARRAY, "move types to train on (unset: all)"),
    Param("on_bad_bag", "fail", "fail: a bag that does not load fails the training; skip: it is "
          "left out with a warning", "fail | skip"),
    Param("max_samples", 0, "train on at most this many samples, a seeded random subset "
          "(0: all)", ">= 0"),
    Param("seed", 0, "seed of the random max_samples subset of the samples"),
    Param("heartbeat", 30.0, "seconds between 'still fitting' log lines (0: none)", ">= 0"),
)


class TrainingError(Exception):
    """Training failed (bad data, failing fit): one FATAL line, exit status 1."""


class TrainerNode(Node):
    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        defaults, self.config_path = load_config_defaults("trainer.yaml", NODE_NAME)
        unknown = sorted(set(defaults) - {p.name for p in PARAMS})
        if unknown:
            raise StartupError(f"{self.config_path}: unknown parameter(s) {', '.join(unknown)}")
        for p in PARAMS:
            value = defaults.get(p.name, p.default)
            if isinstance(p.default, float) and isinstance(value, int):
                value = float(value)
            try:
                self.declare_parameter(p.name, value, ParameterDescriptor(
                    description=p.description, read_only=True,
                    additional_constraints=p.constraints))
            except Exception as e:
                raise StartupError(f"parameter {p.name}: {' '.join(str(e).split())}") from None

    def param(self, name: str) -> Any:
        try:
            return self.get_parameter(name).value
        except ParameterUninitializedException:
            return None

    def settings(self) -> dict[str, Any]:
        """Parameters checked; StartupError (exit 2) on a bad one."""
        from ..models.onestep import TARGETS
        from ..models.persistence import ModelError, get_method

        s = {p.name: self.param(p.name) for p in PARAMS}
        if not s["data"] or not s["out"]:
            raise StartupError("set the parameters data (dataset directory) and out (model "
                               "directory)")
        try:
            s["estimator_class"] = get_method(s["method"])
        except ModelError as e:
            raise StartupError(str(e)) from None
        try:
            params = yaml.safe_load(s["method_params"]) or {}
        except yaml.YAMLError as e:
            raise StartupError(f"method_params is not YAML: {' '.join(str(e).split())}") from None
        if not isinstance(params, dict):
            raise StartupError("method_params must be a YAML mapping, e.g. \"{max_iter: 50}\"")
        s["method_params"] = params
        if s["target"] not in TARGETS:
            raise StartupError(f"target must be one of {', '.join(TARGETS)}")
        if s["split"] not in ("train", "test", "all"):
            raise StartupError("split must be train, test or all")
        if s["on_bad_bag"] not in ("fail", "skip"):
            raise StartupError("on_bad_bag must be fail or skip")
        if s["max_samples"] < 0 or s["heartbeat"] < 0:
            raise StartupError("max_samples and heartbeat must be >= 0")
        return s

    def train(self) -> None:
        """Load, fit, save; TrainingError on any failure (nothing written then)."""
        import warnings

        from ..data.dataset import features_responses, load_moves
        from ..models.onestep import OneStepModel

        s = self.settings()
        log = self.get_logger()
        try:
            estimator = s["estimator_class"](**s["method_params"])
        except (TypeError, ValueError) as e:
            raise StartupError(f"{s['method']}(**method_params): {e}") from None

        t0 = time.perf_counter()
        log.info(f"loading the {s['split']} bags of {s['data']}"
                 + (f" (types {','.join(s['types'])})" if s["types"] else ""))
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                moves = load_moves(s["data"], split=s["split"], types=s["types"],
                                   on_error="raise" if s["on_bad_bag"] == "fail" else "skip")
            for w in caught:
                log.warning(str(w.message))
            X, Y, _ = features_responses(moves)
        except (ValueError, OSError) as e:   # DatasetError, BagError are ValueErrors
            raise TrainingError(_one_line(e)) from None
        n_all = X.shape[0]
        if s["max_samples"] and n_all > s["max_samples"]:
            rows = np.sort(np.random.default_rng(s["seed"]).choice(
                n_all, size=s["max_samples"], replace=False))
            X, Y = X[rows], Y[rows]
        log.info(f"{len(moves)} moves, {X.shape[0]} samples"
                 + (f" (of {n_all})" if X.shape[0] < n_all else "")
                 + f" loaded in {time.perf_counter() - t0:.1f} s; fitting {s['method']} "
                 f"{s['method_params'] or ''}".rstrip())

        done = threading.Event()
        t1 = time.perf_counter()
        if s["heartbeat"] > 0:
            def beat() -> None:
                while not done.wait(s["heartbeat"]):
                    log.info(f"still fitting {s['method']} ({time.perf_counter() - t1:.0f} s)")
            threading.Thread(target=beat, daemon=True).start()
        try:
            model = OneStepModel.fit(
                estimator, X, Y, target=s["target"],
                info={"trained_by": NODE_NAME, "data": str(s["data"]), "split": s["split"],
                      "types": list(s["types"] or []), "n_moves": len(moves)})
        except (ValueError, np.linalg.LinAlgError, MemoryError) as e:
            raise TrainingError(f"fitting {s['method']} failed: {_one_line(e)}") from None
        finally:
            done.set()
        log.info(f"fitted in {time.perf_counter() - t1:.1f} s; writing {s['out']}")
        try:
            model.save(s["out"])
        except (ValueError, OSError) as e:   # ModelError is a ValueError
            raise TrainingError(f"cannot write the model: {_one_line(e)}") from None
        log.info(f"wrote {s['method']} model to {s['out']} "
                 f"({time.perf_counter() - t0:.1f} s in all)")


def _one_line(e: BaseException) -> str:
    text = " ".join(str(e).split())
    return text or type(e).__name__


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def main(args: Sequence[str] | None = None) -> int:
    # No rclpy signal handlers: nothing spins here, so SIGINT/SIGTERM must interrupt the fit.
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except Exception as e:  # rcl refuses the command line (e.g. an unparsable -p override)
        print(f"{NODE_NAME}: error: {_one_line(e)}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGTERM, _interrupt)
    logger = rclpy.logging.get_logger(NODE_NAME)
    node = None
    status = 0
    try:
        node = TrainerNode()
        node.train()
    except StartupError as e:
        logger.fatal(_one_line(e))
        status = 2
    except TrainingError as e:
        logger.fatal(f"training failed, no model written: {e}")
        status = 1
    except KeyboardInterrupt:
        logger.fatal("interrupted, no model written")
        status = 130
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return status


if __name__ == "__main__":
    sys.exit(main())
