"""``benchmarks/blind_zoo/harness/learned_misses.py``: where a miss of the learned route stood,
read off a report dict (report.json's shape) and off the text a run keeps where report.json is
not committed (the diagnose log and report.md). Fast: small synthetic reports, no diagnosis."""
from __future__ import annotations

from benchmarks.blind_zoo.harness import learned_misses as lm

TRUTH = {"id": "z01", "family": "command_delay", "scope": "side:left",
         "params": {"delay_ms": 20.0}, "learned_inputs": False}


def _probe(label, p, gain, significant, material):
    return {"label": label, "p_value": p, "total_gain": gain, "significant": significant,
            "material": material}


def test_a_report_dict_gives_where_the_truths_family_stood():
    """The best probe of the truth's family per round and screen (its scope read as the route
    reports it, its rank by p), the truth's own family x scope wherever probed, what the
    reference contrast set aside, the two readings against the reference, the change
    screen's best hypothesis of the family, and the family's suspected entries."""
    report = {
        "source": "report.json",
        "rounds": [{"round": 1, "picked": None, "best": [
            {"candidate": "state_lag(lag=3, group=all)", "p_value": 1e-20,
             "total_gain": 0.3, "significant": True, "material": False},
            {"candidate": "command_lag(lag=2, joints=all)", "p_value": 1e-10,
             "total_gain": 0.2, "significant": True, "material": False}]}],
        "suspected": [{"family": "command_delay", "scope": "side:left",
                       "label": "command_lag(lag=2, joints=left)", "p_value": 3e-5,
                       "why": "significant but below the materiality minimum"},
                      {"family": "time_drift", "scope": "all", "label": "elapsed_time()"}],
        "rollout_route": {
            "options": {"alpha": 1e-4},
            "rounds": [{"round": 0, "probes": [
                _probe("heading()", 1e-6, 5.0, True, False),
                _probe("command_lag(lag=2, joints=all)", 0.01, 2.0, False, False),
                _probe("gait_phase(quarter_lag=9)", 1.0, 0.1, False, False)],
                "scoped": [_probe("command_lag(lag=2, joints=front_left)", 1e-3, 1.0, False,
                                  False),
                           _probe("command_lag(lag=2, joints=left)", 3e-5, 1.5, True, False)]}],
            "effects": [],
            "reference": {"shared": [{"label": "command_filter(time_constant_ms=30.0, "
                                               "joints=left)",
                                      "reference": {"p_change": 0.4,
                                                    "reference_total_gain": 1.2}}],
                          "not_comparable": []},
            "unexplained_change": {"ratio": 1.2, "p_value": 0.05, "scope": "all",
                                   "concentration": 1.0, "significant": False,
                                   "material": False},
            "reference_change": {
                "ratio": 4.0, "p_value": 1e-20, "scope": "side:left", "significant": True,
                "named": False, "family": "servo_gain", "kept_scope": "side:left",
                "hypotheses": [
                    {"label": "servo response @ side:left", "family": "servo_gain",
                     "stage": "servo", "p_value": 1e-30, "total_gain": 5.0},
                    {"label": "set-point delay 1 step(s) @ side:left",
                     "family": "command_delay", "stage": "family", "p_value": 1e-8,
                     "total_gain": 1.0, "significant": True, "material": True},
                    {"label": "set-point delay 2 step(s) @ side:left",
                     "family": "command_delay", "stage": "family", "p_value": 1e-12,
                     "total_gain": 1.4, "significant": True, "material": True}]}}}
    f = lm.standing_facts(report, TRUTH, {"named": [], "found": False, "family_right": False})
    one = f["one_step"][0]["best"][0]
    assert (one["label"], one["scope"], one["rank"], one["of"]) == (
        "command_lag(lag=2, joints=all)", "all", 2, 2)
    full, scoped = f["rollout"]
    assert full["best"][0]["label"] == "command_lag(lag=2, joints=all)"
    assert (full["best"][0]["rank"], full["best"][0]["of"]) == (2, 3) and not full["at_scope"]
    assert scoped["best"][0]["scope"] == "side:left" == scoped["at_scope"][0]["scope"]
    assert [p["where"] for p in f["own_scope"]] == ["rollout round 0, narrower"]
    assert f["contrast"] == [{"label": "command_filter(time_constant_ms=30.0, joints=left)",
                              "kind": "in the reference as well", "family": "command_filter",
                              "scope": "side:left", "p_change": 0.4,
                              "reference_total_gain": 1.2}]
    assert f["change_best"]["label"] == "set-point delay 2 step(s) @ side:left"
    assert [s["label"] for s in f["suspected"]] == ["command_lag(lag=2, joints=left)"]
    assert f["standing"] == "significant at its scope, not material"
    text = "\n".join(lm.fact_lines(f))
    assert "reference_change: ratio 4.00, p 1e-20, scope side:left" in text
    assert "stood: significant at its scope, not material" in text


