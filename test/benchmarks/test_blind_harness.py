"""The blind zoo harness's loop closed by the learned route's advice (``--follow-recordings``):
which recording a report asks for, and what the harness records and diagnoses for it. Fast:
``record`` and ``diagnose`` are replaced by fakes that write nothing but a report."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from benchmarks.blind_zoo.harness import run as harness

CONDITIONS = ("record the reference the way the data were recorded: with command excitation "
              "(record --excitation 0.05)")
SPREAD = ("record the same move types started from several places on the floor and headings "
          "(record --start-spread 0.5), so where the robot is, which way it faces and how far "
          "into which move it is are not confounded")
TIME = "record longer moves (8 s or more), or the same moves at different times since power-up"


def test_a_reference_of_other_conditions_asks_for_the_reference_again():
    rec = harness.recommended_recording({"reference_conditions": {"recording": CONDITIONS},
                                         "rollout_route": {"unexplained_change":
                                                           {"recording": SPREAD}}})
    assert rec["what"] == "reference" and rec["args"] == {"--excitation": 0.05}


def test_the_rollout_routes_unexplained_change_asks_for_both_recordings():
    rec = harness.recommended_recording({"rollout_route": {
        "unexplained_change": {"recording": SPREAD},
        "suspected": [{"recording": "record with command excitation (record --excitation 0.05)"}]}})
    assert rec["what"] == "both" and rec["args"] == {"--start-spread": 0.5}


def test_a_recording_with_no_record_argument_is_not_followed():
    assert harness.recommended_recording({"suspected": [{"recording": TIME}],
                                          "rollout_route": {}}) is None
    assert harness.recommended_recording({}) is None


def test_a_held_frame_finding_is_named_and_scored_like_the_timing_checks():
    """Decision 044: the held-frame check's vocabulary counts as the timing check's does."""
    voc = {"family": "other", "scope": "body", "params": {"held_fraction": 0.23}}
    report = {"significant": False, "effects": [],
              "timing": {"significant": False},
              "held_frames": {"significant": True, "vocabulary": voc}}
    assert harness.named_effects(report) == [voc] and harness.significant(report)
    s = harness.score({"family": "other", "scope": "body", "params": {}}, report)
    assert s["found"] and s["family_right"] and s["scope_right"]
    quiet = {**report, "held_frames": {"significant": False}}
    assert harness.named_effects(quiet) == [] and not harness.significant(quiet)


def test_the_physical_routes_named_excess_counts_as_other_at_its_scope():
    """Decision 047: the excess over the reference the physical route's findings leave, where
    named, is an ``other`` effect at its scope; not named, it names nothing."""
    voc = {"family": "other", "scope": "joint:back_left_knee", "params": {"error_ratio": 1.4}}
    left = {"named": True, "vocabulary": voc, "significant": True, "material": True}
    report = {"significant": True, "effects": [], "physics": {"reference": {"unexplained": left}}}
    assert harness.named_effects(report) == [voc]
    s = harness.score({"family": "other", "scope": "joint:back_left_knee", "params": {}}, report)
    assert s["found"] and not s["identified"]
    quiet = {**report, "physics": {"reference": {"unexplained": {**left, "named": False}}}}
    assert harness.named_effects(quiet) == []


def test_the_tag_names_every_condition():
    assert harness.follow_up_tag({}) == ""
    assert harness.follow_up_tag({"--excitation": 0.05}) == "_e0.05"
    assert harness.follow_up_tag({"--start-spread": 0.5, "--excitation": 0.05}) == \
        "_e0.05_spread0.5"


@pytest.fixture()
def fakes(monkeypatch):
    recorded: dict[str, tuple[float, list[str]]] = {}
    diagnosed: dict[str, list[str]] = {}

    def record(ds, moves, jobs, logs, extra=()):
        recorded[str(ds.path)] = (ds.excitation, list(extra))

    def diagnose(ds, work, extra, logs, arm=""):
        diagnosed[ds.name] = list(extra)
        ds.diag_seconds = 1.0
        ds.report = {"significant": False, "effects": []}

    monkeypatch.setattr(harness, "record", record)
    monkeypatch.setattr(harness, "diagnose", diagnose)
    return recorded, diagnosed


def _args(**kw):
    base = dict(arm="learned+reference", record_arg=[], diagnose_arg=[], moves_per_type=2,
                jobs=1)
    return argparse.Namespace(**{**base, **kw})


def test_each_asked_recording_is_made_once_and_diagnosed_against_its_reference(tmp_path, fakes):
    recorded, diagnosed = fakes
    work = tmp_path
    truth = [{"id": "z01", "family": "backlash", "scope": "type:knees"},
             {"id": "z02", "family": "other", "scope": "body"},
             {"id": "z03", "family": "other", "scope": "body"},
             {"id": "z04", "family": "time_drift", "scope": "all"}]
    eff = [harness.Dataset("z01", work / "effects" / "z01", 7, 0.05, Path("z01.yaml")),
           harness.Dataset("z02", work / "effects" / "z02", 7, 0.0, Path("z02.yaml")),
           harness.Dataset("z03", work / "effects" / "z03", 7, 0.0, Path("z03.yaml")),
           harness.Dataset("z04", work / "effects" / "z04", 7, 0.0, Path("z04.yaml"))]
    eff[0].report = {"reference_conditions": {"recording": CONDITIONS}, "effects": []}
    eff[1].report = {"rollout_route": {"unexplained_change": {"recording": SPREAD}},
                     "effects": []}
    eff[2].report = {"rollout_route": {"unexplained_change": {"recording": SPREAD}},
                     "effects": []}
    eff[3].report = {"suspected": [{"recording": TIME}], "effects": []}
    reference = harness.Dataset("reference", work / "reference", 13, 0.0)
    rows, cleans = harness.follow_recordings(truth, eff, _args(), work, work / "logs", None,
                                             reference)
    # z01: only the reference again, under the data's excitation; z02 and z03 share the spread
    # recordings; z04 asks for nothing a record argument gives
    assert recorded == {
        str(work / "reference_e0.05"): (0.05, []),
        str(work / "clean" / "s7_e0.05"): (0.05, []),
        str(work / "effects" / "z02_spread0.5"): (0.0, ["--start-spread", "0.5"]),
        str(work / "reference_spread0.5"): (0.0, ["--start-spread", "0.5"]),
        str(work / "clean" / "s7_spread0.5"): (0.0, ["--start-spread", "0.5"]),
        str(work / "effects" / "z03_spread0.5"): (0.0, ["--start-spread", "0.5"])}
    assert [r["id"] for r in rows] == ["z01 (recommended recording)",
                                       "z02 (recommended recording)",
                                       "z03 (recommended recording)"]
    assert rows[0]["recording"]["reference"] == {"--excitation": 0.05}
    assert rows[1]["recording"]["data"] == {"--start-spread": 0.5}
    assert sorted(c.name for c in cleans) == ["clean_s7_e0.05_ref_e0.05",
                                              "clean_s7_spread0.5_ref_spread0.5"]
    ref_of = {name: extra[extra.index("--reference") + 1] for name, extra in diagnosed.items()}
    assert ref_of == {"z01_e0.05_ref_e0.05": str(work / "reference_e0.05"),
                      "clean_s7_e0.05_ref_e0.05": str(work / "reference_e0.05"),
                      "z02_spread0.5_ref_spread0.5": str(work / "reference_spread0.5"),
                      "clean_s7_spread0.5_ref_spread0.5": str(work / "reference_spread0.5"),
                      "z03_spread0.5_ref_spread0.5": str(work / "reference_spread0.5")}


def test_following_needs_an_arm_with_a_reference(tmp_path, fakes):
    with pytest.raises(SystemExit, match="reference"):
        harness.follow_recordings([], [], _args(arm="learned"), tmp_path, tmp_path, None, None)


def test_a_friction_fitted_alone_is_scored_as_the_contacts(tmp_path):
    """Bullet multiplies the foot's and the floor's friction: a twin that fits the floor's
    from its own foot's is scored on the product, against the truth's product; a parameter
    fitted as itself is scored as itself."""
    import dataclasses

    from littledog_mlsim.robot.config import robot_config
    from littledog_mlsim.robot.twin import Twin, save_twin

    base = robot_config("measured")
    truth = dataclasses.replace(base, name="truth", foot_friction=0.7, ground_friction=1.0,
                                body_mass=2.0)
    twin = dataclasses.replace(base, name="twin", foot_friction=0.9, ground_friction=0.8,
                               body_mass=2.3)
    save_twin(Twin(truth, {}), tmp_path / "truth.json")
    save_twin(Twin(twin, {"parameters": {
        "ground_friction": {"value": 0.8, "ci95": [0.76, 0.84], "at_bound": None},
        "body_mass": {"value": 2.3, "ci95": [2.2, 2.4], "at_bound": None}},
        "calibration": {}}), tmp_path / "twin.json")
    got = harness.calibration_score({"twin": str(tmp_path / "twin.json"), "seconds": 1.0},
                                    tmp_path / "truth.json")
    rows = {r["name"]: r for r in got["rows"]}
    friction = rows["ground_friction"]
    assert friction["scored_as"] == "contact_friction"
    assert friction["truth"] == pytest.approx(0.7) and friction["value"] == pytest.approx(0.72)
    assert friction["ci95"] == pytest.approx([0.684, 0.756]) and friction["inside"]
    assert rows["body_mass"]["scored_as"] == "body_mass" and not rows["body_mass"]["inside"]
    assert got["summary"] == "1 of 2"
    # a weak direction takes out the parameters in it (coefficient >= 0.1), not the others
    # its combination lists with 0
    save_twin(Twin(twin, {"parameters": {
        "ground_friction": {"value": 0.8, "ci95": [0.76, 0.84], "at_bound": None},
        "body_mass": {"value": 2.3, "ci95": [2.2, 2.4], "at_bound": None}},
        "calibration": {"weak_directions": [{"combination": {"body_mass": 1.0,
                                                             "ground_friction": 0.0}}]}}),
        tmp_path / "weak.json")
    got = harness.calibration_score({"twin": str(tmp_path / "weak.json"), "seconds": 1.0},
                                    tmp_path / "truth.json")
    assert [r["identifiable"] for r in got["rows"]] == [True, False]
    assert got["summary"] == "1 of 1"


def test_the_gap_robot_is_weighed_to_the_scales_resolution(tmp_path):
    """``--weigh KG``: the calibration gets the gap robot's total mass (body and four legs)
    rounded to KG, nothing else of it."""
    import dataclasses

    from littledog_mlsim.robot.config import robot_config
    from littledog_mlsim.robot.twin import Twin, save_twin

    gap = dataclasses.replace(robot_config("measured"), name="gap", body_mass=2.3137,
                              leg_mass=0.1811)
    save_twin(Twin(gap, {}), tmp_path / "gap.json")
    assert harness.weighing(tmp_path / "gap.json", 0.01) == pytest.approx(3.04)   # 3.0381
    assert harness.weighing(tmp_path / "gap.json", 0.001) == pytest.approx(3.038)


def test_misses_reads_where_each_miss_stood_in_its_diagnosis(tmp_path):
    """``harness/misses.py``: for an effect not identified, the truth's family in the screen
    (in the vocabulary: a searched form counts as its family), its fitted hypotheses with
    their J and held-out cut (null values shown as "-"), the best held-out cut and the located
    pass's log line; identified effects and follow-up rows are left out."""
    import json
    import yaml
    from benchmarks.blind_zoo.harness import misses
    truth = {"effects": [
        {"id": "z01", "family": "time_drift", "scope": "all", "params": {"rate_per_s": -0.03}},
        {"id": "z02", "family": "servo_gain", "scope": "all", "params": {"gain_ratio": 0.7}}]}
    (tmp_path / "truth.yaml").write_text(yaml.safe_dump(truth))
    run = tmp_path / "run"
    rows = [{"id": "z01", "score": {"identified": False, "found": False, "named": [
                {"family": "mass_com", "scope": "body", "params": {"added_mass_kg": 0.1}}]}},
            {"id": "z02", "score": {"identified": True, "found": True, "named": []}},
            {"id": "z01 (recommended recording)", "score": {"identified": False}}]
    run.mkdir()
    (run / "results.json").write_text(json.dumps({"rows": rows}))
    ev = {"screening_top": [{"family": "supply_sag", "scope": "type:hip_rolls", "score": 4.5},
                            {"family": "mass_com", "scope": "body", "score": 3.0}],
          "alternatives": [
              {"family": "time_drift", "searched_family": "supply_sag", "scope": "all",
               "params": {"rate_per_s": -0.011}, "J_relative": 0.962,
               "held_out_move_cut": None, "held_out_p": 0.18},
              {"family": "mass_com", "searched_family": "mass_com", "scope": "body",
               "params": {}, "J_relative": 0.854, "held_out_move_cut": 3.68,
               "held_out_p": 1e-4}]}
    report = {"effects": [{"round": 1, "physical": {"family": "mass_com", "scope": "body"},
                           "evidence": ev}], "physics": {"rejected": []}}
    (run / "reports" / "z01").mkdir(parents=True)
    (run / "reports" / "z01" / "report.json").write_text(json.dumps(report))
    (run / "logs").mkdir()
    (run / "logs" / "diagnose_z01.log").write_text(
        "diagnose: physics round 1: the fit moves' excess over the reference lives at all: "
        "every joint family fitted there\n")
    text = "\n".join(misses.rows(run, tmp_path / "truth.yaml", every=False))
    assert "### z01: time_drift @ all (rate_per_s=-0.03)" in text and "z02" not in text
    assert "#1 supply_sag @ type:hip_rolls (4.50); not at all" in text
    assert "**supply_sag @ all** rate_per_s=-0.011, J 0.962, cut - (p 0.18)" in text
    assert "best held-out cut: mass_com @ body, J 0.854, cut 3.680" in text
    assert "located pass: round 1: the fit moves' excess over the reference lives at all" in text
    assert "recommended" not in text


