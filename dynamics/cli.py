"""The ``dynamics`` command line (also ``python -m dynamics``).

    dynamics info ROBOT [--floating-base] [--json]       what the model holds: joints with q/v slices, frames
    dynamics check ROBOT [--floating-base]               every warning and refusal; exit 0 if it loads (and simulate
                                                         takes it at the neutral configuration), 1 if not
    dynamics simulate ROBOT --duration 2 [--q0 ...] [--torque pd:kp=50,kd=5] [--contact ground:mu=0.8]
                                         [--plot out.png] [--json] [--strict]
    dynamics serve [--host ...] [--port ...]             the HTTP service (same as python -m service)
    dynamics view ROBOT [--trajectory FILE.npz] [--url URL]   the inspector page in a browser (GET /inspect), on a
                                                         service started here, or the one at URL

ROBOT is a URDF path or the name of a bundled robot (``dynamics.robots.names()``).

Exit codes: 0 done; 1 a bad argument (one line on stderr naming it); 2 a simulation that did not end "ok" (its
status, its step budget exhausted, or with --strict a warning in its report).
"""

import argparse
import importlib
import json
import os
import sys
import time
import webbrowser

import numpy as np

from . import plot, robots
from .aba import refuse_singular
from .contact.config import PENETRATION_ALLOWANCE, Contact, Material
from .contact.geometry import Ground
from .errors import DynamicsError, InputError
from .simulation import simulate
from .torques import PD
from .urdf import load_urdf

INTEGRATORS = ("auto", "rk45", "dop853", "radau", "rk4", "euler", "implicit_euler")
CONTACT_HELP = ("contact with a ground plane, the robot's URDF collision primitives touching it: 'ground' (z = 0, "
                "the default material) or 'ground:mu=M,height=H,normal=NX,NY,NZ,stiffness=K,dissipation=D,"
                "allowance=DELTA' (any of them; see the contact guide)")
TORQUE_HELP = ("torque source: 'zero' (default), 'constant:TAU' (one number per joint, comma separated), or "
               "'pd:kp=K,kd=D[,target=Q]' (PD towards target, default q0; K and D scalars)")


def _load(args, strict=True):
    collision = getattr(args, "contact", None) is not None  # (the collision primitives: what contact touches with)
    return load_urdf(args.robot, floating_base=args.floating_base, strict_inertia=strict, collision=collision)


def _numbers(text, what):
    try:
        return np.array([float(x) for x in text.replace(",", " ").split()])
    except ValueError:
        raise DynamicsError(f"{what}: expected numbers separated by commas, got {text!r}") from None


def _torque(spec, model, q0):
    """Parse --torque into what dynamics.simulate takes."""
    kind, _, rest = spec.partition(":")
    if kind == "zero":
        return None
    if kind == "constant":
        return _numbers(rest, "--torque constant")
    if kind == "pd":
        fields = {}
        for part in rest.replace(";", ",").split(","):
            key, eq, value = part.partition("=")
            if eq:
                fields[key.strip()] = value.strip()
            elif part.strip() and "target" in fields:  # target=0.1,0.2: the numbers after the first
                fields["target"] += " " + part.strip()
        unknown = set(fields) - {"kp", "kd", "target"}
        if unknown or not {"kp", "kd"} <= set(fields):
            raise DynamicsError(f"--torque: expected pd:kp=K,kd=D[,target=Q], got {spec!r}")
        target = _numbers(fields["target"], "--torque target") if "target" in fields else q0
        return PD(target, float(fields["kp"]), float(fields["kd"]))
    raise DynamicsError(f"--torque: unknown kind {kind!r}; {TORQUE_HELP}")


