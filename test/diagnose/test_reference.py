"""The diagnosis of recordings whose robot it does not know exactly: imported bags, and a clean
reference recording (``--reference``) that cancels what the twin gets wrong.

- An imported recording (written as ``ros2 bag record`` writes it, ``data.realstyle``, and
  imported) names no robot: the diagnosis takes the learned route and says why.
- "What changed since the reference?": the robot's set-points have arrived 15 ms late all
  along, in the reference too; the twin (``measured``) knows nothing of it. The data add a
  softer front-left knee (60 % stiffness). The delay is the twin's error that the reference
  shares: it is absorbed (``physics.reference.twin_errors``), and the knee is the finding
  (here the first round's other fitted hypothesis: a change since the reference, fitted
  again on the base with the delay, ``driver._changed_alternative``). Two families, the
  delay and the servo gain: a body family's fit re-simulates 4 s replays, and the tether
  case below takes about 2.4 times as long (``benchmarks/ci_time/reference_case``).
- The same with a tether (a 3 N force fixed in odom) as the shared twin error and the five
  families below, among them the tether's rivals (a slope, a body wrench), is ``-m slow``; so
  is clean data with the tether against the same reference, which raise no alarm.

Small versions of the benchmark (``benchmarks/blind_zoo``, zoo8): 4 moves of each of 5 move
types (of 4 types for the shared delay, make test's case), a short family list, two
hypotheses fitted per round, LR as the report model.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from littledog_mlsim.diagnose import SearchModel, diagnose

TYPES = ["F", "L", "R", "DL", "S"]
DELAY_TYPES = ["F", "L", "R", "S"]     # make test's case: about half the time of 5 types
FAMILIES = ["command_delay", "servo_gain", "odom_force", "ground_slope", "body_wrench"]
JOINT_FAMILIES = ["command_delay", "servo_gain"]
PHYS = dict(fit_per_type=1, validate_per_type=2, test_per_type=1, screen_moves=3, n_refine=2,
            families=FAMILIES)
DELAY = ("- class: littledog_mlsim.robot.effects:SetpointDelay\n"
         "  params: {delay_ms: 15.0}\n")
TETHER = ("- class: littledog_mlsim.robot.effects:ConstantWind\n"
          "  params: {force_xy: [0.0, 3.0]}\n")
SOFT_KNEE = ("- class: littledog_mlsim.robot.effects:ServoGain\n"
             "  params: {gain_ratio: 0.6, joints: front_left_knee}\n")


def _record(root: Path, name: str, seed: int, effects: str, moves: int = 4,
            types=TYPES) -> Path:
    from littledog_mlsim.apps.record import record_dataset
    effects_file = root / f"{name}.yaml"
    effects_file.write_text(effects)
    out = root / name
    record_dataset(out, moves_per_type=moves, seed=seed, types=types, jobs=2, progress=False,
                   effects_file=str(effects_file))
    return out


@pytest.fixture(scope="module")
def delayed(tmp_path_factory):
    root = tmp_path_factory.mktemp("reference_delay")
    return {"root": root, "types": DELAY_TYPES,
            "reference": _record(root, "reference", 411, DELAY, types=DELAY_TYPES),
            "changed": _record(root, "changed", 412, DELAY + SOFT_KNEE, types=DELAY_TYPES)}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    root = tmp_path_factory.mktemp("reference")
    return {"root": root, "types": TYPES, "reference": _record(root, "reference", 411, TETHER),
            "changed": _record(root, "changed", 412, TETHER + SOFT_KNEE)}


def test_an_imported_recording_takes_the_learned_route_and_says_why(tmp_path):
    from littledog_mlsim.data.dataset import load_moves, read_index
    from littledog_mlsim.data.importer import ImportOptions, import_bags
    from littledog_mlsim.data.realstyle import RealStyle, write_realstyle_bag
    src = _record(tmp_path, "src", 401, TETHER, moves=2)
    bag = tmp_path / "rec.mcap"
    write_realstyle_bag(bag, load_moves(src, "all"), RealStyle(seed=401))
    data = tmp_path / "imported"
    import_bags([bag], data, ImportOptions(test_fraction=0.3))
    assert "robot" not in read_index(data).info
    report = diagnose(data, tmp_path / "out", method="lr",
                      search=SearchModel(n_gp_points=300, gp_max_iter=40), figures=False,
                      progress=False, max_rounds=1)
    assert report["route"]["name"] == "learned"
    assert "an imported recording" in report["route"]["why"]
    assert report["before"]["nmse_mean"] is not None
    assert (tmp_path / "out" / "report.json").is_file()


def _shared_absorbed_and_knee_named(data: dict, twin_family: str, scope: str, param: str,
                                    truth: float, **physics) -> None:
    """Diagnose ``data["changed"]`` against ``data["reference"]``: the shared twin error
    (``twin_family`` at ``scope``, ``param`` near ``truth``) is absorbed, no change; the soft
    front-left knee is the finding, a change; nothing is left."""
    report = diagnose(data["changed"], data["root"] / "changed_out", method="lr",
                      figures=False, progress=False, twin="measured",
                      reference=data["reference"], physics_options={**PHYS, **physics})
    route = report["route"]
    assert route["name"] == "physical" and route["robot"] == "measured"
    assert route["reference"] == str(data["reference"]) and "reference" in route["why"]
    ref = report["physics"]["reference"]
    assert ref["n_moves"] == len(ref["moves"]) == 2 * len(data["types"]), ref
    shared = [t for t in ref["twin_errors"] if t["family"] == twin_family]
    assert shared and shared[0]["scope"] == scope and not shared[0]["changed"], ref["twin_errors"]
    assert shared[0]["params"][param] == pytest.approx(truth, rel=0.25), shared
    assert report["significant"], report["physics"]["rejected"]
    ph = report["effects"][0]["physical"]
    assert (ph["family"], ph["scope"]) == ("servo_gain", "joint:front_left_knee"), ph
    assert ph["params"]["gain_ratio"] == pytest.approx(0.6, rel=0.25), ph
    check = report["effects"][0]["evidence"]["reference_check"]
    assert check["changed"] and check["data_move_cut"] > 2 * check["reference_move_cut"]
    assert not (ref["unexplained"]["significant"] and ref["unexplained"]["material"]), ref
    assert "remainder" not in report["effects"][0] and "stand_in" not in report["effects"][0]


def test_a_shared_delay_is_absorbed_and_the_soft_knee_is_named(delayed):
    _shared_absorbed_and_knee_named(delayed, "command_delay", "all", "delay_ms", 15.0,
                                    families=JOINT_FAMILIES)


def test_the_physical_route_gets_the_references_excitation(delayed, tmp_path, monkeypatch):
    """Decision 052's wiring: ``diagnose --reference`` hands the physical route the data's and
    the reference's command excitation, each read from its ``dataset.yaml``."""
    import shutil
    import yaml
    from littledog_mlsim.diagnose import physical

    class Seen(Exception):
        pass

    def seen(train, test, options, **kw):
        raise Seen(options)
    data = tmp_path / "excited"
    shutil.copytree(delayed["changed"], data)
    index = yaml.safe_load((data / "dataset.yaml").read_text())
    index["info"]["command_excitation_rad"] = 0.05
    (data / "dataset.yaml").write_text(yaml.safe_dump(index, sort_keys=False))
    monkeypatch.setattr(physical, "identify", seen)
    with pytest.raises(Seen) as got:
        diagnose(data, tmp_path / "out", method="lr", figures=False, progress=False,
                 twin="measured", reference=delayed["reference"], physics_options=PHYS)
    (options,) = got.value.args
    assert options.excitation == 0.05 and options.reference_excitation == 0.0


