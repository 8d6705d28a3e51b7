"""The learned route of the diagnosis (``diagnose/learned.py``): no twin, k-step rollouts.

Two small pybullet datasets of the same seed (5 and 4 moves per type): one with a steady 1.5 N
push fixed in odom toward +y (a cause the learned model cannot see: it acts through the
heading, which the state drops), one clean. At this size the route runs at alpha = 1e-3 (its
default, 1e-4, is set for 88-move datasets: ``benchmarks/learned_route``). The push, diagnosed
with the clean data as its reference, must be found as a heading effect pointing along +y in
odom, a change since the reference, and must cut the TestPool rollout error; the clean data
alone must raise no alarm, neither a found effect nor unexplained residual structure. The evidence's one-step rollouts are checked against
the one-step residuals computed independently, and the time-drift augmentation against t*(u-q)
computed by hand.
"""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from synthetic import make_recording

from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.data.states import actions_from_recording, states_from_recording
from littledog_mlsim.diagnose.learned import LearnedOptions, diagnose_learned
from littledog_mlsim.layout import CONTROL_DT, N_FEATURE
from littledog_mlsim.models.feature_library import ElapsedTracking
from littledog_mlsim.models.features import CommandLag, ElapsedTime, FeatureSet, Heading

SMALL = LearnedOptions(n_random_features=300, n_gp_points=200, gp_max_iter=30, max_rounds=1,
                       horizons_s=(0.01, 0.5, 1.0, 4.0), start_every=25, alpha=1e-3,
                       push_moves_per_type=1)
LIBRARY = [CommandLag(lag=2), Heading(), ElapsedTime()]


def _record(root: Path, name: str, effects: str | None, per_type: int) -> Path:
    from littledog_mlsim.apps.record import record_dataset
    effects_file = None
    if effects is not None:
        effects_file = root / f"{name}.yaml"
        effects_file.write_text(effects)
    out = root / name
    record_dataset(out, moves_per_type=per_type, seed=5, jobs=2, progress=False,
                   effects_file=None if effects_file is None else str(effects_file))
    return out


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("learned_route")
    return {"push": _record(root, "push", "- class: littledog_mlsim.robot.effects:ConstantWind\n"
                                          "  params: {force_xy: [0.0, 1.5]}\n", 5),
            "clean": _record(root, "clean", None, 4)}


def _run(path: Path) -> dict:
    return diagnose_learned(load_moves(path, "train"), load_moves(path, "test"), options=SMALL,
                            library=LIBRARY)


@pytest.fixture(scope="module")
def push_diagnosis(data, tmp_path_factory):
    """``diagnose --physics off --rollout-route --reference CLEAN`` on the push (no one-step
    rounds): (report, its directory). Its ``rollout_route`` is ``diagnose_learned``'s report."""
    from littledog_mlsim.diagnose import DiagnoseOptions, LearnedRoute, diagnose
    out = tmp_path_factory.mktemp("push_diagnosis") / "d"
    route = LearnedRoute(max_rounds=0, rollout=SMALL, rollout_library=LIBRARY)
    return diagnose(data["push"], out, DiagnoseOptions(
        route=route, reference=data["clean"], method="lr", figures=False, progress=False)), out


def test_world_fixed_push_is_found_along_y_and_cuts_the_rollout_error(push_diagnosis):
    report = push_diagnosis[0]["rollout_route"]
    assert report["significant"], report["rounds"]
    e = report["effects"][0]
    assert e["family"] == "pose (heading)", e
    direction = e["physical"]["direction_deg"]
    assert abs((direction - 90.0 + 180.0) % 360.0 - 180.0) <= 30.0, e["physical"]
    before, after = report["test"]["before"], report["test"]["after"]
    assert after["final_xy_error_m"] < before["final_xy_error_m"], report["test"]
    assert report["verdict"].startswith("found: a steady force fixed in odom of about")
    assert e["physical"]["drift_along_force_mps"] > 0, e["physical"]
    # sized by the drift against the reference over the nominal robot's push response, which
    # is not this robot's (benchmarks/learned_route/push_reading): within a factor of 3
    phys = e["physical"]
    assert phys["push"]["robot"] == "nominal" and phys["drift"]["n_moves"] > 0, phys
    assert 0.5 <= phys["force_N"] <= 4.5, phys
    lo, hi = phys["push"]["force_interval_N"]
    assert lo <= phys["force_N"] <= hi, phys
    assert phys["one_step_free_body_N"] > 0 and "N toward" in e["statement"]
    # with a reference, the options the route ran with are SMALL's, the *_with_reference on
    assert report["options"]["focus_all"] is (SMALL.focus_all or SMALL.focus_all_with_reference)
    assert report["options"]["widen_focus"] is (SMALL.widen_focus
                                                or SMALL.widen_focus_with_reference)


@pytest.fixture(scope="module")
def clean_report(data):
    return _run(data["clean"])


def test_without_a_reference_a_push_has_a_direction_and_no_size():
    from littledog_mlsim.diagnose import learned
    numbers = {"force_N": None, "direction_deg": 91.0}
    text, out = learned._push_in_newtons(numbers, [], None, SMALL, print)
    assert out["force_N"] is None and "needs a reference recording" in text
    text, out = learned._push_in_newtons(numbers, [], [], replace(SMALL, push_robot=None),
                                         print)
    assert out["force_N"] is None and "push_robot is off" in text


def test_clean_data_raises_no_alarm(clean_report):
    report = clean_report
    assert report["significant"] is False, [p for r in report["rounds"] for p in r["probes"]]
    assert report["effects"] == [] and report["residual"]["unexplained"] == []
    assert report["test"]["after"] == report["test"]["before"]
    assert report["verdict"].startswith("nothing significant")
    # no reference: SMALL's own focus_all and widen_focus, whatever the *_with_reference say
    assert report["options"]["focus_all"] is SMALL.focus_all is False
    assert report["options"]["widen_focus"] is SMALL.widen_focus is False


def test_a_one_step_rollout_is_the_one_step_residual(data):
    """The evidence's horizon of one step must equal the held-out one-step residual of the same
    fit at the same rows (clipping aside, which a one-step prediction of measured data never
    reaches), computed here from the model directly."""
    from littledog_mlsim.diagnose import learned
    from littledog_mlsim.diagnose.candidates import measured_robot_features
    train = load_moves(data["clean"], "train")
    fs = measured_robot_features()
    route = learned._Route(train, fs, SMALL, lambda s: None)
    model, ev = route.fit(fs)
    X, Y, mi = fs.features_responses(train)
    offsets = np.concatenate([[0], np.cumsum([s.shape[0] for s in route.mv.S])])
    rows = offsets[ev.move[1]] + ev.t0[1]
    folds = route.fold_of_move[ev.move[1]]
    direct = np.stack([Y[r] - X[r, :33] - model.predict(X[r:r + 1], int(f))[0]
                       for r, f in zip(rows, folds)])
    np.testing.assert_allclose(ev.err[1], direct, rtol=1e-9, atol=1e-12)
    # the odom residual of one step is the body displacement residual turned into odom
    assert np.all(np.linalg.norm(ev.odom[1], axis=1) <= np.linalg.norm(ev.err[1][:, 1:4], axis=1)
                  + 1e-12)


