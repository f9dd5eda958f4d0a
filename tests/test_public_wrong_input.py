"""Every public callable of every importable module of ``dynamics``, called with wrong input, returns or raises a
Python exception: the interpreter never dies by a signal (the C++ core reads only what the bindings checked; a
crash there would kill the process); and the top-level functions answer wrong input with a ``ValueError``
subclass (``dynamics.errors``) or a ``TypeError``, not an ``IndexError`` or a crash.  Each in a fresh interpreter,
so that nothing another test imported or patched can hide what ``import dynamics`` does.
"""

import functools
import json
import os
import pkgutil
import subprocess
import sys
import tempfile

import pytest

import dynamics

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGE_DIR = os.path.dirname(os.path.abspath(dynamics.__file__))


# ---------------------------------------------------------------------------------------------------------------
# wrong input to every public callable

#: ``dynamics.__main__`` runs the command line when imported.  Modules that need an optional extra
#: (pyproject's [project.optional-dependencies]) are skipped when it is absent (their import raises ImportError).
SKIP_MODULES = {"dynamics.__main__"}
#: seconds one call may take before it counts as hung, and all the calls together
CALL_TIMEOUT, TOTAL_TIMEOUT = 60, 1800

# One interpreter imports every module and lists every public callable (no leading underscore, defined in the
# package: its own or re-exported; an object reachable from several modules is called once, under its own module
# if that shows it, else under the first that does; the top level's own names under ``dynamics``).  The calls of
# each callable run in a forked child: a call that kills it (a signal; SIGALRM after CALL_TIMEOUT s for a hang)
# is reported, and a new child goes on with the next call.
CALLER = r"""
import importlib, inspect, json, os, signal, sys, time, warnings
import numpy as np

modules, urdf, call_timeout = json.loads(sys.argv[1]), sys.argv[2], int(sys.argv[3])
sys.argv = ["probe"]  # a command-line entry point called here must not read the probe's own arguments
warnings.simplefilter("ignore")
os.environ["MPLBACKEND"] = "Agg"

def emit(**record):
    sys.stdout.write(json.dumps(record) + "\n")
    sys.stdout.flush()

def origin(obj):
    return getattr(getattr(obj, "py_func", obj), "__module__", None) or ""

def parameters(obj):
    # the positional parameters a call needs, at least one
    try:
        sig = inspect.signature(getattr(obj, "py_func", obj))
    except (TypeError, ValueError):
        return ["x"]
    names = [p.name for p in sig.parameters.values() if p.default is p.empty
             and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return names or ["x"]

BAD = {"a string": "x", "None": None, "a NaN array": np.full(6, np.nan),
       "an array of the wrong shape": np.zeros((2, 3, 5))}
found = {}  # id(object) -> (module, name, object)
for name in modules:
    try:
        module = importlib.import_module(name)
    except ImportError as e:  # an optional extra that is not installed
        emit(skip=name, reason=f"{type(e).__name__}: {e}")
        continue
    for attr in sorted(vars(module)):
        obj = getattr(module, attr)
        if (attr.startswith("_") or not callable(obj) or inspect.ismodule(obj)
                or not origin(obj).startswith("dynamics")):
            continue
        if id(obj) not in found or (name == origin(obj) and found[id(obj)][0] != "dynamics"):
            found[id(obj)] = (name, attr, obj)

import dynamics
model = dynamics.load_urdf(urdf)
groups = []  # per callable: its calls (label, arguments)
for name in modules:
    for _, attr, obj in sorted((v for v in found.values() if v[0] == name), key=lambda v: v[1]):
        params = parameters(obj)
        calls = [("no arguments", ())]
        for kind, value in BAD.items():
            calls.append((kind, (value,) * len(params)))
            if name == "dynamics" and params[0] == "model" and len(params) > 1:  # past the model check
                calls.append((f"a model, then {kind}", (model,) + (value,) * (len(params) - 1)))
        groups.append((name, attr, obj, calls))

emit(total=sum(len(g[3]) for g in groups))
for name, attr, obj, calls in groups:
    k = 0
    while k < len(calls):
        sys.stdout.flush()
        progress_r, progress_w = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child makes the calls from k on, telling the parent which one it is in
            os.close(progress_r)
            for j in range(k, len(calls)):
                label, args = calls[j]
                os.write(progress_w, b"%d\n" % j)
                signal.alarm(call_timeout)
                t0 = time.process_time()
                try:
                    obj(*args)
                except BaseException as e:
                    signal.alarm(0)
                    cls = type(e)
                    emit(module=name, name=attr, input=label, raised=f"{cls.__module__}.{cls.__qualname__}",
                         input_error=isinstance(e, (ValueError, TypeError)), message=" ".join(str(e).split())[:160],
                         cpu=time.process_time() - t0)
                else:
                    signal.alarm(0)
                    emit(module=name, name=attr, input=label, raised=None, input_error=False, message="",
                         cpu=time.process_time() - t0)
            os._exit(0)
        os.close(progress_w)
        with os.fdopen(progress_r, "rb") as f:
            started = [int(x) for x in f.read().split()]
        _, status = os.waitpid(pid, 0)
        if os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0:
            break
        j = started[-1] if started else k  # the call the child started and never finished
        how = (f"exit {os.WEXITSTATUS(status)}" if not os.WIFSIGNALED(status)
               else f"hung (no answer in {call_timeout} s)" if os.WTERMSIG(status) == signal.SIGALRM
               else f"killed by {signal.Signals(os.WTERMSIG(status)).name}")
        emit(died=1, module=name, name=attr, input=calls[j][0], how=how)
        k = j + 1
"""
def _modules():
    names = ["dynamics"] + [m.name for m in pkgutil.walk_packages(dynamics.__path__, "dynamics.")]
    return [n for n in names if n not in SKIP_MODULES]