def _contact(spec):
    """Parse --contact into a dynamics.Contact (None without --contact)."""
    if spec is None:
        return None
    kind, _, rest = spec.partition(":")
    if kind != "ground":
        raise DynamicsError(f"--contact: unknown kind {kind!r}; {CONTACT_HELP}")
    fields = {}
    last = None
    for part in filter(None, (p.strip() for p in rest.replace(";", ",").split(","))):
        key, eq, value = part.partition("=")
        if eq:
            last = key.strip()
            fields[last] = value.strip()
        elif last == "normal":  # normal=0,0,1: the numbers after the first
            fields["normal"] += " " + part
        else:
            raise DynamicsError(f"--contact: expected key=value, got {part!r}; {CONTACT_HELP}")
    known = {"mu", "height", "normal", "stiffness", "dissipation", "allowance"}
    if set(fields) - known:
        raise DynamicsError(f"--contact: unknown key {sorted(set(fields) - known)[0]!r}; {CONTACT_HELP}")
    number = {k: float(_numbers(v, f"--contact {k}")[0]) for k, v in fields.items() if k != "normal"}
    ground = Ground(_numbers(fields["normal"], "--contact normal") if "normal" in fields else (0.0, 0.0, 1.0),
                    number.get("height", 0.0))
    material = Material(stiffness=number.get("stiffness"), dissipation=number.get("dissipation"),
                        mu_static=number.get("mu", 1.0),
                        penetration_allowance=number.get("allowance", PENETRATION_ALLOWANCE))
    return Contact(ground=ground, friction=material)


def info(args):
    model = _load(args, strict=not args.lenient)
    joints = [{"name": n, "type": t, "q": [model.q_slice(n).start, model.q_slice(n).stop],
               "v": [model.v_slice(n).start, model.v_slice(n).stop],
               "lower": _plain(model.lower[model.v_slice(n)][0]), "upper": _plain(model.upper[model.v_slice(n)][0])}
              for n, t in zip(model.joint_names, model.joint_types)]
    out = dict(model.summary(), joints=joints, frames=list(model.frame_names))  # the model's (depth-first) order
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print(f"{model.name}: nq={model.nq} nv={model.nv}, {model.nbodies} bodies, "
          f"floating base: {'yes' if model.floating_base else 'no'}")
    print(f"{'joint':<28} {'type':<11} {'q':>9} {'v':>9}  limits")
    for j in joints:
        print(f"{j['name']:<28} {j['type']:<11} {'%d:%d' % tuple(j['q']):>9} {'%d:%d' % tuple(j['v']):>9}  "
              f"[{_fmt(j['lower'])}, {_fmt(j['upper'])}]")
    print(f"frames ({len(out['frames'])}): {', '.join(out['frames'])}")
    for key in ("fixed_joints_merged", "links_pruned"):
        print(f"{key}: {len(out.get(key, []))}")
    for w in model.warnings:
        print(f"warning: {w}")
    return 0


def _fmt(x):
    return "-" if x is None else f"{x:.4g}"


def _plain(x):
    x = float(x)
    return x if np.isfinite(x) else None


def check(args):
    try:
        model = _load(args)
    except DynamicsError as e:
        try:
            lenient = _load(args, strict=False)
        except DynamicsError:
            lenient = None
        print(f"refused: {e}")
        if lenient is not None:
            print("(it loads with strict_inertia=False / --lenient, with warnings:)")
            for w in lenient.warnings:
                print(f"warning: {w}")
        return 1
    for w in model.warnings:
        print(f"warning: {w}")
    try:  # simulate's own rule, so that check and simulate agree
        refuse_singular(model, model.neutral(), "model.neutral()")
    except DynamicsError as e:
        print(f"refused by simulate and forward dynamics at the neutral configuration: {e}")
        return 1
    print(f"ok: {model.name} loads (nq={model.nq}, nv={model.nv}, {len(model.warnings)} warnings)")
    return 0