@pytest.mark.slow   # make test runs the case above: a shared delay, two families
def test_what_the_reference_shares_is_absorbed_and_the_change_is_named(recorded):
    _shared_absorbed_and_knee_named(recorded, "odom_force", "body", "force_N", 3.0)


@pytest.mark.slow
def test_clean_data_against_its_reference_raise_no_alarm(recorded):
    clean = _record(recorded["root"], "clean", 413, TETHER)
    report = diagnose(clean, recorded["root"] / "clean_out", method="lr",
                      figures=False, progress=False, twin="measured",
                      reference=recorded["reference"], physics_options=PHYS)
    assert report["significant"] is False and report["effects"] == [], report["effects"]
    left = report["physics"]["reference"]["unexplained"]
    assert not (left["significant"] and left["material"]), left


# ------------------------------------------------------------------- the decisions, stand-ins


class _Ctx:
    """A stand-in search context: per-move channel errors of the base and of a hypothesis."""

    def __init__(self, base: dict, with_h: dict) -> None:
        self.base, self.with_h = base, with_h

    @staticmethod
    def _err(v: float) -> dict:
        import numpy as np
        return {"short": np.full((1, 1, 18), np.sqrt(v)), "long": np.full((1, 18), np.sqrt(v))}

    def sse(self, hyp, moves):
        import numpy as np
        from littledog_mlsim.diagnose.physical.channels import sse
        return np.array([sse(self._err(self.base[i])) for i in moves])

    def run(self, hyps, moves):
        return [[self._err(self.with_h[i]) for i in moves] for _ in hyps]


def _held(ctx: _Ctx, V):
    import numpy as np
    from littledog_mlsim.diagnose.physical.records import HeldOutDecision
    S0 = ctx.sse(None, V)
    S1 = np.array([S0[k] * ctx.with_h[i] / ctx.base[i] for k, i in enumerate(V)])
    return HeldOutDecision((), 1, S0, (S1,), (), (0.0,), 0)


