"""Typed options of the diagnosis (``littledog_mlsim.diagnose.options``): the keywords of
``diagnose()`` and the CLI's ``--physics auto|on|off`` map onto a route object."""
from __future__ import annotations

import pytest

from littledog_mlsim.diagnose import (AutoRoute, DiagnoseOptions, LearnedRoute, PhysicalRoute,
                                      SearchModel, diagnose)
from littledog_mlsim.diagnose.options import route_from_mode
from littledog_mlsim.diagnose.physical import PhysicalOptions


def test_physics_modes_map_onto_routes():
    search = SearchModel(seed=3)
    on = DiagnoseOptions.from_keywords(physics="on", physics_options={"jobs": 1}, alpha=0.02)
    assert isinstance(on.route, PhysicalRoute) and on.route.overrides == {"jobs": 1}
    assert on.alpha == 0.02
    off = DiagnoseOptions.from_keywords(physics="off", search=search, max_rounds=2)
    assert off.route == LearnedRoute(search=search, max_rounds=2)
    auto = DiagnoseOptions.from_keywords()
    assert isinstance(auto.route, AutoRoute)
    assert isinstance(auto.route.resolve("measured"), PhysicalRoute)
    assert isinstance(auto.route.resolve(None), LearnedRoute)
    assert isinstance(auto.route.resolve("no such robot"), LearnedRoute)
    assert route_from_mode("off", PhysicalRoute(), LearnedRoute()) == LearnedRoute()


def test_physical_options_take_the_run_s_then_the_route_s():
    o = PhysicalRoute({"alpha": 0.001, "jobs": 1}).options(0.01, 0.05, "measured", 0.03)
    assert o == PhysicalOptions(alpha=0.001, min_gain=0.05, robot="measured", excitation=0.03,
                                jobs=1)


def test_bad_options_fail_with_one_line_naming_them(tmp_path):
    with pytest.raises(ValueError, match="physics must be on, off or auto, got 'maybe'"):
        DiagnoseOptions.from_keywords(physics="maybe")
    with pytest.raises(ValueError, match="unknown option 'alhpa'"):
        DiagnoseOptions.from_keywords(alhpa=0.1)
    with pytest.raises(ValueError, match="unknown physics option 'fit_moves'"):
        PhysicalRoute({"fit_moves": 2})
    with pytest.raises(ValueError, match="initial_state must be measured or smoothed"):
        PhysicalRoute({"initial_state": "guessed"})
    with pytest.raises(ValueError, match="not both"):
        diagnose(tmp_path, tmp_path / "out", DiagnoseOptions(), method="lr")
    assert not (tmp_path / "out").exists()


def test_twin_and_reference_take_the_physical_route_and_say_why(tmp_path):
    from littledog_mlsim.diagnose.run import choose_route
    imported = {"source": "rosbag2"}
    route, robot, why = choose_route(DiagnoseOptions(), imported)
    assert isinstance(route, LearnedRoute) and robot is None and "names no known robot" in why
    route, robot, why = choose_route(DiagnoseOptions(), {"robot": "measured"})
    assert isinstance(route, PhysicalRoute) and robot == "measured"
    route, robot, why = choose_route(DiagnoseOptions(twin="nominal"), imported)
    assert isinstance(route, PhysicalRoute) and robot == "nominal" and "twin 'nominal'" in why
    assert "with no reference, what the twin gets wrong is found as an effect" in why
    # a calibrated twin file names the recording it was fitted on as the reference to give
    from littledog_mlsim.robot.config import robot_config
    from littledog_mlsim.robot.twin import Twin, save_twin
    twin = save_twin(Twin(robot_config("nominal"), {"calibrated_from": {"data": "/data/ref"}}),
                     tmp_path / "twin.json")
    route, robot, why = choose_route(DiagnoseOptions(twin=twin), imported)
    assert "this twin was calibrated on /data/ref" in why
    odd = save_twin(Twin(robot_config("nominal"), {"calibrated_from": "by hand"}),
                    tmp_path / "odd.json")               # a provenance edited by hand
    route, robot, why = choose_route(DiagnoseOptions(twin=odd), imported)
    assert "with no reference" in why and "calibrated on" not in why
    route, robot, why = choose_route(DiagnoseOptions(twin=twin, reference=tmp_path), imported)
    assert "with no reference" not in why and "cancelled against the reference" in why
    route, robot, why = choose_route(DiagnoseOptions(reference=tmp_path), imported)
    assert isinstance(route, PhysicalRoute) and robot == "nominal"
    assert "names no known robot" in why and str(tmp_path) in why
    route, robot, why = choose_route(DiagnoseOptions(reference=tmp_path), {"robot": "measured"})
    assert robot == "measured"
    off = DiagnoseOptions.from_keywords(physics="off", twin="nominal")
    with pytest.raises(ValueError, match="drop --physics off"):
        choose_route(off, imported)
    # no twin, a reference: the learned route contrasts its rollout route's findings with it
    off = DiagnoseOptions.from_keywords(physics="off", reference=tmp_path)
    with pytest.raises(ValueError, match="add --rollout-route"):
        choose_route(off, imported)
    ref = DiagnoseOptions(route=LearnedRoute(rollout=object()), reference=tmp_path)
    route, robot, why = choose_route(ref, {"robot": "measured"})
    assert isinstance(route, LearnedRoute) and robot is None
    assert f"contrasted with the reference {tmp_path}" in why


