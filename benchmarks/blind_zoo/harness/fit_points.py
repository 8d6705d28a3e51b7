"""A calibrated twin file read back as the points a study of its fit compares.

``calibrate --bootstrap`` writes the corrected twin; its report keeps the fit's own values
(``bootstrap.params.*.fitted``). Studies of a calibration (``zoos/*/runs/after_run1/``) cost
the fit's optimum, the corrected twin and the gap robot on the fit's own residuals; this reads
them once:

    from fit_points import fit_points        # with this directory on sys.path
    pts = fit_points("TWIN.json", "GAP_ROBOT.json")
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from littledog_mlsim.robot.config import RobotConfig
from littledog_mlsim.robot.parameters import twin_parameters
from littledog_mlsim.robot.twin import load_twin


@dataclass(frozen=True)
class FitPoints:
    """``names``: the fitted parameters; ``settings``: the calibration's; ``final``: the twin as
    written, ``fit``: the same with the fitted parameters at the fit's optimum (before the
    bootstrap), ``gap``: the gap robot (None if not given); all without sensor noise."""

    names: list[str]
    settings: dict[str, Any]
    final: RobotConfig
    fit: RobotConfig
    gap: RobotConfig | None


def fit_points(twin_path: str, gap_path: str | None = None) -> FitPoints:
    twin = load_twin(twin_path)
    cal = twin.provenance["calibration"]
    fitted = {n: p["fitted"] for n, p in (cal.get("bootstrap") or {}).get("params", {}).items()}
    final = replace(twin.robot, sensor_noise=False)
    names = list(twin.provenance["parameters"])
    fit = final
    for p in twin_parameters(names, final):
        if p.name in fitted:
            fit = p.set(fit, fitted[p.name])
    gap = None if gap_path is None else replace(load_twin(gap_path).robot, sensor_noise=False)
    return FitPoints(names, dict(cal["settings"]), final, fit, gap)