class _Sse:
    """A stand-in context whose per-move, per-channel SSE is the rows of ``S``."""

    def __init__(self, S):
        self.S = S

    def sse(self, hyp, moves):
        return self.S[list(moves)]


def test_reference_check_tells_a_change_from_a_twin_error():
    from types import SimpleNamespace
    from littledog_mlsim.diagnose.physical.driver import reference_check
    V, R = list(range(8)), list(range(8, 16))
    fin = SimpleNamespace(hyp=None)
    rng = __import__("numpy").random.default_rng(0)
    base = {i: 1.0 + 0.1 * rng.random() for i in V + R}
    # the hypothesis halves the error on the data's moves and on the reference's: shared
    shared = _Ctx(base, {i: 0.5 * base[i] for i in V + R})
    c = reference_check(shared, fin, _held(shared, V), R, 0.01)
    assert not c["changed"] and c["reference_move_cut"] > 0.5 * c["data_move_cut"]
    # it halves the data's error and leaves the reference's: a change
    change = _Ctx(base, {**{i: 0.5 * base[i] for i in V}, **{i: base[i] for i in R}})
    c = reference_check(change, fin, _held(change, V), R, 0.01)
    assert c["changed"] and c["p_value"] < 0.01 and c["reference_move_cut"] == 0.0


def test_what_is_left_is_unexplained_only_if_the_data_exceed_the_reference():
    from littledog_mlsim.diagnose.physical.driver import unexplained
    V, R = list(range(8)), list(range(8, 16))
    rng = __import__("numpy").random.default_rng(1)
    same = _Ctx({i: 1.0 + 0.2 * rng.random() for i in V + R}, {})
    left = unexplained(same, V, R, 0.01)
    assert not (left["significant"] and left["material"]), left
    worse = _Ctx({**{i: 2.0 + 0.2 * rng.random() for i in V},
                  **{i: 1.0 + 0.2 * rng.random() for i in R}}, {})
    left = unexplained(worse, V, R, 0.01)
    assert left["significant"] and left["material"] and left["pooled_ratio"] > 1.7, left
    assert len(left["channels"]) == 8 and left["channels"][0]["ratio"] > 1.7



def test_a_difference_in_one_channel_is_left_even_if_the_pooled_ratio_hides_it():
    """The reference route stops once nothing is left against the reference; a change that
    lives in one channel of 36 must still count as left (``channel_significant``)."""
    import numpy as np
    from littledog_mlsim.diagnose.physical.driver import unexplained
    V, R = list(range(12)), list(range(12, 24))
    rng = np.random.default_rng(2)   # each move's own scale times each channel's scatter
    S = np.exp(rng.normal(0.0, 0.5, (24, 1)) + rng.normal(0.0, 0.3, (24, 36)))

    left = unexplained(_Sse(S), V, R, 0.01)
    assert not left["significant"] and not left["channel_significant"], left
    one = S.copy()
    one[:12, 5] *= 6.0
    left = unexplained(_Sse(one), V, R, 0.01)
    assert not left["significant"], left
    assert left["channel_significant"] and left["channel_p_value"] < 0.01, left
    assert left["channels"][0]["ratio"] > 3, left

def test_a_move_cut_a_few_steps_short_keeps_four_segments():
    """An imported move is often a few steps shorter than 4 s: its last 1 s segment starts
    earlier; a move shorter than 3 s is left out of the physical route."""
    from littledog_mlsim.diagnose.physical.channels import MIN_STEPS, measured, seg_starts
    from synthetic import make_recording
    assert seg_starts(400) == (0, 100, 200, 300) and seg_starts(398) == (0, 100, 200, 298)
    rec = make_recording("F_00", n=398)
    assert rec.n_steps == 398
    m = measured(rec)
    assert m.segs.shape == (4, 100, 18) and m.full.shape == (398, 18)
    assert (m.segs[3][-1] == m.full[-1]).all()
    with pytest.raises(ValueError, match=f"shorter than the physical route's {MIN_STEPS}"):
        seg_starts(MIN_STEPS - 1)


@pytest.mark.slow
def test_the_reference_route_on_a_dask_cluster_gives_the_local_result(recorded):
    """``diagnose --scheduler``: the re-simulations on a scheduler and two worker processes."""
    distributed = pytest.importorskip("distributed")
    kw = dict(method="lr", figures=False, progress=False, twin="measured",
              reference=recorded["reference"])
    local = diagnose(recorded["changed"], recorded["root"] / "local_out", **kw,
                     physics_options=PHYS)
    with distributed.LocalCluster(host="127.0.0.1", dashboard_address=None, n_workers=2,
                                  threads_per_worker=1, processes=True) as cluster:
        remote = diagnose(recorded["changed"], recorded["root"] / "dask_out", **kw,
                          physics_options={**PHYS, "scheduler": cluster.scheduler_address})
    for key in ("significant", "effects", "suspected", "stages", "physics"):
        assert _untimed(remote[key]) == _untimed(local[key]), key