def test_elapsed_tracking_is_time_times_tracking_error_in_batch_and_online():
    recs = [make_recording(f"F_0{i}", n=60, yaw0=0.3 * i, yaw_rate=0.5, seed=i) for i in range(2)]
    aug = ElapsedTracking(joints="knees")
    fs = FeatureSet((aug,))
    X, _, mi = fs.features_responses(recs)
    for i, r in enumerate(recs):
        s = states_from_recording(r)[:-1]
        u = actions_from_recording(r)[1:]
        t = np.arange(s.shape[0]) * CONTROL_DT
        knees = [2, 5, 8, 11]
        expect = t[:, None] * (u[:, knees] - s[:, 9:21][:, knees])
        np.testing.assert_allclose(X[mi == i, N_FEATURE:], expect, rtol=1e-12, atol=1e-15)
        h = fs.history(s[0])
        Y = states_from_recording(r)[1:]
        for k in range(s.shape[0]):
            np.testing.assert_allclose(h.features(u[k])[N_FEATURE:], expect[k], rtol=1e-12,
                                       atol=1e-15)
            h.push(Y[k])


def test_swing_rate_is_the_joint_rate_weighted_by_its_legs_commanded_lift():
    """``SwingRate``: dq_j times its leg's commanded lift over SWING_LIFT_M, clipped to [0, 1],
    the same in batch and online; it reads as a contact-phase effect of the leg it is scoped
    to."""
    from littledog_mlsim.diagnose.families.learned import physical_reading
    from littledog_mlsim.models.feature_library import (SWING_LIFT_M, CommandedLift,
                                                        SwingRate)
    recs = [make_recording(f"F_0{i}", n=60, yaw0=0.3 * i, yaw_rate=0.5, seed=i) for i in range(2)]
    aug = SwingRate(joints="back_left")
    fs = FeatureSet((aug, CommandedLift()))
    X, _, mi = fs.features_responses(recs)
    lift = X[:, N_FEATURE + 3:N_FEATURE + 7]               # per leg, contract order
    assert np.any(lift[:, 2] > SWING_LIFT_M) and np.any(lift[:, 2] <= 0.0), "no swing, no stance"
    dq = X[:, 21:33][:, [6, 7, 8]]                          # the back-left leg's joint rates
    expect = np.clip(lift[:, [2]] / SWING_LIFT_M, 0.0, 1.0) * dq
    np.testing.assert_allclose(X[:, N_FEATURE:N_FEATURE + 3], expect, rtol=1e-12, atol=1e-15)
    for i, r in enumerate(recs):
        s = states_from_recording(r)[:-1]
        u = actions_from_recording(r)[1:]
        h = fs.history(s[0])
        Y = states_from_recording(r)[1:]
        rows = X[mi == i]
        for k in range(s.shape[0]):
            np.testing.assert_allclose(h.features(u[k])[N_FEATURE:], rows[k, N_FEATURE:],
                                       rtol=1e-12, atol=1e-15)
            h.push(Y[k])
    reading = physical_reading(aug)
    assert (reading["family"], reading["scope"]) == ("contact_phase", "leg:back_left")


def test_too_few_moves_is_a_clear_error():
    recs = [make_recording(f"F_0{i}", n=30, seed=i) for i in range(4)]
    with pytest.raises(ValueError, match="diagnose_learned: needs at least 10 TrainPool moves"):
        diagnose_learned(recs, recs[:1], options=SMALL)


def test_diagnose_rollout_route_adds_what_it_accepts_to_the_report_model(data, push_diagnosis):
    """``diagnose --physics off --rollout-route --reference CLEAN`` as a function: the one-step
    loop (no rounds here), then the rollout route, each finding contrasted with the clean
    recording; its push is a change, in ``rollout_route``, its augmentation is the report
    model's last stage, and report.md says what it found."""
    report, out = push_diagnosis
    assert "contrasted with the reference" in report["route"]["why"]
    r = report["rollout_route"]
    assert r["significant"] and r["effects"][0]["family"] == "pose (heading)", r["rounds"]
    c = r["effects"][0]["reference"]
    assert c["changed"] and c["reference_total_gain"] < r["effects"][0]["total_gain"], c
    assert r["reference"] == {"n_moves": len(load_moves(data["clean"], "train")), "shared": [],
                              "not_comparable": [],
                              "conditions": {"data_excitation_rad": 0.0,
                                             "reference_excitation_rad": 0.0,
                                             "comparable": True}}
    assert report["reference_conditions"] == r["reference"]["conditions"]
    assert report["effects"] == [] and len(report["stages"]) == 1 + len(r["effects"])
    last = report["after"]["feature_set"]
    assert last == report["stages"][-1]["feature_set"] != report["before"]["feature_set"]
    assert any(a.get("name") == "heading" or "heading" in str(a) for a in last["augmentations"])
    assert [(s["label"], s["recording"]) for s in report["suspected"]] == [
        (s["label"], s["recording"]) for s in r["suspected"]]
    # the push explains the change: no excess over the reference is left (decision 026)
    u = r["unexplained_change"]
    assert not u["significant"] and u["ratio"] < 1.5 and u["n_reference_moves"] > 0, u
    md = (out / "report.md").read_text()
    assert "## Rollout route" in md and r["effects"][0]["label"] in md
    assert "Against the reference: an unexplained change since the reference" in md


def test_every_rollout_route_key_is_documented(push_diagnosis):
    """docs/report.md lists every key of the rollout route's report, of its effects and of its
    change screen, each in its own section."""
    from report_docs import documented_report_keys
    known = documented_report_keys()
    r = push_diagnosis[0]["rollout_route"]
    blocks = [(r, "Rollout route", "rollout_route"),
              (r["reference_change"], "The change screen (`reference_change`)",
               "rollout_route.reference_change")]
    blocks += [(e, "Rollout-route effects", f"rollout_route.effects[{i}]")
               for i, e in enumerate(r["effects"])]
    assert r["effects"]
    missing = [f"{where}.{k}" for block, section, where in blocks for k in block
               if k not in known[section]]
    assert missing == []


