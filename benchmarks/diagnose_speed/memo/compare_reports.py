"""Compare two report.json files key by key, leaving out timings (and the n_simulations count):

    python3 benchmarks/diagnose_speed/memo/compare_reports.py A/report.json B/report.json

prints each difference (path, values) and their number."""
import json, sys
SKIP = {"seconds", "n_simulations", "wall_s", "rollout_wall_s", "fit_s", "elapsed_s", "created", "code"}
def walk(a, b, path, out):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k in SKIP: continue
            if k not in a or k not in b: out.append((path + "/" + k, "missing")); continue
            walk(a[k], b[k], path + "/" + k, out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b): out.append((path, f"len {len(a)} {len(b)}")); return
        for i, (x, y) in enumerate(zip(a, b)): walk(x, y, f"{path}[{i}]", out)
    elif a != b and not (a != a and b != b):
        out.append((path, f"{a!r} != {b!r}"))
a, b = (json.load(open(p)) for p in sys.argv[1:3])
out = []; walk(a, b, "", out)
for o in out: print(*o)
print(len(out), "differences")