def _untimed(x):
    """``x`` without its wall times (keys ending in ``seconds`` or ``_wall_s``)."""
    if isinstance(x, dict):
        return {k: _untimed(v) for k, v in x.items()
                if not (k.endswith("seconds") or k.endswith("_wall_s"))}
    if isinstance(x, list):
        return [_untimed(v) for v in x]
    return x


def _rounds_with(monkeypatch, alternatives, left_significant, **opts):
    """``driver._rounds`` with its steps replaced: every round's finding is accepted and shared
    with the reference; ``alternatives`` the successive answers of ``_changed_alternative``;
    ``left_significant`` whether the data still exceed the reference. Returns (findings, twin
    errors, the number of rounds run)."""
    from types import SimpleNamespace
    import numpy as np
    from littledog_mlsim.diagnose.physical import driver
    calls = {"rounds": 0}
    answers = list(alternatives)

    def round_(ctx, o, sp, robot_mass, foot_mu, say, rnd):
        calls["rounds"] += 1
        o.observer(None)
        return SimpleNamespace(accepted=True, statement=f"twin error {rnd}", p_value=1e-4,
                               gain=np.ones(3), family="command_delay", scope="all",
                               params={}, hyp=("twin", rnd)), []

    monkeypatch.setattr(driver, "_round", round_)
    monkeypatch.setattr(driver, "reference_check",
                        lambda *a: {"changed": False, "p_value": 0.5, "data_move_cut": 1.0,
                                    "reference_move_cut": 1.0})
    monkeypatch.setattr(driver, "_changed_alternative", lambda *a: answers.pop(0))
    monkeypatch.setattr(driver, "_rebase", lambda ctx, base: SimpleNamespace(base=tuple(base)))
    monkeypatch.setattr(driver, "unexplained",
                        lambda *a: {"significant": left_significant, "channel_significant":
                                    False, "p_value": 0.5, "channel_p_value": 1.0})
    o = driver.PhysicalOptions(**opts)
    sp = SimpleNamespace(R=[0], V=[1])
    found, rejected, twin, ctx = driver._rounds(SimpleNamespace(base=()), sp, o, 1.0, 1.0,
                                                lambda s: None)
    return found, twin, calls["rounds"]


def test_a_twin_error_round_stops_when_nothing_is_left(monkeypatch):
    found, twin, rounds = _rounds_with(monkeypatch, [None, None, None], False)
    assert (found, len(twin), rounds) == ([], 1, 1)
    found, twin, rounds = _rounds_with(monkeypatch, [None, None, None], True)
    assert (found, len(twin), rounds) == ([], 3, 3)   # at most three corrections


def test_a_twin_error_rounds_alternative_is_the_finding_and_the_cap_holds(monkeypatch):
    from types import SimpleNamespace
    alt = SimpleNamespace(hyp=("change", 0))
    found, twin, rounds = _rounds_with(monkeypatch, [alt], True)
    assert found == [alt] and len(twin) == 1 and rounds == 1
    # more rounds asked for: the cap of corrections still ends the search
    alts = [SimpleNamespace(hyp=("change", k)) for k in range(3)]
    found, twin, rounds = _rounds_with(monkeypatch, list(alts), True, max_rounds=5)
    assert found == alts and len(twin) == 3 and rounds == 3


def test_what_is_left_in_a_few_channels_is_reported_as_unexplained():
    from littledog_mlsim.diagnose.physical.driver import left_suspicion
    base = {"pooled_ratio": 1.23, "p_value": 0.016, "significant": False, "material": False,
            "channel_p_value": 0.0027, "channel_significant": True,
            "channels": [{"channel": "q_front_right_hip_pitch", "ratio": 3.1}]}
    s = left_suspicion(base, capped=True)
    assert len(s) == 1 and s[0]["kind"] == "unexplained", s
    assert "q_front_right_hip_pitch" in s[0]["why"] and "per channel p = 0.0027" in s[0]["why"]
    assert "stopped at the most twin errors" in s[0]["why"]
    assert left_suspicion({**base, "channel_significant": False}, capped=False) == []
    pooled = left_suspicion({**base, "significant": True, "material": True,
                             "pooled_ratio": 1.8, "channel_significant": False, "scope": "body",
                             "concentration": 1.0, "scope_ratios": {"body": 1.8, "all": 1.0}},
                            False)
    assert "1.80 times the reference's" in pooled[0]["why"] and "no family" in pooled[0]["why"]