@pytest.mark.slow   # make test keeps decision 031's parts: test/diagnose/test_conditions.py
def test_against_a_reference_of_another_excitation_a_command_response_is_no_change(
        data, tmp_path, monkeypatch):
    """Decision 031 end to end: the push against the clean recording whose ``dataset.yaml``
    says it was made with command excitation, the heading family marked as one excitation
    shows (its attribute, monkeypatched). The finding is carried by the report model but listed
    under ``reference.not_comparable``, and decision 026's reading is kept but not significant:
    the diagnosis raises nothing, and says which reference would settle it."""
    import shutil

    import yaml

    from littledog_mlsim.diagnose import DiagnoseOptions, LearnedRoute, diagnose
    from littledog_mlsim.diagnose.conditions import Conditions
    from littledog_mlsim.diagnose.families.learned import learned_family
    ref = tmp_path / "excited_reference"
    shutil.copytree(data["clean"], ref)
    index = yaml.safe_load((ref / "dataset.yaml").read_text())
    index["info"]["command_excitation_rad"] = 0.05
    (ref / "dataset.yaml").write_text(yaml.safe_dump(index, sort_keys=False))
    monkeypatch.setattr(learned_family("pose (heading)"), "excitation_shows", True)
    route = LearnedRoute(max_rounds=0, rollout=SMALL, rollout_library=LIBRARY)
    report = diagnose(data["push"], tmp_path / "d", DiagnoseOptions(
        route=route, reference=ref, method="lr", figures=False, progress=False))
    cond = Conditions(0.0, 0.05)
    r = report["rollout_route"]
    assert report["reference_conditions"] == r["reference"]["conditions"] == cond.to_dict()
    assert r["effects"] == [] and r["significant"] is False and report["significant"] is False
    (e,) = r["reference"]["not_comparable"]
    assert e["family"] == "pose (heading)" and not e["reference"]["changed"], e
    assert e["reference"]["comparable"] is False
    assert (e["why"], e["recording"]) == (cond.why, cond.recording)
    assert r["reference"]["shared"] == []
    u, rc = r["unexplained_change"], r["reference_change"]
    assert u["comparable"] is False and u["significant"] is False and u["ratio"] > 0, u
    assert rc["comparable"] is False and not rc["significant"] and not rc["named"]
    assert u["statement"].startswith("not compared: ") and u["recording"] == cond.recording
    # the report model carries the heading columns all the same
    assert len(report["stages"]) == 2
    assert "heading" in str(report["after"]["feature_set"]["augmentations"])
    assert "the reference cannot tell whether these are changes" in r["verdict"]
    md = (tmp_path / "d" / "report.md").read_text()
    assert f"- the reference cannot tell: `{e['label']}` (the model keeps it)" in md


def test_a_finding_the_reference_shows_as_much_is_no_change(data):
    """``contrast``: the push's heading columns on every other TrainPool move of the push
    recording, with the other moves (the same push) as the reference: they gain there too, so
    it is no change (the robot's own). The changed case, against the clean recording, is the
    test above."""
    from littledog_mlsim.diagnose import learned
    from littledog_mlsim.diagnose.candidates import measured_robot_features
    train = load_moves(data["push"], "train")
    fs = measured_robot_features()
    route = learned._Route(train[0::2], fs, SMALL, lambda s: None)
    _, ev0 = route.fit(fs)
    probe = route.probe(fs, ev0, Heading(), 1)
    assert probe.total_gain > 0, probe.to_dict()
    c = learned.contrast(route, learned._Route(train[1::2], fs, SMALL, lambda s: None), fs,
                         probe)
    assert not c["changed"] and c["p_change"] > 0.01 and c["reference_total_gain"] > 0, c


def test_a_candidates_fit_reuses_the_random_features_and_skips_the_one_step_residuals(data):
    """A candidate's fit copies the TrainPool's random features, made once per process (the
    same numbers as made again; not pickled to a worker), and leaves out the one-step residuals
    its decision does not use: its rollout evidence is the same bit for bit."""
    import pickle

    from littledog_mlsim.diagnose import learned
    from littledog_mlsim.diagnose.candidates import measured_robot_features
    train = load_moves(data["clean"], "train")
    fs = measured_robot_features()
    route = learned._Route(train, fs, SMALL, lambda s: None)
    X, _, _ = fs.with_augmentation(Heading()).features_responses(train)
    mean, std = X.mean(axis=0), X.std(axis=0) + 1.0
    cached = route.design.basis(X, mean, std)
    assert route.design._block is not None
    again = replace(route.design, _key=None).basis(X, mean, std)
    assert np.array_equal(cached, again)
    shipped = pickle.loads(pickle.dumps(route.design))
    assert shipped._block is None and np.array_equal(shipped.basis(X, mean, std), cached)
    rows = route.design.basis(X[:7], mean, std)           # other rows: made, not copied
    assert np.array_equal(rows, replace(route.design, _key=None).basis(X[:7], mean, std))
    full = route.fit(fs.with_augmentation(Heading()))[1]
    probe = route.fit(fs.with_augmentation(Heading()), one_step=False)[1]
    assert probe.one_step is None and probe.one_step_std is None
    assert full.one_step.shape == full.one_step_std.shape == (X.shape[0], 33)
    for h in full.horizons:
        for a, b in ((full.err, probe.err), (full.odom, probe.odom), (full.body, probe.body),
                     (full.move, probe.move), (full.t0, probe.t0)):
            assert np.array_equal(a[h], b[h])


def test_a_shared_finding_is_carried_by_the_model_and_reported_as_no_change():
    """The report's side of a finding the reference shows as much: the report model carries it
    (``run._accepted``), the verdict and report.md say it is the robot's own."""
    from littledog_mlsim.diagnose import learned, run
    from littledog_mlsim.diagnose.report import _md_rollout_route
    from littledog_mlsim.diagnose.candidates import measured_robot_features
    entry = {"label": "heading()", "gain": 2.5, "statement": "a steady force fixed in odom",
             "augmentation": Heading().to_dict(),
             "reference": {"reference_total_gain": 2.4, "p_change": 0.6, "changed": False}}
    r = {"effects": [], "suspected": [], "reference": {"n_moves": 40, "shared": [entry]},
         "residual": {"unexplained": [], "smallest_p": 1.0}}
    fs = measured_robot_features()
    assert [a.label() for a in run._accepted(r, fs)] == ["heading()"]
    r["verdict"] = learned._verdict(r)
    assert r["verdict"] == ("in the reference as well (the robot's own, carried by the model; "
                            "not a change since it): a steady force fixed in odom")
    md = "\n".join(_md_rollout_route(r))
    assert ("in the reference as well: `heading()` (gain 2.50 here, 2.40 on the reference; p of "
            "a change 0.6)") in md


def _one_blas_thread_or_skip() -> None:
    from threadpoolctl import threadpool_info
    if any(p["internal_api"] in ("openblas", "mkl", "blis") and p["num_threads"] != 1
           for p in threadpool_info()):
        pytest.skip("compares with this process's probes at one BLAS thread: run with "
                    "OPENBLAS_NUM_THREADS=1 (make test sets it)")


@pytest.fixture(scope="module")
def probed_here(data):
    """The clean data's route, its start's evidence and two candidates' probes in this
    process (a route's probes are what ``jobs`` and ``scheduler`` send out)."""
    from littledog_mlsim.diagnose.candidates import measured_robot_features
    from littledog_mlsim.diagnose.learned import _Route
    _one_blas_thread_or_skip()
    fs = measured_robot_features()
    route = _Route(load_moves(data["clean"], "train"), fs, SMALL, lambda s: None)
    _, ev0 = route.fit(fs)
    here = route.probes(fs, ev0, LIBRARY[:2], len(LIBRARY))
    return route, fs, ev0, json.dumps([p.to_dict() for p in here], sort_keys=True, default=str)


