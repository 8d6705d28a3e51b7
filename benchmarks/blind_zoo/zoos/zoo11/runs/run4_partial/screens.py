"""Print the rollout route's screens (full-scope probes and narrower ones) of report.json files."""
import json, sys
for path in sys.argv[1:]:
    r = json.load(open(path)); rr = r["rollout_route"]
    print(f"== {path}: significant {rr.get('significant')}, {r.get('seconds', 0):.0f} s")
    for k, rd in enumerate(rr["rounds"]):
        for p in rd.get("probes", []):
            print(f"  round {k} full   {p['label'][:62]:62s} p {p['p_value']:.3g}  gain {p['total_gain']:+.3f}")
        for p in rd.get("scoped", []) or []:
            print(f"  round {k} scoped {p['label'][:62]:62s} p {p['p_value']:.3g}  gain {p['total_gain']:+.3f}")
    for e in rr.get("effects", []):
        print("  effect", e["label"], json.dumps(e.get("physical"))[:300])
