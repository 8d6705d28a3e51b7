"""Summarise a `py-spy record --format raw` file: the share of samples by leaf frame (the line
running when sampled; a C call counts on the Python line that made it) and by process (the
innermost `process` frame of each stack).

    python3 benchmarks/diagnose_speed/step_python/stacks_summary.py STACKS [N]
"""
import collections
import sys


def main() -> None:
    path, n = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 30
    leaf, proc, total = collections.Counter(), collections.Counter(), 0
    with open(path) as f:
        for line in f:
            stack, _, count = line.rstrip().rpartition(" ")
            frames, k = stack.split(";"), int(count)
            total += k
            leaf[frames[-1]] += k
            procs = [x for x in frames if x.startswith("process ")]
            proc[procs[-1].split(":")[0]] += k     # the innermost: the process sampled
    print(f"{total} samples")
    for name, k in proc.most_common():
        print(f"{k / total:6.1%}  {name}")
    for name, k in leaf.most_common(n):
        print(f"{k / total:6.1%}  {name}")


if __name__ == "__main__":
    main()
