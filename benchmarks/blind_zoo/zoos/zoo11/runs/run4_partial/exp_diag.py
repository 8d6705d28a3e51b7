"""The CLI's diagnose with the rollout route's LearnedOptions changed by KEY=VALUE
arguments before "--" (an experiment on options the CLI does not expose). Usage, from a
checkout (PYTHONPATH=CHECKOUT so that the checkout's package is imported):

    PYTHONPATH=CHECKOUT .venv/bin/python -P exp_diag.py scope_test=1 -- diagnose ARGS
"""
import sys
from dataclasses import fields
from littledog_mlsim import cli
from littledog_mlsim.diagnose.learned import LearnedOptions


def main() -> int:
    i = sys.argv.index("--")
    kv = dict(a.split("=", 1) for a in sys.argv[1:i])
    types = {f.name: f.type for f in fields(LearnedOptions)}
    def conv(k, v):
        t = str(types[k])
        return (v not in ("0", "False")) if "bool" in t else float(v) if "float" in t else int(v) if "int" in t else v
    over = {k: conv(k, v) for k, v in kv.items()}
    orig = cli._rollout_options
    def patched(a):
        o = orig(a)
        from dataclasses import replace
        return None if o is None else replace(o, **over)
    cli._rollout_options = patched
    print("options:", over, flush=True)
    return cli.main(sys.argv[i + 1:])


if __name__ == "__main__":   # the probes' spawned workers import this file again
    sys.exit(main())
