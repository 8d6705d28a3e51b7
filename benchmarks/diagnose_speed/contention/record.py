"""Run one `diagnose` and record, for each round of its physical route, what each fitted
hypothesis looked like at every stage the search passes it through, and what each stage cost:

- the wide refit (`wide_magnitude` on all fit moves, for joint families from the driver and for
  body and leg families inside `refine_wide`): each hypothesis's J/J0 on the screening moves
  before it and on all fit moves after it, and the re-simulations it ran;
- the located pass (`located_variants`): each family's J at the side it starts from
  (`start_side`) and its J/J0 after its fit;
- the held-out decision: every hypothesis's mean per-move cut, and which was chosen;
- every map call's re-simulations and wall time, charged to the step that asked for it
  (`../where_sims_go/count.py`'s `_step`).

The diagnosis is unchanged: the wrappers only record. Writes OUT (JSON).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/contention/record.py \\
        OUT.json -- diagnose --data DATA --out DIR --no-figures --jobs 2 --twin TWIN \\
        --reference REF
"""
from __future__ import annotations

import collections
import importlib
import json
import subprocess
import sys
import time
from pathlib import Path

from littledog_mlsim import cli
from littledog_mlsim.diagnose.physical import driver, resim
from littledog_mlsim.diagnose.physical.fit import segments_only

fit = importlib.import_module("littledog_mlsim.diagnose.physical.fit")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "where_sims_go"))
from count import _step  # noqa: E402  (charges a map call to the search step that asked)


def _inside(name: str) -> bool:
    f = sys._getframe(1)
    while f is not None:
        if f.f_code.co_name == name:
            return True
        f = f.f_back
    return False


def _rel(c) -> float | None:
    return None if c.J is None or not c.J0 else float(c.J / c.J0)


def main() -> int:
    out, rest = sys.argv[1], sys.argv[sys.argv.index("--") + 1:]
    rec: dict = {"command": "diagnose " + " ".join(rest[1:]), "rounds": []}
    cur: dict = {}
    sims = collections.Counter()
    wall = collections.Counter()
    runner_box: list = []

    def new_round() -> dict:
        r = {"wide": [], "located": [], "located_start": [], "held_out": None}
        rec["rounds"].append(r)
        cur["r"] = r
        return r

    inner_map = resim.Memo.map

    def counted(self, ts):
        if not runner_box:
            runner_box.append(self)
        step = _step()
        before = self.inner.n_sims
        t0 = time.perf_counter()
        res = inner_map(self, ts)
        wall[step] += time.perf_counter() - t0
        sims[step] += self.inner.n_sims - before
        return res
    resim.Memo.map = counted

    def n_sims() -> int:
        return runner_box[0].inner.n_sims if runner_box else 0

    inner_wide = fit.wide_magnitude

    def wide(obj, c, F, *a, **kw):
        s0 = n_sims()
        out_c = inner_wide(obj, c, F, *a, **kw)
        cur["r"]["wide"].append({
            "family": c.family, "scope": c.scope, "kind": "joints" if segments_only(c.family)
            else "body_or_leg", "rel_screening": _rel(c), "rel_fit_moves": _rel(out_c),
            "magnitude_before": c.fitted, "magnitude_after": out_c.fitted,
            "known": bool(a[1] if len(a) > 1 else kw.get("known")),
            "sims": n_sims() - s0})
        return out_c
    fit.wide_magnitude = wide
    driver.wide_magnitude = wide

    inner_start = fit.start_side

    def start(obj, c, F):
        c2, known = inner_start(obj, c, F)
        if _inside("located_variants"):
            cur["r"]["located_start"].append({"family": c.family, "scope": c.scope,
                                              "J_start": next(iter(known.values()), None)})
        return c2, known
    fit.start_side = start

    inner_located = driver.located_variants

    def located(obj, top, scopes, F, allowed=None, cands=(), into=None):
        mine: list = []
        res = inner_located(obj, top, scopes, F, allowed, cands, into=mine)
        if into is not None:
            into.extend(mine)
        cur["r"]["located"] = [{"family": c.family, "scope": c.scope, "rel": _rel(c),
                                "J0": c.J0} for c in mine]
        cur["r"]["located_joined"] = [c.family + " " + c.scope for c in res]
        return res
    driver.located_variants = located

    inner_round = driver._round

    def round_(ctx, o, sp, *a, **kw):
        r = new_round()
        r["sims_at_start"] = n_sims()
        t0 = time.perf_counter()
        res = inner_round(ctx, o, sp, *a, **kw)
        r["seconds"] = time.perf_counter() - t0
        r["sims"] = n_sims() - r["sims_at_start"]
        return res
    driver._round = round_

    inner_validate = driver.validate

    def validate(ctx, top, V, T, alpha, min_gain, horizons_s, cands, robot_mass, foot_mu,
                 observer=None):
        def obs(d):
            cur["r"]["held_out"] = {
                "hypotheses": [{"family": h.family, "scope": h.scope, "rel_fit_moves": _rel(h),
                                "kind": "joints" if segments_only(h.family) else "body_or_leg"}
                               for h in d.hypotheses],
                "n_shortlist": d.n_shortlist, "move_cut": [float(x) for x in d.move_cut],
                "significant": [bool(x.significant) for x in d.decisions],
                "chosen": int(d.chosen)}
            if observer is not None:
                observer(d)
        return inner_validate(ctx, top, V, T, alpha, min_gain, horizons_s, cands, robot_mass,
                              foot_mu, obs)
    driver.validate = validate

    import littledog_mlsim
    root = Path(littledog_mlsim.__file__).resolve().parents[1]
    code = subprocess.run(["git", "rev-parse", "--short=8", "HEAD"], capture_output=True,
                          text=True, cwd=root).stdout.strip()
    if subprocess.run(["git", "diff", "--quiet", "HEAD", "--", "littledog_mlsim"],
                      cwd=root).returncode:
        code += " with uncommitted package edits"
    rec["code"] = code
    rec["load_at_start"] = open("/proc/loadavg").read().split()[:3]
    t0 = time.perf_counter()
    rc = cli.main(rest)
    rec["seconds"] = time.perf_counter() - t0
    rec["sims_by_step"] = dict(sims)
    rec["map_wall_by_step"] = {k: round(v, 2) for k, v in wall.items()}
    rec["sims"] = sum(sims.values())
    Path(out).write_text(json.dumps(rec, indent=1) + "\n", encoding="utf-8")
    return rc


if __name__ == "__main__":
    raise SystemExit(main())
