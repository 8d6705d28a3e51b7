"""What the three checks share: run4's twin as fitted before its bootstrap, zoo32's gap robot,
and the 22 TrainPool moves run4 fitted, read from REFERENCE."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

HERE = Path(__file__).resolve().parent
ZOO = HERE.parents[1]


def run4_case(ref: str, run: str | Path | None = None, gap: str | Path | None = None
              ) -> SimpleNamespace:
    """``twin`` (run4's file), ``cal`` (its calibration report), ``boot`` (its bootstrap's
    parameters), ``params`` (the 15 fitted), ``fit`` (the twin at the values fitted before the
    bootstrap), ``gap`` (the gap robot) and ``train`` (the fitted moves of ``ref``). ``run``
    and ``gap``: another run's directory (its ``calibrated_twin.json``) and gap robot file."""
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.robot.parameters import twin_parameters
    from littledog_mlsim.robot.twin import load_twin

    twin = load_twin(Path(run or HERE.parent / "run4_bootstrap2") / "calibrated_twin.json")
    cal = twin.provenance["calibration"]
    boot = cal["bootstrap"]["params"]
    fit = twin.robot
    params = twin_parameters(list(boot), fit)
    for p in params:
        fit = p.set(fit, boot[p.name]["fitted"])
    train = [r for r in load_moves(ref, "train") if r.name in set(cal["train_moves"])]
    return SimpleNamespace(twin=twin, cal=cal, boot=boot, params=params, fit=fit,
                           gap=load_twin(gap or ZOO / "gap_robot.json").robot, train=train)