def test_the_family_named_elsewhere_or_set_aside_stands_before_its_probes():
    report = {"rollout_route": {"rounds": [], "reference": {"shared": [
        {"label": "command_lag(lag=2, joints=left)", "reference": {"p_change": 0.9}}]}}}
    assert (lm.standing_facts(report, TRUTH, {"family_right": True})["standing"]
            == "named its family at another scope")
    assert (lm.standing_facts(report, TRUTH, {})["standing"]
            == "accepted by the search, set aside by the reference contrast")
    assert lm.standing_facts(None, TRUTH, {})["standing"] == "no report or log committed"


LOG = """diagnose: round 0: no effect accepted (3 significant, best gain 0.01) in 20 s
diagnose: reference: 77 TrainPool moves from REF
diagnose: round 0: command_lag(lag=2, joints=all) gain +1.50 p 0.002, heading() gain +0.30 p 1
diagnose: round 0, narrower scopes: command_lag(lag=2, joints=front_left) gain +1.00 p 3e-05, \
command_lag(lag=2, joints=knees) gain +0.80 p 0.001, command_lag(lag=2, joints=right) gain \
+0.50 p 0.002, command_lag(lag=2, joints=back_left) gain +0.40 p 0.003
diagnose: change since the reference: a change since the reference at the left side's joints: \
the reference's model predicts this data's next step 3.00 times as far off as its own held-out \
moves at the left side's joints (p = 1e-20; 1 s rollouts 1.50 times); the best hypothesis \
(set-point delay 2 step(s) @ side:left) removes 40 % of the excess over the data's own model, \
so it is not named
"""


def test_a_log_is_read_in_the_reports_shape():
    """Without report.json: the log's probes (significant at alpha; not material where the
    round's reference line does not list them), the truth's scope the log leaves out of the
    narrower screen's four but the screen's rule probed (p at least the fourth's), and
    reference_change's statement: its family kept, not named."""
    report = lm.report_from_text(LOG, None, alpha=1e-4, narrow_p=1.0)
    rr = report["rollout_route"]
    assert rr["rounds"][0]["scoped"][0] == {
        "label": "command_lag(lag=2, joints=front_left)", "total_gain": 1.0, "p_value": 3e-5,
        "significant": True, "material": False}
    assert rr["reference_change"]["family"] == "command_delay"
    assert rr["reference_change"]["scope"] == "side:left" and not rr["reference_change"]["named"]
    f = lm.standing_facts(report, TRUTH, {})
    inferred = [p for p in f["own_scope"] if p.get("inferred")]
    assert len(inferred) == 1 and inferred[0]["p_at_least"] == 0.003
    assert inferred[0]["significant"] is False
    assert f["standing"] == "kept by the change screen, not named"
    assert lm.label_reading("play(width=0.03, source=u)") == {"family": "backlash",
                                                               "scope": "all"}


def test_a_log_probe_is_not_material_only_where_it_gained_and_the_suspects_are_there():
    """Missing from the round's reference line reads as not material only where the total
    gain is > 0 and, for the position probe, the run's suspects are in results.json; a slope
    whose position probe ran is not "never probed" where the floor is unknown."""
    log = ("diagnose: reference: 77 TrainPool moves from REF\n"
           "diagnose: round 0: heading() gain -0.50 p 1e-06, planar_position() gain +0.90 "
           "p 1e-05, elapsed_time() gain +0.40 p 1e-05\n")
    for suspects, position in ((True, False), (False, None)):
        probes = lm.report_from_text(log, None, alpha=1e-4, narrow_p=1.0, suspects=suspects
                                     )["rollout_route"]["rounds"][0]["probes"]
        assert [p["material"] for p in probes] == [None, position, False]
    f = lm.standing_facts(lm.report_from_text(log, None, alpha=1e-4),
                          {"id": "z02", "family": "ground_slope", "scope": "all"}, {})
    assert f["standing"] == "the position probe ran, its reading as a slope unknown"
    assert "the position probe ran (p 1e-05)" in "\n".join(lm.fact_lines(f))


def test_a_report_md_that_does_not_parse_reads_nothing():
    f = lm.standing_facts(lm.report_from_text(None, "# a report\n\nno rounds here\n"), TRUTH, {})
    assert f["standing"] == "nothing readable"
    assert f["standing"] in lm.STANDINGS


def test_a_committed_run_ties_the_text_to_its_formats():
    """zoo26's first run (report.md and the diagnose log, no report.json): z08, a delay at
    the left side, was picked by the one-step loop but not compared with the reference
    (recorded under another excitation)."""
    run = lm.ROOT / "benchmarks/blind_zoo/zoos/zoo26/runs/run1/learned+reference"
    f = {row["id"]: f for _, row, f in lm.misses(run, run.parents[2] / "truth.yaml")}["z08"]
    assert f["source"] == "report.md and the diagnose log" and f["alpha"] == 1e-4
    assert len(f["one_step"]) == 4 and len(f["rollout"]) == 3
    assert f["standing"] == ("accepted by the search, not compared (reference under another "
                             "excitation)")
