"""The one-step loop's findings read against a reference (``diagnose/one_step_contrast.py``,
decisions 041 and 042): the contrast of each move's held-out contribution, the report's
``shared``, and end to end on recordings whose robot has a set-point delay of its own, in the
reference too."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from littledog_mlsim.diagnose.learned import SCOPES, scope_elements
from littledog_mlsim.diagnose.one_step_contrast import contrast_findings, contrast_one_step
from littledog_mlsim.models.feature_library import CommandLag, JointRateMagnitude, Play


class _OnRef:
    """The reference's screen as :func:`contrast_one_step` reads it."""

    def __init__(self, d: np.ndarray) -> None:
        self.d, self.gain = d, d.mean(axis=0)
        self.p_value, self.significant = 0.5, False


def _cuts(rng, n: int, per_element: float, elements=None) -> np.ndarray:
    d = rng.normal(0.0, 0.02, (n, 33))
    cols = list(range(33)) if elements is None else list(elements)
    d[:, cols] += per_element
    return d


def test_an_effect_the_reference_shows_as_much_is_not_a_change():
    rng = np.random.default_rng(0)
    aug = JointRateMagnitude(kind="quadratic")
    d, d_ref = _cuts(rng, 77, 0.08), _cuts(rng, 77, 0.08)
    c = contrast_one_step(aug, d, _OnRef(d_ref), 1)
    assert not c.changed and c.p_focus is None and c.p_change == c.p_state > 0.01, c
    assert c.total_gain == pytest.approx(d.mean(axis=0).sum())
    assert c.reference_total_gain == pytest.approx(d_ref.mean(axis=0).sum())
    # the same cuts on the data, none on the reference: a change
    d_none = _cuts(rng, 77, 0.0)
    c = contrast_one_step(aug, d, _OnRef(d_none), 1)
    assert c.changed and c.p_change < 1e-6, c
    assert set(c.to_dict()) == {"total_gain", "reference_total_gain", "reference_p_value",
                                "reference_significant", "p_state", "p_change", "n_contrasts",
                                "max_excess", "changed"}


def test_a_change_must_be_at_least_half_new():
    """Decision 042. Two recordings of one robot: the data gain 0.03 more on every element than
    the reference (0.08 against 0.05), which 77 moves a side make significant, but the
    reference gains more than half as much: not a change. A change spread thinly over every
    element (0.02 each, none on the reference) is one, though no element gains 5 % more."""
    rng = np.random.default_rng(2)
    aug = JointRateMagnitude(kind="quadratic")
    d, d_ref = _cuts(rng, 77, 0.08), _cuts(rng, 77, 0.05)
    c = contrast_one_step(aug, d, _OnRef(d_ref), 1)
    assert c.p_change < 1e-6 and c.reference_total_gain > 0.5 * c.total_gain, c
    assert not c.changed
    assert contrast_one_step(aug, d, _OnRef(d_ref), 1,
                             new_share=0.7).changed
    spread, none = _cuts(rng, 77, 0.02), _cuts(rng, 77, 0.0)
    c = contrast_one_step(aug, spread, _OnRef(none), 1)
    assert c.changed and c.max_excess < 0.05, c


def test_a_one_leg_change_is_read_on_its_joints_and_pays_for_the_scopes():
    """A cut on one leg's q and dq alone, diluted in the sum over 33 elements by noise on the
    others, is a change through the focus test; ``p_change`` is 2 min(p_state, 9 p_focus)."""
    rng = np.random.default_rng(1)
    aug = CommandLag(lag=2, joints="back_left")
    focus = scope_elements(aug)
    others = [j for j in range(33) if j not in focus]
    d, d_ref = rng.normal(0.0, 0.05, (40, 33)), rng.normal(0.0, 0.05, (40, 33))
    d[:, others] *= 4.0
    d_ref[:, others] *= 4.0
    d[:, focus] += 0.15
    c = contrast_one_step(aug, d, _OnRef(d_ref), 2)
    assert c.focus_choices == len(SCOPES) and c.p_focus is not None
    assert c.p_change == pytest.approx(min(1.0, 2 * min(c.p_state, len(SCOPES) * c.p_focus)))
    assert c.changed and c.p_focus < c.p_state, c
    assert {"p_focus", "focus_choices"} <= set(c.to_dict())
    # the Bonferroni over the effects contrasted decides a borderline case
    assert c.changed == (min(1.0, 2 * c.p_change) < 0.01)
    # a play band scoped by its columns was chosen among 21 joint groups (decision 065)
    play = contrast_one_step(Play(width=0.05, source="u", joints="back_left"), d,
                             _OnRef(d_ref), 2)
    assert play.focus_choices == 21
    assert play.p_change == pytest.approx(min(1.0, 2 * min(play.p_state, 21 * play.p_focus)))


