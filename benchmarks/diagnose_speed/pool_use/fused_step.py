"""A prototype, not kept: the servo, the joint read and the encoders fused into one physics-step
method (monkeypatched over ``LittleDogSim._physics_step``), against the simulator's own, on the
first three TrainPool moves of DATASET; each side alternately three times, a SHA-256 prefix of
every observation and the time per move.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python -P benchmarks/diagnose_speed/pool_use/fused_step.py ROBOT DATASET
"""
import sys, time, hashlib
import numpy as np
import pybullet as p
from littledog_mlsim.data.dataset import load_moves
from littledog_mlsim.robot import sim as S
from littledog_mlsim.robot.sim import InitialState, LittleDogSim
from littledog_mlsim.robot.twin import robot_config_from

def fast_physics_step(self, q_des):
    enc = self._encoders
    servo = self._servo
    c = self.client
    if servo.needs_encoders:
        tau = servo.kp * (q_des - enc.position) - servo.kd * enc.raw_rate
        tau = np.minimum(np.maximum(tau, servo._tau_min), servo.tau_max)
        servo.last_torque = tau
        p.setJointMotorControlArray(self.robot, self.joint_indices, p.TORQUE_CONTROL, forces=tau.tolist(), physicsClientId=c)
    else:
        servo.apply(c, self.robot, self.joint_indices, q_des, enc)
    p.stepSimulation(physicsClientId=c)
    self._step_count += 1
    if self._needs_joints:
        js = p.getJointStates(self.robot, self.joint_indices, physicsClientId=c)
        q = np.array([s[0] for s in js]); dq = np.array([s[1] for s in js])
        q.setflags(write=False); dq.setflags(write=False)
        self._js = (q, dq)
        if enc.resolution is None:
            position, raw = q, dq
        else:
            position = np.rint(q * enc._counts_per_rad) * enc.resolution
            raw = (position - enc.position) * enc._rate_scale
        enc.position = position
        enc.raw_rate = raw
        enc.rate = raw if enc.alpha == 1.0 else enc.rate + enc.alpha * (raw - enc.rate)
    else:
        self._js = None

def main():
    sim = LittleDogSim(robot_config_from(sys.argv[1]))
    recs = load_moves(sys.argv[2], split="train")[:3]
    def run():
        h = hashlib.sha256()
        for rec in recs:
            o = sim.reset(initial=InitialState.at(rec, 0))
            for u in rec.cmd:
                o = sim.step(u)
                for k in sorted(o): h.update(o[k].tobytes())
        return h.hexdigest()[:16]
    orig = LittleDogSim._physics_step
    for name, f in [("orig", orig), ("fast", fast_physics_step)] * 3:
        LittleDogSim._physics_step = f
        run()
        t0 = time.perf_counter(); d = run(); t = time.perf_counter() - t0
        print(name, d, "%.1f ms per move" % (t / len(recs) * 1e3))
main()
