"""`littledog-mlsim diagnose` with the physical route searching only some families (a probe of
the screen and the shortlist, not a tool): the first argument is the families, comma-separated;
the rest is the diagnose command line.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python \
      benchmarks/blind_zoo/zoos/zoo43/runs/run3_decision049/probe/families_only.py \
      foot_slip,leg_difference diagnose --data WORK/effects/z01 --out OUT --no-figures --jobs 2 \
      --twin WORK/<run1's calibrated twin>.json --reference WORK/reference
"""
import sys

import littledog_mlsim.diagnose.physical as physical


def main() -> int:
    families = sys.argv[1].split(",")
    identify = physical.identify

    def restricted(*args, **kw):
        return identify(*args, families=families, **kw)

    physical.identify = restricted    # diagnose imports it from the package at run time
    from littledog_mlsim.cli import main as cli
    return cli(sys.argv[2:])


if __name__ == "__main__":
    sys.exit(main())
