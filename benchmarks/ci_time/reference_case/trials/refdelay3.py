import json, sys, time, tempfile
from pathlib import Path
sys.path.insert(0, 'test/diagnose'); sys.path.insert(0, 'test')
import test_reference as T
from littledog_mlsim.diagnose import diagnose
DELAY = ("- class: littledog_mlsim.robot.effects:SetpointDelay\n"
         "  params: {delay_ms: %s}\n" % sys.argv[1])
FAMS = sys.argv[2].split(",")
T.TYPES = sys.argv[3].split(",")
root = Path(tempfile.mkdtemp(prefix="refdl"))
t = time.time()
ref = T._record(root, "reference", 411, DELAY); ch = T._record(root, "changed", 412, DELAY + T.SOFT_KNEE)
print("record", time.time() - t, flush=True)
t = time.time(); c0 = time.process_time()
rep = diagnose(ch, root / "out", method="lr", figures=False, progress=True, twin="measured", reference=ref,
               physics_options={**T.PHYS, "families": FAMS})
print("diagnose", time.time() - t)
json.dump(rep, open(root / "report.json", "w"), default=str)
ref = rep["physics"]["reference"]
print("twin_errors", [(e["family"], e["scope"], e["params"], e["changed"]) for e in ref["twin_errors"]])
print("effects", [(e["physical"]["family"], e["physical"]["scope"], e["physical"]["params"]) for e in rep["effects"]])
print("unexplained", ref["unexplained"]["significant"], ref["unexplained"]["material"])