def test_cli_refuses_a_bad_twin_or_reference_in_one_line(tmp_path):
    import subprocess
    import sys
    data = tmp_path / "data"
    data.mkdir()
    (data / "dataset.yaml").write_text("{}\n")
    cli = [sys.executable, "-m", "littledog_mlsim.cli", "diagnose", "--data", str(data),
           "--out", str(tmp_path / "out")]
    for extra, words in ((["--twin", "nosuchrobot"], "--twin: unknown robot 'nosuchrobot'"),
                         (["--twin", str(tmp_path / "t.json")], "--twin: twin file"),
                         (["--reference", str(tmp_path / "nothing")], "no dataset there"),
                         (["--twin", "nominal", "--physics", "off"], "drop --physics off"),
                         (["--reference", str(data), "--physics", "off"], "add --rollout-route")):
        r = subprocess.run(cli + extra, capture_output=True, text=True)
        lines = r.stderr.strip().splitlines()
        assert r.returncode != 0 and len(lines) == 1 and words in lines[0], r.stderr
    assert not (tmp_path / "out").exists()


def test_diagnose_prints_the_rollout_routes_verdict(tmp_path, capsys):
    """A finding of the rollout route alone (here an unexplained change) is not printed as
    "nothing significant"; without a rollout route that line stays, saying so where findings
    could not be compared with the reference; a sensor-timing finding gets its own line."""
    from littledog_mlsim.cli import print_diagnosis
    base = {"effects": [], "suspected": [], "before": {"nmse_mean": 0.07},
            "after": {"nmse_mean": 0.07}}
    verdict = "an unexplained change since the reference: ..."
    print_diagnosis({**base, "rollout_route": {"significant": True, "verdict": verdict}},
                    tmp_path)
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"rollout route: {verdict}" and "nothing significant" not in out[0]
    assert out[1].startswith("one-step nMSE mean 0.0700 -> 0.0700; wrote")
    print_diagnosis(base, tmp_path)
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "nothing significant: no candidate effect explains the residual"
    assert len(out) == 2
    # findings set aside as not comparable with the reference are not "no candidate"
    print_diagnosis({**base, "not_comparable": [{"label": "state_lag(lag=3, group=all)"}]},
                    tmp_path)
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("nothing significant against the reference: 1 finding(s)")
    assert "cannot be compared" in out[0] and "no candidate" not in out[0]
    # nor are findings the reference shows as much (decision 041)
    print_diagnosis({**base, "shared": [{"label": "joint_rate_magnitude(kind=quadratic)"}]},
                    tmp_path)
    out = capsys.readouterr().out.splitlines()
    assert out[0] == ("nothing significant against the reference: 1 finding(s) it shows as "
                      "much (the robot's own: joint_rate_magnitude(kind=quadratic))")
    # a sensor-timing finding is printed
    timing = {"significant": True, "statement": "the pose lags the joint states by about 30 ms"}
    print_diagnosis({**base, "timing": timing}, tmp_path)
    out = capsys.readouterr().out.splitlines()
    assert out[1] == "timing: the pose lags the joint states by about 30 ms" and len(out) == 3
    # the physical route's excess over the reference, named other (decision 047)
    left = {"named": True, "scope": "joint:back_left_knee", "statement": "1.40 times ..."}
    print_diagnosis({**base, "significant": True, "physics": {"reference": {"unexplained": left}}},
                    tmp_path)
    out = capsys.readouterr().out.splitlines()
    assert out[0] == ("unexplained against the reference: other at joint:back_left_knee: "
                      "1.40 times ...") and len(out) == 2


def test_the_report_models_lgpr_fits_run_in_the_diagnosis_jobs():
    """``diagnose --jobs N`` fits each stage's LGPR in N local processes (``n_jobs`` 1 and 2
    give the same model: ``test/models/test_lgpr.py``); options that name ``n_jobs``, one
    job, and other methods are left as they are, and the run's options are not changed."""
    from littledog_mlsim.diagnose.run import fit_options
    opts = {"cluster_size": 500}
    assert fit_options("lgpr", opts, 2) == {"cluster_size": 500, "n_jobs": 2}
    assert opts == {"cluster_size": 500}
    assert fit_options("lgpr", opts, 1) == opts
    assert fit_options("lgpr", {"n_jobs": 1}, 2) == {"n_jobs": 1}
    assert fit_options("lr", {}, 2) == {}