def simulate_command(args):
    model = _load(args, strict=not args.lenient)
    q0 = _numbers(args.q0, "--q0") if args.q0 else model.neutral()
    v0 = _numbers(args.v0, "--v0") if args.v0 else np.zeros(model.nv)
    options = {k: getattr(args, k) for k in ("integrator", "rtol", "atol", "dt", "sample_dt")
               if getattr(args, k) is not None}
    torque = _torque(args.torque, model, q0)
    contact = _contact(args.contact)
    if contact is not None:
        options["contact"] = contact
    try:
        traj = simulate(model, q0, v0, args.duration, torque=torque, **options)
    except InputError as e:
        if not str(e).startswith("max_steps:"):  # a bad argument (exit 1)
            raise
        print(f"dynamics simulate: {e}", file=sys.stderr)  # the simulation ran and did not finish
        return 2
    if args.out:
        np.savez(args.out, t=traj.t, q=traj.q, v=traj.v, tau=traj.tau, report=json.dumps(traj.report))
    if args.plot:
        plot.trajectory(traj, args.plot, joint_names=model.joint_names)
    if args.json:
        print(json.dumps(traj.report, indent=2, default=str))
    else:
        print(plot.report_title(traj.report))
        for w in traj.report.get("warnings", []):
            print(f"warning: {w}")
        print(f"final q: {np.array2string(traj.q[-1], precision=6)}")
        c = traj.report.get("contact")
        if c:
            print(f"contact: largest penetration {c['max_penetration']:.3g} m, {c['time_in_contact']:.3g} s in "
                  f"contact, {c['energy_dissipated']:.4g} J dissipated ({c['pairs']} pairs)")
    if args.strict and traj.report.get("warnings"):
        print(f"dynamics simulate: --strict: the report has {len(traj.report['warnings'])} warning(s): "
              + "; ".join(traj.report["warnings"]), file=sys.stderr)
        return 2
    return 0 if traj.report.get("status") == "ok" else 2


def serve(argv):
    """Hand every argument to ``python -m service`` (its own --help lists them)."""
    try:
        service_main = importlib.import_module("service.__main__").main  # the optional web layer
    except ImportError as e:
        raise SystemExit(f"dynamics serve: the service is not installed ({e})") from None
    return service_main(list(argv), prog="dynamics serve")


def _trajectory_json(path):
    """A trajectory file (``dynamics simulate --out``'s .npz, or JSON with t, q, v, tau, report) -> the JSON the
    inspector page plays (non-finite numbers as null: JSON has none)."""
    if str(path).endswith(".json"):
        with open(path, "rb") as f:
            data = json.load(f)
    else:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    missing = [k for k in ("t", "q") if k not in data]
    if missing:
        raise DynamicsError(f"--trajectory: {path} has no {' or '.join(missing)} (expected the .npz of dynamics "
                            f"simulate --out)")
    report = data.get("report", "{}")
    out = {"report": report if isinstance(report, dict) else json.loads(str(report))}
    out.update({k: np.asarray(data[k], dtype=float).tolist() for k in ("t", "q", "v", "tau") if k in data})
    return json.dumps(_finite(out), default=str, allow_nan=False).encode()


def _finite(x):
    """x with every non-finite float replaced by None, through dicts and lists."""
    if isinstance(x, float):
        return x if np.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    return x


def view(args):
    """Open the inspector on ROBOT: on the service at --url, or on one started here (until Ctrl-C)."""
    if args.url:
        if args.trajectory:
            raise DynamicsError("--trajectory: only the service that dynamics view starts can hand it to the page "
                                "(drop --url)")
        base = args.url.rstrip("/")
        page = f"{base}/inspect/{_robot_ref(args, base)}"
        _open(page)
        return 0
    viewer = importlib.import_module("service.viewer")  # the optional web layer
    trajectory = _trajectory_json(args.trajectory) if args.trajectory else None
    with viewer.local_service(port=args.port, store=args.store, trajectory=trajectory) as base:
        page = f"{base}/inspect/{_robot_ref(args, base)}" + ("?trajectory=1" if trajectory else "")
        _open(page)
        print("press Ctrl-C to stop the service", flush=True)
        _wait()
    return 0