def test_the_excess_left_is_located_and_named_other_where_it_lives():
    """Decision 047: what the findings leave significantly and materially above the reference
    is named ``other`` at the scope where it lives: one knee's angles, all joints, or the
    body's motion; a material excess the data cannot establish is only suspected, with more
    moves asked for first."""
    import numpy as np
    from types import SimpleNamespace
    from littledog_mlsim.diagnose.physical.channels import CHANNELS, channels_of
    from littledog_mlsim.diagnose.physical.driver import left_suspicion, name_left, unexplained
    from littledog_mlsim.diagnose.report import _left_named
    assert [CHANNELS[k] for k in channels_of("joint:back_left_knee")] == [
        "short:q_back_left_knee", "long:q_back_left_knee"]
    assert len(channels_of("body")) == 12 and len(channels_of("all")) == 24
    V, R = list(range(12)), list(range(12, 24))
    rng = np.random.default_rng(4)
    S = np.exp(rng.normal(0.0, 0.2, (24, 1)) + rng.normal(0.0, 0.2, (24, 36)))

    def left_with(cols, factor):
        T = S.copy()
        T[np.ix_(V, cols)] *= factor
        return name_left(unexplained(_Sse(T), V, R, 0.01))

    knee = left_with(channels_of("joint:back_left_knee"), 12.0)
    assert knee["named"] and knee["scope"] == "joint:back_left_knee", knee
    assert knee["concentration"] > 2 and knee["vocabulary"]["family"] == "other"
    assert knee["vocabulary"]["scope"] == "joint:back_left_knee"
    assert "back-left knee" in knee["statement"] and "times the reference's" in knee["statement"]
    spread = left_with(channels_of("all"), 2.5)
    assert spread["named"] and spread["scope"] == "all" and spread["concentration"] == 1.0
    body = left_with(channels_of("body"), 4.0)
    assert body["named"] and body["scope"] == "body", body
    # decision 048: the knees' excess with the body's motion carrying as much (a soft floor)
    # is placed on the body; the knee's own, with the body at a tenth of it, stays at the knee
    soft = S.copy()
    soft[np.ix_(V, channels_of("type:knees"))] *= 12.0
    soft[np.ix_(V, channels_of("body"))] *= 11.0
    soft = name_left(unexplained(_Sse(soft), V, R, 0.01))
    assert soft["named"] and soft["scope"] == "body", soft["scope_ratios"]
    assert soft["scope_ratios"]["type:knees"] > soft["scope_ratios"]["body"]
    both = S.copy()
    both[np.ix_(V, channels_of("joint:back_left_knee"))] *= 12.0
    both[np.ix_(V, channels_of("body"))] *= 1.2
    assert name_left(unexplained(_Sse(both), V, R, 0.01))["scope"] == "joint:back_left_knee"
    (sus,) = left_suspicion(body, capped=False)
    assert sus["scope"] == "body" and "--start-spread" in sus["recording"]
    quiet = name_left(unexplained(_Sse(S), V, R, 0.01))
    assert not quiet["named"] and "vocabulary" not in quiet
    assert not _left_named(SimpleNamespace(reference={"unexplained": quiet}))
    assert _left_named(SimpleNamespace(reference={"unexplained": knee}))
    assert not _left_named(SimpleNamespace(reference=None))
    # material, not significant: suspected, more moves first
    untold = {**knee, "significant": False, "channel_significant": False, "named": False}
    (sus,) = left_suspicion(untold, capped=False)
    assert "cannot tell it from chance" in sus["why"] and sus["scope"] == "joint:back_left_knee"
    assert sus["recording"].startswith("record more moves") and "--excitation" in sus["recording"]