def test_a_clean_excitation_no_effect_uses_is_recorded_when_asked(tmp_path, fakes):
    """``--clean-excitation``: the excited clean seeds are recorded under it even where no
    effect of the zoo is recorded with excitation; without it they are not."""
    recorded, _ = fakes
    zoo = tmp_path / "zoo"
    zoo.mkdir()
    (zoo / "truth.yaml").write_text("effects:\n  - {id: z01, family: other, scope: body}\n")
    base = ["--zoo", str(zoo), "--seed", "7", "--clean-seeds", "7,8",
            "--clean-seeds-excited", "7", "--record-only"]
    assert harness.main(base + ["--work", str(tmp_path / "w1"),
                                "--out", str(tmp_path / "o1")]) == 0
    assert sorted(Path(p).name for p in recorded) == ["s7_e0", "s8_e0", "z01"]
    recorded.clear()
    assert harness.main(base + ["--work", str(tmp_path / "w2"), "--out", str(tmp_path / "o2"),
                                "--clean-excitation", "0.05"]) == 0
    assert {Path(p).name: e for p, (e, _) in recorded.items()} == {
        "s7_e0": 0.0, "s8_e0": 0.0, "s7_e0.05": 0.05, "z01": 0.0}
    for bad in ("nan", "-0.05", "0"):
        with pytest.raises(SystemExit, match="--clean-excitation RAD"):
            harness.main(base + ["--work", str(tmp_path / "w3"), "--out", str(tmp_path / "o3"),
                                 "--clean-excitation", bad])


