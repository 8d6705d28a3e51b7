"""A reference recorded under another command excitation than the data (``diagnose/
conditions.py``, decision 031): which comparisons still hold, and the report's side of those
that do not (the end-to-end case is in ``test_learned.py``)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from littledog_mlsim.diagnose.conditions import Conditions, cannot_contrast, conditions_of
from littledog_mlsim.models.feature_library import (CommandFilter, CommandLag, ElapsedTime,
                                                    ElapsedTracking, GaitPhase, Heading,
                                                    JointRateMagnitude, JointRateSign, Play,
                                                    PlanarPosition, StateLag, SwingRate,
                                                    TrackingSaturation)


def test_a_recording_that_names_no_excitation_was_made_without():
    c = conditions_of({}, {"command_excitation_rad": None})
    assert (c.data_excitation_rad, c.reference_excitation_rad, c.comparable) == (0.0, 0.0, True)
    assert c.to_dict() == {"data_excitation_rad": 0.0, "reference_excitation_rad": 0.0,
                           "comparable": True}
    c = conditions_of({"command_excitation_rad": 0.05}, {})
    assert not c.comparable
    d = c.to_dict()
    assert d["recording"] == ("record the reference the way the data were recorded: with "
                              "command excitation (record --excitation 0.05)")
    assert "with command excitation 0 rad and the data with 0.05 rad" in d["statement"]
    # the other way round: an excited reference, data without
    assert Conditions(0.0, 0.05).recording.endswith("without command excitation (record "
                                                    "without --excitation)")


@pytest.mark.parametrize("bad", ["abc", -0.01, math.nan, math.inf, [0.05]])
def test_an_excitation_that_is_not_a_number_is_refused_naming_the_dataset(bad):
    with pytest.raises(ValueError, match=r"^reference /r: dataset.yaml's "
                                         r"command_excitation_rad ") as e:
        conditions_of({}, {"command_excitation_rad": bad}, "data", "reference /r")
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match="data_excitation_rad must be a finite number"):
        Conditions(math.nan, 0.0)


def test_only_the_joints_own_command_response_cannot_be_contrasted():
    """Families whose columns are the joints' commands and states (their history or a
    nonlinear function of them) cannot be contrasted across excitations; heading, position,
    time, phase and swing can, and with the same excitation everything can."""
    differ, same = Conditions(0.05, 0.0), Conditions(0.05, 0.05)
    shown = [CommandLag(lag=2), CommandFilter(time_constant_ms=30.0), Play(width=0.01),
             StateLag(lag=3), JointRateSign(), JointRateMagnitude(), TrackingSaturation()]
    others = [Heading(), PlanarPosition(), ElapsedTime(), ElapsedTracking(),
              GaitPhase(quarter_lag=9), SwingRate()]
    assert [cannot_contrast(a, differ) for a in shown] == [True] * len(shown)
    assert [cannot_contrast(a, differ) for a in others] == [False] * len(others)
    assert not any(cannot_contrast(a, same) or cannot_contrast(a, None) for a in shown)


def _one_step_effect(aug, round_: int) -> dict:
    from littledog_mlsim.diagnose.families.learned import physical_reading
    return {"round": round_, "label": aug.label(), "family": aug.family, "p_value": 1e-9,
            "physical": physical_reading(aug)}


def test_the_one_step_loops_command_response_against_another_excitation_is_not_a_change():
    """``report._not_comparable``: with the reference recorded under another excitation, the
    one-step loop's lagged state and play move from ``effects`` to ``not_comparable`` and
    ``suspected`` (why, and the recording that settles it); a heading effect stays, and so
    does ``significant``; with nothing left it is false."""
    from littledog_mlsim.diagnose.report import _not_comparable
    lag, play, heading = StateLag(lag=3), Play(width=0.01), Heading()
    cond = Conditions(0.05, 0.0)
    doc = {"effects": [_one_step_effect(a, k + 1) for k, a in enumerate((lag, heading, play))],
           "significant": True, "suspected": []}
    _not_comparable(doc, cond.to_dict())
    assert [e["label"] for e in doc["effects"]] == [heading.label()] and doc["significant"]
    assert [e["label"] for e in doc["not_comparable"]] == [lag.label(), play.label()]
    assert [(s["label"], s["family"], s["scope"]) for s in doc["suspected"]] == [
        (lag.label(), "other", "body"), (play.label(), "backlash", "all")]
    assert all(s["why"] == cond.why and s["recording"] == cond.recording
               for s in doc["suspected"] + doc["not_comparable"])
    doc = {"effects": [_one_step_effect(lag, 1)], "significant": True, "suspected": []}
    _not_comparable(doc, cond.to_dict())
    assert doc["effects"] == [] and doc["significant"] is False


def test_a_reading_against_another_excitation_is_kept_but_neither_significant_nor_named():
    """``learned._not_compared`` on decision 026's and 027's readings."""
    from littledog_mlsim.diagnose.learned import _not_compared
    cond = Conditions(0.05, 0.0)
    reading = {"significant": True, "named": True, "ratio": 1.51, "statement": "a change"}
    out = _not_compared(reading, cond)
    assert (out["significant"], out["named"], out["comparable"], out["ratio"]) == (
        False, False, False, 1.51)
    assert out["statement"].startswith("not compared: the reference was recorded with ")
    assert out["statement"].endswith("(as measured: a change)")
    assert out["recording"] == cond.recording
    assert "named" not in _not_compared({"significant": True, "statement": ""}, cond)


def test_a_reading_concentrated_at_a_joint_scope_is_compared_across_excitations():
    """Decisions 033 and 064: decision 026's reading across excitations counts where it
    concentrates at one joint that also stands out of its type's other joints, one leg or one
    side; spread over the joints, on the body, at a joint type however concentrated, or at a
    joint its type's others share, it does not."""
    from littledog_mlsim.diagnose.excess import CONCENTRATION
    from littledog_mlsim.diagnose.learned import (_compared_where_concentrated,
                                                  concentrated_at_joints, over_type_mates)
    cond = Conditions(0.05, 0.0)
    mates = {"joint:front_left_knee": 6.0, "joint:front_right_knee": 1.0,
             "joint:back_left_knee": 2.0, "joint:back_right_knee": 3.0}
    knee = {"significant": True, "ratio": 1.87, "scope": "joint:front_left_knee",
            "concentration": 3.51, "statement": "a change", "recording": "r",
            "scope_ratios": mates}
    assert concentrated_at_joints(knee) and over_type_mates(knee, "front_left_knee") == 3.0
    # the other knees share it (the twin's per-type error under excitation), or the reading
    # does not give them: not counted
    shared = {**mates, "joint:front_right_knee": 4.0, "joint:back_left_knee": 4.0,
              "joint:back_right_knee": 4.0}
    assert over_type_mates({**knee, "scope_ratios": shared}, "front_left_knee") == 1.5
    assert not concentrated_at_joints({**knee, "scope_ratios": shared})
    assert not concentrated_at_joints({k: v for k, v in knee.items() if k != "scope_ratios"})
    assert np.isnan(over_type_mates(knee, "front_knee"))
    assert not concentrated_at_joints({**knee, "concentration": None})
    for scope in ("leg:front_left", "side:right"):
        assert concentrated_at_joints({**knee, "scope": scope})
    for scope, conc in (("all", 1.0), ("body", 2.5), ("type:knees", CONCENTRATION - 0.01),
                        ("type:knees", 2.04), ("type:hip_rolls", 10.0)):
        assert not concentrated_at_joints({**knee, "scope": scope, "concentration": conc})
    out = _compared_where_concentrated(knee, cond)
    assert (out["significant"], out["comparable"], out["concentrated"], out["ratio"],
            out["scope"]) == (True, False, True, 1.87, "joint:front_left_knee")
    assert "front-left knee" in out["statement"] and out["statement"].endswith(": a change")
    assert out["statement"].startswith(cond.recorded + ", but the change concentrates")
    quiet = _compared_where_concentrated({**knee, "significant": False}, cond)
    assert quiet["significant"] is False