def test_an_excess_significant_only_in_a_few_channels_is_named_where_material():
    """Decision 062: one knee's angles twice the reference's on every held-out move, and one
    move's error four times over every channel (material pooled), leave the pooled rank test
    not significant and the per-channel one significant: the excess is named ``other`` at that
    knee, and its words give the per-channel p. Decision 063: a pooled ratio below 1.25 (the
    other channels below the reference's) does not keep it from being named where a
    significant channel is material, and its words lead with that channel; material only
    through channels that are not significant, it is only suspected. A finding's remainder is
    read on the channel that makes it exceed."""
    import numpy as np
    from littledog_mlsim.diagnose.physical.channels import channels_of
    from littledog_mlsim.diagnose.physical.driver import (exceeds, lead_channel, left_suspicion,
                                                          name_left, p_words, remainder,
                                                          unexplained)
    from littledog_mlsim.diagnose.report import remainder_words
    V, R = list(range(12)), list(range(12, 24))
    rng = np.random.default_rng(4)
    S = np.exp(rng.normal(0.0, 0.2, (24, 1)) + rng.normal(0.0, 0.2, (24, 36)))
    S[np.ix_(V, channels_of("joint:back_left_knee"))] *= 2.0
    S[V[0], :] *= 4.0
    left = name_left(unexplained(_Sse(S), V, R, 0.01))
    assert not left["significant"] and left["channel_significant"] and left["material"], left
    sig = {c["channel"] for c in left["significant_channels"]}
    assert sig and sig <= {"short:q_back_left_knee", "long:q_back_left_knee"}, sig
    assert all(c["ratio"] >= 1.25 and c["p_value"] < 0.01 for c in left["significant_channels"])
    assert exceeds(left) and left["named"] and left["scope"] == "joint:back_left_knee", left
    assert left["vocabulary"]["family"] == "other"
    assert "per channel p = " in left["statement"] and "pooled p = " in left["statement"]
    assert "q_back_left_knee" in left["statement"] and "back-left knee" in left["statement"]
    (sus,) = left_suspicion(left, capped=False)
    assert "named other at joint:back_left_knee" in sus["why"] and "per channel p" in sus["why"]
    # material pooled, but the significant channels' own excess is not
    weak = {**left, "significant_channels": [{**c, "ratio": 1.1}
                                             for c in left["significant_channels"]]}
    assert not exceeds(weak) and not name_left(weak)["named"]
    # decision 063: the other channels below the reference's, the pooled ratio near 1
    quiet = S.copy()
    quiet[np.ix_(V, [j for j in range(36) if j not in channels_of("joint:back_left_knee")])] *= 0.6
    quiet[V[0], :] /= 4.0
    low = name_left(unexplained(_Sse(quiet), V, R, 0.01))
    assert not low["material"] and low["pooled_ratio"] < 1.1 and low["channel_significant"], low
    assert exceeds(low) and low["named"] and low["scope"] == "joint:back_left_knee", low
    lead = lead_channel(low)
    assert lead["channel"].endswith("q_back_left_knee") and lead["ratio"] >= 1.25
    assert f"channel {lead['channel']} is {lead['ratio']:.2f} times" in low["statement"]
    assert low["vocabulary"]["params"]["channel"] == lead["channel"]
    (sus,) = left_suspicion(low, capped=False)
    assert sus["why"].startswith("named other at joint:back_left_knee")
    assert lead["channel"] in sus["why"]
    # the pooled test significant but not material: the words still lead with the channel
    pooled_small = name_left({**low, "significant": True, "p_value": 0.004})
    assert pooled_small["named"] and lead["channel"] in pooled_small["statement"]
    # the lead is the most significant channel that is material, not the most significant
    first = {"channel": "short:yaw", "ratio": 1.1, "p_value": 1e-6}
    picked = {**low, "significant_channels": [first] + low["significant_channels"]}
    assert lead_channel(picked)["channel"] == lead["channel"]
    # a finding's remainder, named through the channel, is read on it
    before = {**low, "pooled_ratio": 1.5,
              "channel_ratios": {**low["channel_ratios"], lead["channel"]: 4.0}}
    rem = remainder(before, low)
    assert rem["channel"] == lead["channel"] and rem["ratio_before"] == 4.0
    assert rem["ratio_after"] == lead["ratio"] and 0.0 < rem["share_of_excess_removed"] < 1.0
    assert f"in the channel {lead['channel']} stays" in remainder_words(rem)
    (sus,) = left_suspicion({**weak, "material": False}, capped=False)
    assert "exceeds the reference's" in sus["why"] and not exceeds({**weak, "material": False})
    untold = {**left, "channel_significant": False, "significant_channels": []}
    (sus,) = left_suspicion(untold, capped=False)
    assert "cannot tell it from chance" in sus["why"] and "per channel p = " in sus["why"]
    both = {**left, "significant": True}
    assert p_words(both) == f"p = {left['p_value']:.2g}"
    # a finding's remainder, significant per channel only, quotes that test
    rem = remainder({**left, "pooled_ratio": 2.0}, left)
    assert rem["channel_significant"] and not rem["significant"]
    assert "per channel p = " in remainder_words(rem)