def test_the_report_moves_what_the_reference_shows_as_much_to_shared():
    """``report._shared``: an effect whose contrast is not changed leaves ``effects`` for
    ``shared``; an effect without a contrast (decision 031 did not contrast it) stays."""
    from littledog_mlsim.diagnose.report import _shared
    own = {"label": "own", "reference": {"changed": False}}
    new = {"label": "new", "reference": {"changed": True}}
    kept = {"label": "not contrasted"}
    doc = {"effects": [own, new, kept], "significant": True}
    _shared(doc)
    assert [e["label"] for e in doc["effects"]] == ["new", "not contrasted"]
    assert doc["shared"] == [own] and doc["significant"]
    doc = {"effects": [own], "significant": True}
    _shared(doc)
    assert doc == {"effects": [], "significant": False, "shared": [own]}


def _record(root: Path, name: str, seed: int, effects: str) -> Path:
    """Moves 0-3 of each type: the TrainPool of 6 moves per type (the test reads only the
    TrainPool; a move's recording depends only on its type, number, seed and effects, so the
    TestPool moves are not recorded)."""
    from littledog_mlsim.apps.record import record_dataset
    f = root / f"{name}.yaml"
    f.write_text(effects)
    out = root / name
    record_dataset(out, moves_per_type=4, seed=seed, types=["F", "L", "R", "DL", "S"], jobs=2,
                   progress=False, effects_file=str(f))
    return out


DELAY = ("- class: littledog_mlsim.robot.effects:SetpointDelay\n"
         "  params: {delay_ms: 30.0}\n")


@pytest.fixture(scope="module")
def delayed(tmp_path_factory):
    root = tmp_path_factory.mktemp("one_step_contrast")
    return {"root": root, "data": _record(root, "data", 431, DELAY),
            "reference": _record(root, "reference", 437, DELAY)}


def test_the_robots_own_delay_is_shared_and_a_new_one_is_a_change(delayed):
    """The one-step loop finds a command lag on data whose robot's set-points arrive 30 ms
    late; the reference recorded with the same delay gains as much from it (not a change), a
    reference without the delay does not (a change)."""
    from littledog_mlsim.data.dataset import load_moves
    from littledog_mlsim.diagnose import SearchModel, select_effects
    search = SearchModel(n_random_features=300, n_gp_points=300, gp_max_iter=30)
    train = load_moves(delayed["data"], "all")
    library = [CommandLag(lag=k) for k in (1, 2, 3, 4)] + [JointRateMagnitude(kind="abs")]
    sel = select_effects(train, library=library, search=search, max_rounds=1)
    (picked,) = sel.accepted
    assert picked.augmentation.family == "command delay", picked.label
    (own,) = contrast_findings(sel, load_moves(delayed["reference"], "all"), search)
    assert not own.changed and own.reference_total_gain > 0.5 * own.total_gain, own
    clean = _record(delayed["root"], "clean", 437, "[]\n")
    (new,) = contrast_findings(sel, load_moves(clean, "all"), search)
    assert new.changed and new.reference_total_gain < 0.5 * new.total_gain, new
    (skipped,) = contrast_findings(sel, [], search, skip=lambda aug: True)
    assert skipped is None
