"""The run4 / run6 table: python3 table.py ../run4_calibrated_add_asked/calibration.json calibration.json > table.md"""
import json, sys
a = json.load(open(sys.argv[1]))  # run4
b = json.load(open(sys.argv[2]))  # run6
ca, cb = a["calibration"], b["calibration"]
ra = {r["name"]: r for r in ca["rows"]}
pc = lambda x: '-' if not x or x.get('rel_error') is None else '%.1f %%' % (100 * x['rel_error'])
print("| parameter | truth | run4 (`--add-asked 1`) | run6 (`--add-asked 2`) | 95 % interval (run6) | error run4 / run6 | inside run4 / run6 |")
print("|---|---|---|---|---|---|---|")
for r in cb["rows"]:
    o = ra.get(r["name"])
    f = lambda x: "-" if x is None else f"{x:.4g}"
    print(f"| {r['name']} | {f(r['truth'])} | {f(o['value']) if o else '-'} | {f(r['value'])} | [{f(r['ci95'][0])}, {f(r['ci95'][1])}] | "
          f"{pc(o)} / {pc(r)} | "
          f"{o['inside'] if o else '-'} / {r['inside']} |")
print()
print("rollout after: run4 %.4f m, run6 %.4f m (before %.4f m); calibrate seconds run4 %s, run6 %s; summary run6: %s" % (
    ca["rollout"]["after"]["final_xy_error_m"], cb["rollout"]["after"]["final_xy_error_m"],
    cb["rollout"]["before"]["final_xy_error_m"], ca.get("seconds"), cb.get("seconds"), cb.get("summary")))