@functools.lru_cache(maxsize=None)
def _wrong_input_calls():
    """Every public callable of every module called with wrong input (CALLER).  Returns (skipped modules,
    outcomes, deaths), deaths as {module: ["module.name(input): how", ...]}."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [REPO, os.environ.get("PYTHONPATH")])))
    urdf = os.path.join(REPO, "robots", "planar_2r.urdf")
    with tempfile.TemporaryDirectory(prefix="wrong-input-") as cwd:  # whatever a call writes lands here
        try:
            out = subprocess.run([sys.executable, "-c", CALLER, json.dumps(_modules()), urdf, str(CALL_TIMEOUT)],
                                 cwd=cwd, env=env, stdin=subprocess.DEVNULL, capture_output=True, text=True,
                                 timeout=TOTAL_TIMEOUT)
        except subprocess.TimeoutExpired as e:
            raise AssertionError(f"the calls took more than {TOTAL_TIMEOUT} s") from e
    records = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
    assert out.returncode == 0 and any("total" in r for r in records), \
        f"the probe failed (exit {out.returncode})\n{out.stderr[-3000:]}"
    skipped = {r["skip"]: r["reason"] for r in records if "skip" in r}
    outcomes = [r for r in records if "raised" in r]
    deaths = {}
    for r in records:
        if "died" in r:
            deaths.setdefault(r["module"], []).append(f"{r['module']}.{r['name']}({r['input']}): {r['how']}")
    total = next(r["total"] for r in records if "total" in r)
    assert len(outcomes) + sum(map(len, deaths.values())) == total, "some calls were not reported"
    return skipped, outcomes, deaths


@pytest.mark.parametrize("name", _modules())
def test_wrong_input_never_kills_the_interpreter(name):
    skipped, _, deaths = _wrong_input_calls()
    if name in skipped:
        pytest.skip(f"{name} needs an optional extra: {skipped[name]}")
    died = deaths.get(name, [])
    assert not died, f"{len(died)} calls did not come back with a result or a Python exception:\n" + "\n".join(died)


def test_top_level_functions_answer_wrong_input_with_an_input_error():
    """Each public function of ``dynamics`` (not the classes and modules it exports) answers every wrong input
    with a ``ValueError`` subclass or a ``TypeError``: the wrong value in every argument, and for the functions
    of a model, a real model then the wrong value in the others.  A return counts as an offence too (a NaN or a
    wrongly shaped array passed through unchecked)."""
    _, outcomes, deaths = _wrong_input_calls()
    functions = {n for n in dynamics.__all__ if callable(getattr(dynamics, n))
                 and not isinstance(getattr(dynamics, n), type)}
    offenders = [f"{o['name']}({o['input']}): " + (f"{o['raised']}: {o['message']}" if o["raised"] else "returned")
                 for o in outcomes if o["module"] == "dynamics" and o["name"] in functions and not o["input_error"]]
    offenders += deaths.get("dynamics", [])
    assert not offenders, f"{len(offenders)} wrong inputs not answered with an input error:\n" + "\n".join(offenders)
