"""Where a cold start's compile time goes: numba's ``numba:compile`` events per dispatcher, in CPU seconds.

    python -m benchmarks.compile_profile {library,default,rk4,os,os-radau,contact} [--top N]

Runs one case of :data:`benchmarks.core.SIM_COLD_CASES` (plus ``os``: a first simulate with an
operational-space torque source; ``os-radau``: the same with radau, whose Newton matrix compiles the controller's
derivatives; ``contact``: a free ball dropped on the ground, the default integrator) in a fresh interpreter with an empty numba cache and prints, per compiled
function, the CPU seconds spent compiling it (exclusive of the functions it compiled on the way: numba
compiles a callee while typing its caller) and inclusive, and the process's CPU seconds.  CPU time, not wall:
the machines are shared.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

SCRIPT = r"""
import json, resource, sys, time
from numba.core import event

stack, rows = [], {}

class Listener(event.Listener):
    def on_start(self, ev):
        stack.append([time.process_time(), 0.0])
    def on_end(self, ev):
        t0, child = stack.pop()
        incl = time.process_time() - t0
        if stack:
            stack[-1][1] += incl
        d = ev.data["dispatcher"]
        name = getattr(d, "py_func", d)
        name = f"{name.__module__}.{name.__qualname__}"
        r = rows.setdefault(name, [0, 0.0, 0.0])
        r[0] += 1; r[1] += incl - child; r[2] += incl

event.register("numba:compile", Listener())
import numpy as np
import dynamics
BALL = '''<robot name="ball"><link name="ball"><inertial><mass value="0.2"/>
<inertia ixx="2e-4" iyy="2e-4" izz="2e-4" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>'''
arm = dynamics.load_urdf(sys.argv[1])
dynamics.inverse_dynamics(arm, np.zeros(2), np.zeros(2), np.zeros(2))
cpu_lib = time.process_time()
case = sys.argv[2]
if case == "default":
    dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 1.0)
elif case == "rk4":
    dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 1.0, integrator="rk4", dt=1e-3)
elif case == "os":
    src = dynamics.torques.Target("tip", [1.2, 0.0, 0.9], kp=100.0, kd=20.0, rows=[0, 2])
    dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 0.2, torque=src, integrator="rk4", dt=1e-3)
elif case == "os-radau":
    src = dynamics.torques.Target("tip", [1.2, 0.0, 0.9], kp=100.0, kd=20.0, rows=[0, 2])
    dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 0.2, torque=src, integrator="radau")
elif case == "contact":
    ball = dynamics.load_urdf(BALL, floating_base=True)
    dynamics.simulate(ball, [0, 0, 0.3, 0, 0, 0, 1.0], np.zeros(6), 0.3,
                      contact=dynamics.Contact(geometries=[dynamics.Sphere("ball", 0.05)]))
cpu = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"rows": rows, "cpu_lib": cpu_lib, "cpu": cpu.ru_utime + cpu.ru_stime}))
"""


def profile(case, urdf):
    with tempfile.TemporaryDirectory(prefix="numba-cold-") as d:
        env = dict(os.environ, NUMBA_CACHE_DIR=d)
        out = subprocess.run([sys.executable, "-c", SCRIPT, urdf, case], env=env, capture_output=True, text=True)
    if out.returncode:
        sys.stderr.write(out.stderr)
        raise SystemExit(out.returncode)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case", choices=("library", "default", "rk4", "os", "os-radau", "contact"))
    ap.add_argument("--top", type=int, default=15)
    args = ap.parse_args(argv)
    urdf = str(Path(__file__).resolve().parent.parent / "robots" / "planar_2r.urdf")
    r = profile(args.case, urdf)
    rows = sorted(r["rows"].items(), key=lambda kv: -kv[1][1])
    print(f"case {args.case}: process CPU {r['cpu']:.1f} s (library part {r['cpu_lib']:.1f} s); "
          f"compile events: {sum(v[1] for _, v in rows):.1f} s exclusive in total")
    print("| function | compiles | exclusive CPU s | inclusive CPU s |\n|---|---:|---:|---:|")
    for name, (n, excl, incl) in rows[:args.top]:
        print(f"| {name} | {n} | {excl:.2f} | {incl:.2f} |")


if __name__ == "__main__":
    main()