def _robot_ref(args, base):
    """The robot's name for a bundled robot or an id, or the id of the URDF file ROBOT uploaded to ``base``."""
    if not os.path.isfile(args.robot):
        return args.robot
    import httpx  # (a dependency of the service)
    with open(args.robot, "rb") as f:
        r = httpx.post(f"{base}/v1/robots", content=f.read(), timeout=600,
                       params={"floating_base": str(bool(args.floating_base)).lower()},
                       headers={"Content-Type": "application/xml"})
    if r.status_code >= 400:
        raise DynamicsError(f"{args.robot}: the service refused it: {r.json().get('detail', r.text)}")
    return r.json()["id"]


def _open(page):
    print(f"inspector: {page}", flush=True)
    webbrowser.open(page)


def _wait():
    """Until Ctrl-C."""
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass


def parser():
    p = argparse.ArgumentParser(prog="dynamics", description=__doc__.split("\n\n")[0],
                                epilog="Run 'dynamics COMMAND --help' for a command's options.")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def robot_command(name, fn, help_):
        c = sub.add_parser(name, help=help_, description=help_)
        c.add_argument("robot", help="a URDF path or a bundled robot name (%s)" % ", ".join(robots.names()))
        c.add_argument("--floating-base", action="store_true", help="give the root link a free joint")
        c.set_defaults(fn=fn)
        return c

    c = robot_command("info", info, "summarise a robot: joints with their q/v slices, frames, warnings")
    c.add_argument("--json", action="store_true", help="print JSON")
    c.add_argument("--lenient", action="store_true", help="accept inertias that break the triangle inequality")
    robot_command("check", check, "print every warning and refusal; exit 0 if the robot loads and simulate takes it "
                  "at the neutral configuration, 1 if not")
    c = robot_command("simulate", simulate_command, "simulate and print the report (exit 2 if not ok, or with "
                                                   "--strict if the report warns)")
    c.add_argument("--duration", type=float, required=True, help="seconds")
    c.add_argument("--q0", help="initial q, comma separated (default: neutral)")
    c.add_argument("--v0", help="initial v, comma separated (default: zero)")
    c.add_argument("--torque", default="zero", help=TORQUE_HELP)
    c.add_argument("--contact", metavar="ground[:mu=M,...]", help=CONTACT_HELP)
    c.add_argument("--integrator", choices=INTEGRATORS)
    c.add_argument("--rtol", type=float)
    c.add_argument("--atol", type=float)
    c.add_argument("--dt", type=float, help="step of the fixed-step integrators")
    c.add_argument("--sample-dt", dest="sample_dt", type=float, help="output sample spacing")
    c.add_argument("--plot", metavar="FILE", help="save a figure of q, v, tau (png, pdf, svg)")
    c.add_argument("--out", metavar="FILE.npz", help="save t, q, v, tau and the report")
    c.add_argument("--json", action="store_true", help="print the report as JSON")
    c.add_argument("--strict", action="store_true", help="exit 2 when the report has warnings")
    c.add_argument("--lenient", action="store_true", help="accept inertias that break the triangle inequality")
    sub.add_parser("serve", help="run the HTTP service (options: dynamics serve --help)")
    c = robot_command("view", view, "open the inspector page on a robot (a bundled name, an id, or a URDF file, "
                                    "uploaded): its tree, bodies, poses, trajectories")
    c.add_argument("--trajectory", metavar="FILE.npz", help="a trajectory to play (dynamics simulate --out)")
    c.add_argument("--url", help="use the service at this address (default: start one here until Ctrl-C)")
    c.add_argument("--port", type=int, default=0, help="port of the service started here (default: a free one)")
    c.add_argument("--store", help="robot store of the service started here (default: a temporary one)")
    return p


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["serve"]:
        return serve(argv[1:])
    args = parser().parse_args(argv)
    try:
        code = args.fn(args)
        sys.stdout.flush()  # (here, so that a reader that went away is seen below, not at exit)
        return code
    except (DynamicsError, FileNotFoundError) as e:
        print(f"dynamics {args.command}: {e}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # `dynamics info ROBOT --json | head`: the reader has all it wanted
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # (Python's own flush at exit would fail)
        return 128 + 13  # as a tool killed by SIGPIPE reports it