def test_an_excited_clean_seed_is_scored_as_a_clean_run(tmp_path, fakes, monkeypatch):
    """``--clean-excitation``: the excited clean seed is diagnosed and counted among the clean
    runs (its alarm a false alarm); an effect recorded without excitation is still compared
    with the clean run of its own seed and excitation."""
    _, diagnosed = fakes
    # each dataset's one-step error tells which clean run an effect was compared with
    nmse = {"clean_s7_e0": 0.1, "clean_s8_e0": 0.2, "clean_s7_e0.05": 0.3, "z01": 0.4}

    def diagnose(ds, work, extra, logs, arm=""):
        diagnosed[ds.name] = list(extra)
        ds.diag_seconds = 1.0
        ds.report = {"significant": ds.name == "clean_s7_e0.05", "effects": [],
                     "before": {"nmse_mean": nmse[ds.name]}}

    monkeypatch.setattr(harness, "diagnose", diagnose)
    zoo = tmp_path / "zoo"
    zoo.mkdir()
    (zoo / "truth.yaml").write_text("effects:\n  - {id: z01, family: other, scope: body}\n")
    out = tmp_path / "out"
    assert harness.main(["--zoo", str(zoo), "--seed", "7", "--clean-seeds", "7,8",
                         "--clean-seeds-excited", "7", "--clean-excitation", "0.05",
                         "--work", str(tmp_path / "w"), "--out", str(out),
                         "--no-follow-up", "--jobs", "1"]) == 0
    assert sorted(diagnosed) == ["clean_s7_e0", "clean_s7_e0.05", "clean_s8_e0", "z01"]
    res = json.loads((out / "results.json").read_text())
    assert res["summary"]["clean runs"] == 3 and res["summary"]["false alarms"] == 1
    (row,) = res["rows"]
    assert row["clean"]["onestep_before"] == nmse["clean_s7_e0"]