def test_an_excess_over_a_reference_of_another_excitation_is_named_only_where_concentrated():
    """Decisions 052 and 064: against a reference recorded under another command excitation,
    an excess on the body, spread over the joints or at a joint type is not named (the twin's
    own error under the data's excitation is not in the reference; a suspected entry asks for
    the reference recorded the data's way); one concentrated at a joint is named as measured,
    marked not comparable. The same excitation, or none given, changes nothing."""
    import numpy as np
    from types import SimpleNamespace
    from littledog_mlsim.diagnose.conditions import Conditions
    from littledog_mlsim.diagnose.physical.channels import channels_of
    from littledog_mlsim.diagnose.conditions import excitation_of
    from littledog_mlsim.diagnose.physical.driver import (PhysicalOptions, _compared,
                                                          _conditions, left_suspicion,
                                                          name_left, unexplained)
    from littledog_mlsim.diagnose.report import _left_named
    V, R = list(range(12)), list(range(12, 24))
    rng = np.random.default_rng(4)
    S = np.exp(rng.normal(0.0, 0.2, (24, 1)) + rng.normal(0.0, 0.2, (24, 36)))
    other = Conditions(data_excitation_rad=0.05, reference_excitation_rad=0.0)

    def left_with(cols, factor, conditions):
        T = S.copy()
        T[np.ix_(V, cols)] *= factor
        return name_left(unexplained(_Sse(T), V, R, 0.01), conditions)

    for scope, factor in (("body", 4.0), ("all", 2.5)):
        left = left_with(channels_of(scope), factor, other)
        assert left["significant"] and left["material"] and left["scope"] == scope, left
        assert not left["named"] and "vocabulary" not in left
        assert left["comparable"] is False and left["concentrated"] is False
        assert left["statement"].startswith("not compared: the reference was recorded with")
        assert not _left_named(SimpleNamespace(reference={"unexplained": left}))
        (sus,) = left_suspicion(left, capped=False)
        assert sus["kind"] == "unexplained" and "not named" in sus["why"]
        assert sus["recording"] == other.recording and "--excitation 0.05" in sus["recording"]
        # the same excitation, or the reference's not given: named as before (decision 047)
        for same in (Conditions(0.05, 0.05), None):
            again = left_with(channels_of(scope), factor, same)
            assert again["named"] and "comparable" not in again
    knee = left_with(channels_of("joint:back_left_knee"), 12.0, other)
    assert knee["named"] and knee["concentrated"] and knee["comparable"] is False
    assert knee["vocabulary"]["scope"] == "joint:back_left_knee"
    assert "does not give" in knee["statement"]
    # decision 064: concentrated at a joint type, it is not named (a twin's per-type error
    # under the data's excitation gathers there) and is suspected, asking for the reference
    # recorded the data's way; with the same excitation it is named as before
    knees = left_with(channels_of("type:knees"), 12.0, other)
    assert knees["significant"] and knees["scope"] == "type:knees", knees
    assert not knees["named"] and knees["concentrated"] is False
    assert knees["statement"].startswith("not compared: ") and not _compared(knees, other)
    (sus,) = left_suspicion(knees, capped=False)
    assert sus["kind"] == "unexplained" and "not named" in sus["why"]
    assert sus["recording"] == other.recording
    for same in (Conditions(0.05, 0.05), None):
        again = left_with(channels_of("type:knees"), 12.0, same)
        assert again["named"] and again["vocabulary"]["scope"] == "type:knees"
    # one knee over a type-wide excess: located at the type, so not named across excitations
    T = S.copy()
    T[np.ix_(V, channels_of("type:knees"))] *= 6.0
    T[np.ix_(V, channels_of("joint:back_left_knee"))] *= 3.0
    mixed = name_left(unexplained(_Sse(T), V, R, 0.01), other)
    assert mixed["scope"] == "type:knees" and not mixed["named"], mixed["scope"]
    # material but not significant, or in a few channels only: suspected as before, with the
    # reference recorded the data's way asked for
    body = left_with(channels_of("body"), 4.0, other)
    untold = {**body, "significant": False, "channel_significant": False}
    (sus,) = left_suspicion(untold, capped=True)
    assert "cannot tell it from chance" in sus["why"] and "--excitation 0.05" in sus["recording"]
    assert "the search stopped" in sus["why"] and sus["recording"].startswith("record more")
    few = {**body, "significant": False, "material": False, "channel_significant": True}
    (sus,) = left_suspicion(few, capped=False)
    assert "per channel" in sus["why"] and sus["recording"] == other.recording
    # the options carry the reference's excitation to the driver; only a compared excess
    # reads the findings against it (remainder)
    assert _conditions(PhysicalOptions(excitation=0.05)) is None
    c = _conditions(PhysicalOptions(excitation=0.05, reference_excitation=0.0))
    assert c == other and not c.comparable
    assert not _compared(body, c) and _compared(knee, c) and _compared(body, None)
    assert _compared(body, Conditions(0.05, 0.05))
    # a recording's excitation is read with a one-line error naming it
    assert excitation_of({"command_excitation_rad": 0.05}, "d") == 0.05
    assert excitation_of({}, "d") == 0.0
    for bad in ("abc", -1.0, float("nan")):
        with pytest.raises(ValueError, match="my_data: dataset.yaml's command_excitation_rad"):
            excitation_of({"command_excitation_rad": bad}, "my_data")