def test_a_routes_probes_in_worker_processes_and_on_a_dask_cluster_are_its_own(probed_here):
    """``_Route.local`` (two spawned processes, one BLAS thread each) and ``_Route.remote`` (a
    real scheduler and two worker processes) give the probes this process gives."""
    distributed = pytest.importorskip("distributed")
    route, fs, ev0, here = probed_here
    try:
        route.local(2)
        pool = route.probes(fs, ev0, LIBRARY[:2], len(LIBRARY))
    finally:
        route.close()
    assert json.dumps([p.to_dict() for p in pool], sort_keys=True, default=str) == here
    with distributed.LocalCluster(host="127.0.0.1", dashboard_address=None, n_workers=2,
                                  threads_per_worker=1, processes=True) as cluster:
        try:
            route.remote(distributed.Client(cluster.scheduler_address))
            remote = route.probes(fs, ev0, LIBRARY[:2], len(LIBRARY))
        finally:
            route.close()
    assert json.dumps([p.to_dict() for p in remote], sort_keys=True, default=str) == here


def test_jobs_and_scheduler_send_the_routes_probes_out(data, monkeypatch):
    """``diagnose_learned``'s ``jobs`` starts the route's worker processes and ``scheduler``
    connects it to the cluster, before the search (replaced here: it reports where the probes
    would run)."""
    distributed = pytest.importorskip("distributed")
    from littledog_mlsim.diagnose import learned

    def where(route, *args):
        return {"pool": route.pool is not None, "client": route.client is not None}
    monkeypatch.setattr(learned, "_search", where)
    moves = load_moves(data["clean"], "train"), load_moves(data["clean"], "test")
    assert diagnose_learned(*moves, options=SMALL, library=LIBRARY, jobs=2) == \
        {"pool": True, "client": False}
    with pytest.raises(ValueError, match="jobs must be >= 1"):
        diagnose_learned(*moves, options=SMALL, library=LIBRARY, jobs=0)
    with distributed.LocalCluster(host="127.0.0.1", dashboard_address=None, n_workers=1,
                                  threads_per_worker=1, processes=True) as cluster:
        assert diagnose_learned(*moves, options=SMALL, library=LIBRARY, jobs=2,
                                scheduler=cluster.scheduler_address) == \
            {"pool": False, "client": True}


