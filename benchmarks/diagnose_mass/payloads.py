"""Every payload (`mass_com`) the blind zoos' twin arms fitted: fitted mass against the truth,
and the horizontal first moment (mass x offset, g m) against the truth's.

    .venv/bin/python benchmarks/diagnose_mass/payloads.py > benchmarks/diagnose_mass/payloads.txt
"""
from __future__ import annotations

import glob
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
ZOOS = os.path.join(HERE, "..", "blind_zoo", "zoos")


def main() -> None:
    seen = set()
    print("run | effect | mass fitted / true (ratio) | moment x, y fitted [g m] | true [g m]")
    for rj in sorted(glob.glob(os.path.join(ZOOS, "zoo*", "runs", "**", "results.json"),
                           recursive=True)):
        r = json.load(open(rj))
        if "calib" not in str(r.get("arm") or ""):
            continue
        for row in r.get("rows", []):
            t = row["truth"]
            if t["family"] != "mass_com":
                continue
            run = os.path.relpath(rj, ZOOS)
            named = [n for n in row["score"]["named"] if n["family"] == "mass_com"]
            if not named:
                print(f"{run} | {row['id']} | not named mass_com: "
                      + ", ".join(f"{n['family']} @ {n['scope']}" for n in row["score"]["named"]))
                continue
            n = named[0]
            tm, to = t["params"]["added_mass_kg"], t["params"]["com_offset_m"]
            fm, fo = n["params"]["added_mass_kg"], n["params"]["com_offset_m"]
            key = (run.split(os.sep)[0], row["id"], round(fm, 6))
            dup = " (the same fit as above)" if key in seen else ""
            seen.add(key)
            print(f"{run} | {row['id']} | {fm:.3f} / {tm:.3f} ({fm / tm:.2f}) | "
                  f"{1000 * fm * fo[0]:+.2f}, {1000 * fm * fo[1]:+.2f} | "
                  f"{1000 * tm * to[0]:+.2f}, {1000 * tm * to[1]:+.2f}{dup}")


if __name__ == "__main__":
    main()