def test_a_finding_that_leaves_a_material_excess_is_read_as_partial_or_a_stand_in():
    """Decision 045: where the findings leave the data's error significantly and materially
    above the reference's, the share of the excess they removed reads them as part of the
    change (at least half) or a stand-in for it; the effect's statement says so and the
    entry carries ``remainder`` and ``stand_in``."""
    from types import SimpleNamespace
    import numpy as np
    from littledog_mlsim.diagnose.physical.driver import STAND_IN_SHARE, remainder, unexplained
    from littledog_mlsim.diagnose.report import _physical_effect
    V, R = list(range(8)), list(range(8, 16))
    rng = np.random.default_rng(3)
    ref = {i: 1.0 + 0.1 * rng.random() for i in R}

    def left(level):
        return unexplained(_Ctx({**{i: level + 0.1 * rng.random() for i in V}, **ref}, {}),
                           V, R, 0.01)
    most = remainder(left(4.0), left(1.6))          # 3.0 of excess, 0.6 left: partial
    assert most["reading"] == "partial" and most["share_of_excess_removed"] > STAND_IN_SHARE
    assert 1.4 < most["ratio_after"] < 1.8 and len(most["channels"]) == 4
    little = remainder(left(2.2), left(1.9))        # 1.2 of excess, 0.9 left: a stand-in
    assert little["reading"] == "stand-in", little
    assert 0.0 < little["share_of_excess_removed"] < STAND_IN_SHARE
    worse = remainder(left(1.6), left(2.0))         # the finding made it worse
    assert worse["reading"] == "stand-in" and worse["share_of_excess_removed"] < 0
    assert remainder({**left(1.6), "pooled_ratio": 0.9}, left(2.0))["reading"] == "stand-in"

    def finding(rem):
        return SimpleNamespace(family="command_filter", scope="all", params={"time_constant_ms": 6},
                               statement="All joints: set-points low-passed, 6 ms", p_value=1e-4,
                               gain=np.full(36, 0.05), p_channel=np.full(36, 1e-3),
                               evidence=lambda: {}, remainder=rem)
    nums = {"nmse": {}}
    e = _physical_effect(0, finding(little), None, nums, nums)
    assert e["stand_in"] is True and e["remainder"]["reading"] == "stand-in"
    assert e["physical"]["family"] == "command_filter"          # the name is kept
    assert "; a stand-in: the data's error stays 1." in e["physical"]["statement"]
    assert "does not hold" in e["physical"]["statement"]
    e = _physical_effect(0, finding(most), None, nums, nums)
    assert e["stand_in"] is False and "only part of the change" in e["physical"]["statement"]
    e = _physical_effect(0, finding(None), None, nums, nums)
    assert "stand_in" not in e and "remainder" not in e
    assert e["physical"]["statement"] == "All joints: set-points low-passed, 6 ms"


def test_the_findings_are_read_against_the_reference_without_them(monkeypatch):
    """``driver._left_against_reference``: what is left is measured with the last finding in
    the twin; where it is significant and material, again without the findings but with the
    twin errors, and each finding carries the reading; where it is not, nothing is added."""
    import numpy as np
    from littledog_mlsim.diagnose.physical import driver
    from littledog_mlsim.diagnose.physical.channels import N_CH
    from littledog_mlsim.diagnose.physical.records import Finding, Hypothesis
    V, R = list(range(8)), list(range(8, 16))
    twin_error = Hypothesis("command_delay", "all", {"delay_ms": 5.0})
    found = Hypothesis("command_filter", "all", {"time_constant_ms": 6.0})
    finding = Finding("command_filter", "all", {"time_constant_ms": 6.0}, "low-passed", True,
                      True, 1e-4, np.full(N_CH, 0.1), np.full(N_CH, 1e-3), [], [], {}, {},
                      found, [])
    rng = np.random.default_rng(4)

    class Ctx:
        def __init__(self, base, level):
            self.base = tuple(base)
            self.levels = {**{i: level + 0.1 * rng.random() for i in V},
                           **{i: 1.0 + 0.1 * rng.random() for i in R}}

        def sse(self, hyp, moves):
            return np.array([np.full(N_CH, self.levels[i]) for i in moves])

    rebased, said = [], []
    sp = driver._Split([], [], V, [], R)
    for levels, reading in (({True: 1.9, False: 2.2}, "stand-in"),
                            ({True: 1.6, False: 4.0}, "partial"),
                            ({True: 1.05, False: 2.2}, None)):
        rebased.clear()

        def rebase(ctx, base, levels=levels):
            rebased.append(tuple(base))
            return Ctx(base, levels[found in base])
        monkeypatch.setattr(driver, "_rebase", rebase)
        out, left = driver._left_against_reference(Ctx((twin_error,), 9.0), [finding], sp,
                                                   driver.PhysicalOptions(), said.append)
        assert rebased[0] == (twin_error, found)            # the last finding joins the twin
        if reading is None:
            assert not left["material"] and out[0].remainder is None and len(rebased) == 1
            continue
        assert rebased[1] == (twin_error,)                  # without it, the twin error kept
        rem = out[0].remainder
        assert rem["reading"] == reading and rem["ratio_after"] == left["pooled_ratio"]
        assert said[-1].endswith(reading) and finding.remainder is None