# make test keeps the two above: a route's probes out and in, and the options that send them
@pytest.mark.slow
def test_probes_on_a_dask_cluster_give_the_local_report(data, clean_report):
    """``scheduler``: the probes (cross-fits and their rollouts) on a real scheduler and two
    worker processes; the report is the local one (wall time aside). On the clean data (the
    screen's probes only: a found effect's scope and parameter probes go through the same
    ``_Route.probes``)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(host="127.0.0.1", dashboard_address=None, n_workers=2,
                                  threads_per_worker=1, processes=True) as cluster:
        remote = diagnose_learned(load_moves(data["clean"], "train"),
                                  load_moves(data["clean"], "test"), options=SMALL,
                                  library=LIBRARY, scheduler=cluster.scheduler_address)
    local = dict(clean_report)
    assert remote.pop("seconds") > 0 and local.pop("seconds") > 0
    assert len(remote["rounds"][0]["probes"]) == len(LIBRARY)
    assert json.dumps(remote, sort_keys=True, default=str) == \
        json.dumps(local, sort_keys=True, default=str)


@pytest.mark.slow
def test_probes_in_local_worker_processes_give_the_one_job_report(data, clean_report,
                                                                 monkeypatch):
    """``jobs`` 2: the probes in two spawned worker processes (the route sent to each once);
    the report is the one-job one (wall time aside) made at one BLAS thread, as make test runs
    the suite and the search runs with workers."""
    from threadpoolctl import threadpool_info

    from littledog_mlsim.diagnose import learned
    if any(p["internal_api"] in ("openblas", "mkl", "blis") and p["num_threads"] != 1
           for p in threadpool_info()):
        pytest.skip("compares with the one-job report at one BLAS thread: run with "
                    "OPENBLAS_NUM_THREADS=1 (make test sets it)")
    pools = []
    start = learned._Route.local

    def counted(route, jobs):
        start(route, jobs)
        pools.append((jobs, route.pool))
    monkeypatch.setattr(learned._Route, "local", counted)
    two = diagnose_learned(load_moves(data["clean"], "train"), load_moves(data["clean"], "test"),
                           options=SMALL, library=LIBRARY, jobs=2)
    assert len(pools) == 1 and pools[0][0] == 2 and pools[0][1] is not None
    local = dict(clean_report)
    assert two.pop("seconds") > 0 and local.pop("seconds") > 0
    assert len(two["rounds"][0]["probes"]) == len(LIBRARY)
    assert json.dumps(two, sort_keys=True, default=str) == \
        json.dumps(local, sort_keys=True, default=str)
    with pytest.raises(ValueError, match="jobs must be >= 1"):
        diagnose_learned(load_moves(data["clean"], "train"), load_moves(data["clean"], "test"),
                         options=SMALL, library=LIBRARY, jobs=0)


def test_unreachable_scheduler_is_one_line(data):
    with pytest.raises(ValueError, match="cannot connect to the Dask scheduler tcp://127.0.0.1:9"):
        diagnose_learned(load_moves(data["clean"], "train"), load_moves(data["clean"], "test"),
                         options=SMALL, library=LIBRARY, scheduler="tcp://127.0.0.1:9")


def _probe(joints: str, move_gains, total: float):
    from types import SimpleNamespace
    d = np.outer(np.asarray(move_gains, float), np.full(33, 1.0 / 33))
    return SimpleNamespace(aug=ElapsedTracking(joints=joints), total_gain=total,
                           decision=SimpleNamespace(state=SimpleNamespace(d=d)))


def test_the_scope_widens_only_where_the_wider_scope_gains_on_most_moves():
    """A drift on every joint that matters most in the knees: the knees are within the
    parsimony tolerance of all joints, and all joints gain a little more on nearly every move,
    so the scope widens. Where the extra gain is noise, the knees stay, and the report says
    the data cannot tell them from all joints."""
    from littledog_mlsim.diagnose.learned import _scope_rivals, _widen
    rng = np.random.default_rng(0)
    knees_gain = 0.08 + 0.02 * rng.random(60)
    knees = _probe("knees", knees_gain, 4.8)
    hips = _probe("hip_pitches", 0.5 * knees_gain, 2.4)
    everywhere = _probe("all", knees_gain + 0.004 + 0.002 * rng.standard_normal(60), 5.0)
    chosen, wider = _widen(knees, [everywhere, knees, hips], 0.01)
    assert chosen is everywhere and wider == {}
    noise = _probe("all", knees_gain + 0.004 * rng.standard_normal(60), 4.9)
    chosen, wider = _widen(knees, [noise, knees, hips], 0.01)
    assert chosen is knees and wider["elapsed_tracking(joints=all)"] >= 0.01
    # a scope that does not contain the chosen one is never taken
    assert _widen(hips, [knees, hips], 0.01) == (hips, {})
    # the report names the wider scope it cannot tell from the one kept
    scan = [{"label": "elapsed_tracking(joints=all)", "total_gain": 4.9, "p_value": 1e-6,
             "p_wider": wider["elapsed_tracking(joints=all)"]},
            {"label": "elapsed_tracking(joints=knees)", "total_gain": 4.8, "p_value": 1e-6,
             "kept_scope": True},
            {"label": "command_lag(lag=9)", "total_gain": 9.0, "p_value": 1e-9,
             "stage": "parameter"}]   # a parameter member does not set the tolerance
    rivals = _scope_rivals(scan, 0.1, 0.01)
    assert [r["label"] for r in rivals] == ["elapsed_tracking(joints=all)"]
    assert rivals[0]["kept"] == "elapsed_tracking(joints=knees)"
    assert rivals[0]["kept_total_gain"] == 4.8
    assert _scope_rivals([{**scan[0], "total_gain": 3.0}, scan[1]], 0.1, 0.01) == []
    assert _scope_rivals(scan[:1], 0.1, 0.01) == []    # no scope kept (the fallback)


def test_widen_focus_takes_all_joints_where_the_added_joints_own_error_falls():
    """``widen_focus``: a drift on every joint kept at the right side by parsimony (the side
    carries nearly all the total gain, and all joints' extra total gain is noise move by
    move) is widened to all joints when the left joints' own q and dq error falls on most
    moves with all joints' columns; without the option, or where the left joints' cut is
    noise too, the side stays."""
    from types import SimpleNamespace

    from littledog_mlsim.diagnose.learned import _widen
    from littledog_mlsim.layout import S
    from littledog_mlsim.models.feature_library import JOINT_GROUPS
    rng = np.random.default_rng(3)
    M = 60
    left = [S.q.start + k for k in JOINT_GROUPS["left"]] + [
        S.dq.start + k for k in JOINT_GROUPS["left"]]

    def probe(joints, d):
        return SimpleNamespace(aug=ElapsedTracking(joints=joints), total_gain=float(
            d.sum(axis=1).mean()), decision=SimpleNamespace(state=SimpleNamespace(d=d)))
    base = np.abs(rng.normal(0.003, 0.001, (M, 33)))
    right = probe("right", base)
    sd = np.full(33, 0.03)                # the rest of the state: noise move by move
    sd[left] = 0.002

    def noisy(shift):
        d = base + sd * rng.standard_normal((M, 33))
        d[:, left] += shift
        return d
    everywhere = probe("all", noisy(0.002))              # the left joints gain
    assert _widen(right, [everywhere, right], 0.01)[0] is right
    assert _widen(right, [everywhere, right], 0.01, added=True)[0] is everywhere
    assert _widen(right, [probe("all", noisy(0.0)), right], 0.01, added=True)[0] is right
    # a wider scope whose added joints gain but whose total is below the kept one's stays out
    lower = probe("all", noisy(0.002) - 0.01)
    assert lower.total_gain < right.total_gain
    assert _widen(right, [lower, right], 0.01, added=True)[0] is right


def test_a_wider_scope_within_the_tolerance_widens_on_the_move_by_move_test():
    """``widen_within_tolerance``: a drift on every joint whose right side alone gains a little
    more in total (within parsimony's tolerance) is widened to all joints where all joints gain
    more on most moves; without the tolerance it stays at the side, and a wider scope whose
    total is beyond the tolerance stays out either way."""
    from littledog_mlsim.diagnose.learned import _widen
    rng = np.random.default_rng(5)
    side_gain = 0.30 + 0.05 * rng.random(60)
    right = _probe("right", side_gain, 21.66)
    everywhere = _probe("all", side_gain + 0.01 + 0.002 * rng.standard_normal(60), 21.34)
    assert _widen(right, [everywhere, right], 0.01)[0] is right
    assert _widen(right, [everywhere, right], 0.01, tolerance=0.1)[0] is everywhere
    far = _probe("all", side_gain + 0.01 + 0.002 * rng.standard_normal(60), 15.0)
    assert _widen(right, [far, right], 0.01, tolerance=0.1)[0] is right


def test_a_round_takes_only_what_cuts_the_total_and_recounts_a_kept_scopes_focus_choices():
    """A probe significant and material on some elements that raises the total held-out
    rollout error is not taken (``_accepted``): it is a suspect that says so. A screen's
    contrast reused for the scope the stage kept is Bonferroni over the scopes it was kept
    among (``_chosen_among``), from the same tests (``stats.contrast_combined``, the ``p`` of
    ``contrast_test``)."""
    from types import SimpleNamespace

    from littledog_mlsim.diagnose.learned import (NO_TOTAL_GAIN, _accepted, _chosen_among,
                                                  _suspect)
    from littledog_mlsim.diagnose.stats import (contrast_combined, contrast_focus_p,
                                                contrast_test)
    rng = np.random.default_rng(5)
    d = _synthetic_decision(rng, 40, 0.6)
    assert d.significant and d.material
    good = SimpleNamespace(aug=CommandLag(lag=2), decision=d, total_gain=0.3,
                           to_dict=lambda: {"label": "command_lag"})
    worse = SimpleNamespace(aug=CommandLag(lag=2), decision=d, total_gain=-0.1,
                            to_dict=lambda: {"label": "command_lag"})
    assert _accepted(good) and not _accepted(worse)
    assert _suspect(worse, 7.0, reference=False)["why"] == NO_TOTAL_GAIN
    a, b, fa, fb = (rng.normal(0.02, 0.05, 40), rng.normal(0.0, 0.05, 40),
                    rng.normal(0.03, 0.05, 40), rng.normal(0.0, 0.05, 40))
    ra, rb = rng.normal(0.1, 0.3, 40), rng.normal(0.0, 0.3, 40)
    for choices in (1, 9, 14):
        p_state, p_path, p = contrast_test(a, b, ra, rb, fa, fb, focus_choices=choices)
        assert p == contrast_combined(p_state, p_path, contrast_focus_p(fa, fb), choices)
    p_state, p_path, p1 = contrast_test(a, b, ra, rb, fa, fb, focus_choices=1)
    c = {"p_state": p_state, "p_path": p_path, "p_focus": contrast_focus_p(fa, fb),
         "focus_choices": 1, "p_change": p1, "n_contrasts": 2, "changed": True}
    again = _chosen_among(c, 12, 0.01)
    assert again["focus_choices"] == 12
    assert again["p_change"] == contrast_combined(p_state, p_path, c["p_focus"], 12) >= p1
    assert again["changed"] == (min(1.0, 2 * again["p_change"]) < 0.01)
    assert _chosen_among({**c, "focus_choices": 20}, 12, 0.01)["focus_choices"] == 20
    no_focus = {k: v for k, v in c.items() if k not in ("p_focus", "focus_choices")}
    assert _chosen_among(no_focus, 12, 0.01) is no_focus


def test_a_kept_leg_narrows_to_the_joint_that_carries_the_gain():
    """The scope stage of ``_refine`` tries the single joints of a kept leg, joint type or side:
    play on one hip pitch is named at that joint, not at its leg; where the leg's other joints
    add gain on most moves, the leg stays; a swing-phase feature (a force on the whole foot)
    never narrows to one joint; ``joint_scopes=False`` turns the stage off."""
    from types import SimpleNamespace
    from littledog_mlsim.diagnose.learned import _joint_members, _refine
    from littledog_mlsim.models.feature_library import Play, SwingRate
    rng = np.random.default_rng(3)
    base = 0.1 + 0.02 * rng.random(40)

    def gains(aug, spread):
        j = aug.joints
        if j == "front_left_hip_pitch":
            return 1.0 * base
        if j == "front_left":
            return (1.0 + spread) * base + 0.005 * rng.standard_normal(40)
        return 0.2 * base

    def route(spread, opts=LearnedOptions()):
        calls = []

        class Route:
            def probes(self, fs, ev0, augs, n):
                calls.append([a.label() for a in augs])
                return [SimpleNamespace(aug=a, total_gain=float(gains(a, spread).sum()),
                                        decision=SimpleNamespace(p_value=1e-6, state=SimpleNamespace(
                                            d=np.outer(gains(a, spread), np.full(33, 1 / 33)))))
                        for a in augs]
        Route.opts = opts
        return Route(), calls

    first_aug = Play(width=0.03, source="u", joints="front_left")
    r, calls = route(0.02)
    first = r.probes(None, None, [first_aug], 1)[0]
    best, scan = _refine(r, FeatureSet(), None, first, 16)
    assert best.aug.joints == "front_left_hip_pitch", scan
    assert [e["label"] for e in scan if e.get("kept_scope")] == [best.aug.label()]
    r, calls = route(0.5)                  # the leg's other joints carry half as much again
    best, _ = _refine(r, FeatureSet(), None, r.probes(None, None, [first_aug], 1)[0], 16)
    assert best.aug.joints == "front_left"
    r, calls = route(0.02, LearnedOptions(joint_scopes=False))
    best, _ = _refine(r, FeatureSet(), None, r.probes(None, None, [first_aug], 1)[0], 16)
    assert best.aug.joints == "front_left"
    assert not any("hip_pitch)" in c for cs in calls for c in cs)
    assert _joint_members(SwingRate(joints="front_left")) == []
    assert [a.joints for a in _joint_members(Play(joints="knees"))] == [
        f"{leg}_knee" for leg in ("front_left", "front_right", "back_left", "back_right")]
    assert _joint_members(Play()) == [] and _joint_members(Heading()) == []


def test_the_rollout_routes_suspects_are_the_reports_in_the_vocabulary():
    """report.json's top-level ``suspected`` on the learned route: each rollout-route suspect
    as the physical route states one (family, scope, params in the vocabulary, why, the
    recording that would settle it), with its probe's label and p."""
    from littledog_mlsim.diagnose.families.learned import physical_reading
    from littledog_mlsim.diagnose.report import _rollout_suspects
    lag = CommandLag(lag=2, joints="back_left")
    r = {"suspected": [{"label": lag.label(), "p_value": 3.4e-4,
                        "why": "not significant at alpha (p within 10 alpha)",
                        "recording": "record with command excitation (record --excitation 0.05)",
                        "vocabulary": physical_reading(lag), "settle_moves_per_type": 12}]}
    (s,) = _rollout_suspects(r)
    assert (s["family"], s["scope"], s["params"]) == ("command_delay", "leg:back_left",
                                                      {"delay_ms": 20.0})
    assert s["recording"].endswith("--excitation 0.05)") and s["p_value"] == 3.4e-4
    assert s["label"] == lag.label() and s["why"].startswith("not significant")
    assert s["settle_moves_per_type"] == 12
    assert _rollout_suspects(None) == [] and _rollout_suspects({"suspected": []}) == []
    # with a reference, an excited recording asks for an excited reference too
    from littledog_mlsim.diagnose.learned import _family_recording
    assert _family_recording(lag) == "record with command excitation (record --excitation 0.05)"
    assert _family_recording(lag, reference=True).endswith(", and the reference the same way")
    assert "reference" not in _family_recording(Heading(), reference=True)


def test_play_on_some_joints_is_those_columns_of_play_on_all():
    """``Play(joints=G)`` gives the columns of ``Play()`` for the joints of G, in batch and
    online."""
    from littledog_mlsim.models.feature_library import JOINT_GROUPS, Play
    recs = [make_recording(f"F_0{i}", n=60, yaw0=0.3 * i, yaw_rate=0.5, seed=i) for i in range(2)]
    whole, _, mi = FeatureSet((Play(width=0.03, source="u"),)).features_responses(recs)
    for g in ("knees", "back_left", "front_left_hip_pitch"):
        cols = list(JOINT_GROUPS[g])
        fs = FeatureSet((Play(width=0.03, source="u", joints=g),))
        part, _, _ = fs.features_responses(recs)
        np.testing.assert_array_equal(part[:, N_FEATURE:], whole[:, N_FEATURE:][:, cols])
        assert fs.augmentations[0].columns() == tuple(Play(source="u").columns()[j] for j in cols)
        r = recs[1]
        s, u = states_from_recording(r)[:-1], actions_from_recording(r)[1:]
        h, Y = fs.history(s[0]), states_from_recording(r)[1:]
        for k in range(s.shape[0]):
            np.testing.assert_allclose(h.features(u[k])[N_FEATURE:], part[mi == 1][k, N_FEATURE:],
                                       rtol=1e-12, atol=1e-15)
            h.push(Y[k])
    with pytest.raises(Exception, match="play: unknown group"):
        Play(joints="tail")


def _walks(slope_deg: float, uphill_deg: float, rng) -> list:
    """Recordings whose body walks straight out from the origin in 11 directions over a floor
    inclined by ``slope_deg`` rising towards ``uphill_deg``, the body bobbing 2 mm."""
    from types import SimpleNamespace
    g = np.tan(np.radians(slope_deg)) * np.array([np.cos(np.radians(uphill_deg)),
                                                  np.sin(np.radians(uphill_deg))])
    out = []
    for a in np.linspace(0, 2 * np.pi, 11, endpoint=False):
        xy = np.outer(np.linspace(0, 0.4, 401), [np.cos(a), np.sin(a)])
        z = 0.138 + xy @ g + 0.002 * np.sin(np.arange(401) * 0.6) + rng.normal(0, 5e-4, 401)
        out.append(SimpleNamespace(position=np.column_stack([xy, z])))
    return out


def test_a_position_effect_on_an_inclined_floor_is_named_a_slope():
    from littledog_mlsim.diagnose.families.learned import floor_plane, physical_reading
    from littledog_mlsim.diagnose.learned import physical_statement, vocabulary_reading
    from littledog_mlsim.models.feature_library import PlanarPosition
    rng = np.random.default_rng(0)
    floor = floor_plane(_walks(2.0, 200.0, rng))
    assert abs(floor["slope_deg"] - 2.0) < 0.05 and abs(floor["uphill_direction_deg"] - 200) < 2
    assert floor["r2"] > 0.9
    reading = physical_reading(PlanarPosition(), floor)
    assert (reading["family"], reading["scope"]) == ("ground_slope", "body")
    assert abs(reading["params"]["slope_deg"] - 2.0) < 0.05
    text, numbers = physical_statement(PlanarPosition(), None, None, None, 2.5, 1.0, floor)
    assert "inclined by about 2.0 deg" in text and numbers["slope_deg"] == floor["slope_deg"]
    assert vocabulary_reading(PlanarPosition(), numbers, text, floor)["family"] == "ground_slope"
    flat = floor_plane(_walks(0.0, 0.0, rng))                 # a flat floor: no plane to read
    assert flat["r2"] < 0.05
    assert physical_reading(PlanarPosition(), flat)["family"] == "other"
    assert physical_reading(PlanarPosition())["family"] == "other"
    assert floor_plane([]) is None
    from types import SimpleNamespace                          # all along one line: no plane
    line = np.column_stack([np.linspace(0, 1, 50), np.full(50, 0.3), np.full(50, 0.14)])
    assert floor_plane([SimpleNamespace(position=line)]) is None


def test_start_spread_says_when_position_follows_the_move():
    """Moves that all start at one place and heading leave position a function of the move's
    type and time (a position effect is then only suspected, unless a floor plane backs it);
    moves started from their own places and headings do not."""
    from types import SimpleNamespace

    from littledog_mlsim.diagnose.families.learned import start_spread
    from littledog_mlsim.rotations import rpy_to_quat
    rng = np.random.default_rng(4)

    def moves(xy_sd, yaw_sd):
        return [SimpleNamespace(position=np.array([[*rng.normal(0, xy_sd, 2), 0.14]]),
                                orientation=rpy_to_quat(np.array([0.0, 0.0, rng.normal(0, yaw_sd)])
                                                        )[None, :]) for _ in range(40)]
    same = start_spread(moves(3e-4, 1e-3))                     # motion-capture noise only
    assert same["confounded"] and same["xy_sd_m"] < 1e-3 and same["heading_sd_rad"] < 5e-3
    assert not start_spread(moves(0.3, 1e-3))["confounded"]    # several places
    assert not start_spread(moves(3e-4, 1.0))["confounded"]    # several headings
    wrapped = start_spread(moves(3e-4, 1e-3) + [SimpleNamespace(   # headings around +-pi
        position=np.array([[0.0, 0.0, 0.14]]),
        orientation=rpy_to_quat(np.array([0.0, 0.0, np.pi - 1e-3]))[None, :])])
    assert wrapped["heading_sd_rad"] > 0.1
    assert start_spread([])["confounded"]


def test_a_round_with_nothing_at_full_scope_screens_the_narrower_scopes_at_their_own_level():
    """The narrower screen (``screen_narrower``): only families whose full-scope probe gained
    with p at most ``narrow_p`` expand, to every narrower scope (never all joints again), at the
    scoped Bonferroni factor; the two screens share alpha (a quarter to the narrower one by
    default) over every member either could test (``screen_sizes``); the refinement reuses the
    probes a screen already made."""
    from types import SimpleNamespace
    from littledog_mlsim.diagnose.learned import (SCOPES, _refine, family_probes,
                                                  screen_narrower, screen_sizes)
    from littledog_mlsim.models.feature_library import CommandFilter
    lib = family_probes()
    assert screen_sizes(lib, False) == (len(lib), 0)
    joint_families = [a for a in lib if "joints" in a.params()]
    assert len(joint_families) == 5   # delay, low-pass, play, time drift (t * (u - q)), swing
    assert screen_sizes(lib, True) == (len(lib) / 0.75, 5 * len(SCOPES) / 0.25)
    assert screen_sizes(lib, True, 0.5) == (2 * len(lib), 2 * 5 * len(SCOPES))
    with pytest.raises(ValueError, match="scoped_share must be in"):
        screen_sizes(lib, True, 1.0)
    assert screen_sizes([Heading(), ElapsedTime()], True) == (2, 0)   # nothing to narrow

    calls = []

    class Route:
        opts = LearnedOptions(narrow_p=0.1)

        def probes(self, fs, ev0, augs, n):
            calls.append(([a.label() for a in augs], n))
            return [SimpleNamespace(aug=a, total_gain=1.0 if a.joints == "back_left" else 0.1,
                                    decision=SimpleNamespace(state=SimpleNamespace(
                                        d=np.full((40, 33), 0.0)), p_value=1e-6))
                    for a in augs]

    def full_probe(aug, gain, p):
        return SimpleNamespace(aug=aug, total_gain=gain, decision=SimpleNamespace(p_value=p))
    full = [full_probe(CommandLag(lag=2), 0.3, 0.002),
            full_probe(CommandFilter(time_constant_ms=30.0), -0.2, 0.002),    # no gain
            full_probe(ElapsedTracking(), 0.4, 0.5),              # above narrow_p (0.1)
            full_probe(Heading(), 0.5, 1e-3)]                               # no joints
    scoped = screen_narrower(Route(), None, None, full, 54)
    assert calls == [([f"command_lag(lag=2, joints={s})" for s in SCOPES], 54)]
    assert [p.aug.joints for p in scoped] == list(SCOPES)
    # the refinement of the back-left delay probes only what the screens did not: parameters
    calls.clear()
    first = next(p for p in scoped if p.aug.joints == "back_left")
    whole = SimpleNamespace(aug=CommandLag(lag=2), total_gain=0.3, decision=first.decision)
    best, scan = _refine(Route(), FeatureSet(), None, first, 16, [whole] + scoped)
    legs_joints = [f"command_lag(lag=2, joints=back_left_{j})"
                   for j in ("hip_roll", "hip_pitch", "knee")]
    assert [c[0] for c in calls] == [[], legs_joints, [f"command_lag(lag={d}, joints=back_left)"
                                                       for d in (1, 3, 4, 5)]]
    assert best.aug.joints == "back_left"
    assert [e["label"] for e in scan if e["stage"] == "scope"][:2] == [
        "command_lag(lag=2, joints=back_left)", "command_lag(lag=2, joints=all)"]


def _synthetic_decision(rng, M: int, shift: float):
    """A learned-route decision on M moves: a cut of ``shift`` (log) on 3 of the 33 elements
    (the scope's focus), path channels that the candidate leaves alone."""
    from littledog_mlsim.diagnose.learned import _Decision
    from littledog_mlsim.diagnose.stats import path_test, sse_decision
    S0 = rng.lognormal(0.0, 0.5, (M, 33))
    S1 = S0 * rng.lognormal(0.0, 0.3, (M, 33))
    S1[:, 15:18] *= np.exp(-shift)
    P0 = rng.lognormal(0.0, 0.5, (M, 8))
    P1 = P0 * rng.lognormal(0.0, 0.3, (M, 8))
    return _Decision(sse_decision(S0, S1, 4, 1e-4, 0.05, focus=[15, 16, 17]), path_test(P0, P1),
                     [f"p{i}" for i in range(8)], 4, 1e-4, 0.05)


def test_moves_to_settle_scales_the_evidence_with_the_moves():
    """A candidate that is not significant: ``moves_to_settle`` gives the TrainPool moves per
    type at which its pooled, focus or path test's z-score (times the square root of the moves,
    at its Bonferroni factor) reaches alpha with 80 % probability. ``decision_tests`` are the
    tests behind ``p_value``. Drawn again at the size asked for (10 types), the candidates near
    alpha are significant more often than not. Nothing is asked where every test's evidence is
    against the candidate, or where no element is cut by the materiality minimum (more moves
    would make it significant, not material); the suspect names the ``record`` size."""
    from types import SimpleNamespace

    from littledog_mlsim.diagnose.learned import (_suspect, decision_tests, moves_to_settle,
                                                  record_moves_per_type)
    rng = np.random.default_rng(1)
    draws = [_synthetic_decision(rng, 40, 0.15) for _ in range(30)]
    for d in draws:
        assert d.p_value == pytest.approx(min(1.0, min(f * p for _, f, p in decision_tests(d))))
    near = [(d, moves_to_settle(d, 4.0)) for d in draws if 1e-4 <= d.p_value < 1e-3]
    assert len(near) >= 5 and all(m is not None and m > 4 for _, m in near), near
    m = int(np.median([m for _, m in near]))
    again = [_synthetic_decision(rng, 10 * m, 0.15).significant for _ in range(30)]
    assert np.mean(again) > 0.5, (m, np.mean(again))
    worse = _synthetic_decision(rng, 40, -0.3)
    worse.path.p = 0.7                                    # the path's evidence against it too
    assert all(p > 0.5 for name, _, p in decision_tests(worse) if name != "element")
    assert moves_to_settle(worse, 4.0) is None
    d = near[0][0]
    small = replace(d, min_gain=10.0)                     # no element cut by the minimum
    assert moves_to_settle(small, 4.0) is None
    assert record_moves_per_type(7) == 10 and record_moves_per_type(14) == 20
    probe = SimpleNamespace(aug=CommandLag(lag=2, joints="back_left"), decision=d,
                            total_gain=0.2, to_dict=lambda: {"label": "command_lag"})
    s = _suspect(probe, 4.0, reference=False)
    assert s["settle_moves_per_type"] == near[0][1]
    assert s["why"] == "not significant at alpha (p within 10 alpha)"
    assert s["recording"].endswith(
        f"about {near[0][1]} TrainPool moves per type instead of 4 (record --moves-per-type "
        f"{record_moves_per_type(near[0][1])})"), s["recording"]


def test_focus_all_ranks_every_joints_elements_for_a_probe_of_all_joints():
    """``LearnedOptions.focus_all``: a probe of all joints gets the focus test too, over every
    joint's q and dq (24 elements), so its state test is Bonferroni over three tests, as a
    scoped probe's; a family without joints never has one. Against a reference, a full-scope
    probe's focus was chosen among no scopes (``_focus_choices`` 1), a narrower one's among the
    screen's nine."""
    from littledog_mlsim.diagnose.learned import SCOPES, _focus_choices, scope_elements
    from littledog_mlsim.layout import JOINT_NAMES, S, STATE_NAMES
    lag = CommandLag(lag=2)
    assert scope_elements(lag) is None
    every = scope_elements(lag, all_joints=True)
    assert sorted(STATE_NAMES[i] for i in every) == sorted(
        [STATE_NAMES[S.q.start + k] for k in range(len(JOINT_NAMES))]
        + [STATE_NAMES[S.dq.start + k] for k in range(len(JOINT_NAMES))])
    assert len(every) == 2 * len(JOINT_NAMES)
    assert scope_elements(replace(lag, joints="back_left"), all_joints=True) == scope_elements(
        replace(lag, joints="back_left"))
    assert scope_elements(Heading(), all_joints=True) is None
    assert _focus_choices(lag) == 1 and _focus_choices(Heading()) == len(SCOPES)
    assert _focus_choices(replace(lag, joints="knees")) == len(SCOPES)
    # zoo11 run11 (without a reference) and run12 (focus_all only with one): off;
    # run13: both only with a reference
    default = LearnedOptions()
    assert not (default.focus_all or default.widen_focus)
    assert default.focus_all_with_reference and default.widen_focus_with_reference


def test_the_with_reference_options_turn_theirs_on_only_where_a_reference_is_given(monkeypatch):
    """``focus_all_with_reference`` and ``widen_focus_with_reference``: the route runs with
    ``focus_all`` and ``widen_focus`` on wherever a reference is given (the options it checks,
    and reports, say so), and as asked without one."""
    from littledog_mlsim.diagnose import learned

    class Seen(Exception):
        pass

    def check(train, test, opts):
        raise Seen(opts.focus_all, opts.widen_focus)
    monkeypatch.setattr(learned, "_check_input", check)
    off = dict(focus_all_with_reference=False, widen_focus_with_reference=False)
    cases = [(None, LearnedOptions(), (False, False)), ([], LearnedOptions(), (True, True)),
             ([], LearnedOptions(**off), (False, False)),
             ([], LearnedOptions(widen_focus_with_reference=False), (True, False)),
             ([], LearnedOptions(focus_all_with_reference=False), (False, True)),
             (None, LearnedOptions(focus_all=True, widen_focus=True, **off), (True, True))]
    for reference, opts, on in cases:
        with pytest.raises(Seen) as seen:
            diagnose_learned([], [], options=opts, reference=reference)
        assert seen.value.args == on, (reference, opts)


def test_a_neighbour_whose_columns_the_model_holds_is_not_probed_again():
    """zoo17 run1's z11: the one-step loop accepted ``command_lag(lag=1, joints=all)``; the
    rollout route's parameter scan of ``command_lag(lag=2, joints=all)`` probed lag 1 again and
    the feature set held its columns twice (the diagnosis stopped with an error)."""
    from littledog_mlsim.diagnose.learned import _new_columns, _param_members
    from littledog_mlsim.models.features import CommandLag, FeatureSet
    fs = FeatureSet((CommandLag(lag=1, joints="all"),))
    members = _param_members(CommandLag(lag=2, joints="all"))
    assert any(a == CommandLag(lag=1, joints="all") for a in members)
    kept = _new_columns(fs, members)
    assert kept and CommandLag(lag=1, joints="all") not in kept
    for a in kept:
        fs.with_augmentation(a)                  # no column twice
    assert _new_columns(fs, [CommandLag(lag=1, joints="front_left"),
                             CommandLag(lag=3, joints="all")]) == [CommandLag(lag=3, joints="all")]
