"""Cross-checks `volmap sample --exact` against tests/python/model.py (an independent Python
implementation of docs/model.md) on the embedded machines and on machine files written here to
exercise every form of the model, at a few hundred random commanded positions each, under several
evaluation inputs (approach directions, temperatures, poses), and reports the largest differences.

usage: compare_model.py VOLMAP_BINARY [--points N] [--seed S] [--keep DIR] [--only SUBSTRING]

Exit code 1 when a difference exceeds 1e-6 mm or 1e-9 rad (a definite bug in one of the two).
Every machine is also run with its error values scaled by 100 ("x100": angles up to 1e-2
rad, translations of millimetres), where second-order terms (composition order, small-angle
approximations) show far above the tolerance.
"""
import csv
import io
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
MODEL = os.path.join(HERE, "model.py")
EMBEDDED = ["vmc-li2015", "vmc-dobariya2015", "4axis-hwang2014", "5axis-hwang2014", "gantry-2m"]
ROTARY = "ABC"
TOL_VE, TOL_OE = 1e-6, 1e-9
SCALE = 100.0  # volmap refuses angular errors above 0.01 rad as a unit mistake


# ---------------------------------------------------------------- TOML writing and scaling
def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(v)


def toml_machine(m):
    out = []
    for k in ("name", "chain", "description"):
        if k in m:
            out.append(f"{k} = {toml_value(m[k])}")
    for sec in ("tool", "thermal", "spindle"):
        if sec in m:
            out.append(f"\n[{sec}]")
            out += [f"{k} = {toml_value(v)}" for k, v in m[sec].items()]
    for ax, body in m["axes"].items():
        out.append(f"\n[axes.{ax}]")
        out += [f"{k} = {toml_value(v)}" for k, v in body.items()]
    return "\n".join(out) + "\n"


def scale_form(v, s):
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return v * s
    v = dict(v)
    if "poly" in v:
        v["poly"] = [c * s for c in v["poly"]]
    if "table" in v:
        v["table"] = [[p, x * s] for p, x in v["table"]]
    if "table2d" in v:
        t = dict(v["table2d"])
        t["values"] = [[x * s for x in row] for row in t["values"]]
        v["table2d"] = t
    if "sum" in v:
        v["sum"] = [scale_form(x, s) for x in v["sum"]]
    for k in ("value", "reverse"):
        if k in v:
            v[k] = scale_form(v[k], s)
    if "per_kelvin" in v:
        v["per_kelvin"] = {k: scale_form(x, s) for k, x in v["per_kelvin"].items()}
    return v  # csv forms: the CSV itself is written scaled


def scale_machine(m, s):
    m = json.loads(json.dumps(m))
    for ax, body in m["axes"].items():
        for k in list(body):
            if k.startswith("E"):
                body[k] = scale_form(body[k], s)
    for k in list(m.get("spindle", {})):
        m["spindle"][k] = scale_form(m["spindle"][k], s)
    return m


# ---------------------------------------------------------------- machines written here
def forms3():
    """Linear axes, every form: constants, poly, linear/quadratic/cubic tables (inline and CSV),
    of, table2d, sum, the general form and its shorthand, reversal, thermal terms on component,
    location and spindle errors, offsets, direction = -1, a tool offset, reference_C != 20."""
    return {
        "name": "forms3", "chain": "FYXFZ",
        "tool": {"offset": [3.0, -2.0, -120.0]},
        "thermal": {"reference_C": 21.5, "inputs": ["ta", "tb", "tc"]},
        "axes": {
            "Y": {
                "range": [0.0, 400.0], "offset": [0.0, 10.0, -5.0], "direction": -1,
                "EC0Y": 1.5e-5, "EZ0Y": {"value": 0.002, "per_kelvin": {"tc": 0.0115}},
                "EYY": {"value": {"poly": [0.001, 3e-6, -2e-9]},
                        "reverse": {"sum": [0.006, {"poly": [0.0, 3e-6]}]},
                        "per_kelvin": {"ta": {"poly": [0.0, 11.5e-6]},
                                       "tb": {"table2d": {"of": ["X", "Z"], "x": [-100.0, 200.0, 500.0],
                                                          "y": [0.0, 150.0, 300.0],
                                                          "values": [[0.0, 1e-4, 2e-4], [1e-4, 3e-4, -1e-4], [2e-4, 0.0, 1e-4]]}}}},
                "EXY": {"csv": "y.csv", "column": "EXY", "interp": "quadratic"},
                "EZY": {"table": [[50.0, 0.001], [200.0, 0.004], [300.0, -0.002]], "interp": "linear",
                        "reverse": {"table": [[0.0, 0.0], [400.0, 0.003]], "interp": "linear"}},
                "EAY": {"poly": [-6e-6, 3e-8], "reverse": {"poly": [-4e-6, 3e-8]}},
                "EBY": {"csv": "y.csv", "column": "EBY", "interp": "cubic"},
                "ECY": {"poly": [2e-6, 1e-8], "of": "Z", "per_kelvin": {"tc": {"poly": [1e-7], "of": "X"}}},
            },
            "X": {
                "range": [-100.0, 500.0], "offset": [5.0, 0.0, 30.0],
                "EX0X": 0.001, "EB0X": {"value": 3e-6, "per_kelvin": {"tb": 1e-6}}, "EC0X": -7e-6,
                "EXX": {"table": [[-100.0, 0.0], [0.0, 0.002], [150.0, 0.0035], [300.0, 0.001], [500.0, 0.004]],
                        "interp": "cubic",
                        "reverse": {"table": [[-100.0, 0.003], [200.0, 0.001], [500.0, 0.005]], "interp": "quadratic"},
                        "per_kelvin": {"ta": {"poly": [0.0, 11.5e-6]}}},
                "EYX": {"table": [[-50.0, 0.0], [50.0, 0.002], [150.0, 0.003], [300.0, 0.001], [450.0, 0.0]],
                        "interp": "quadratic"},
                "EZX": {"poly": [0.0, 0.0, -2e-8], "of": "Z"},
                "EAX": {"csv": "x.csv", "column": "EAX", "interp": "cubic"},
                "EBX": {"table2d": {"of": ["X", "Y"], "x": [-100.0, 100.0, 300.0, 500.0], "y": [0.0, 200.0, 400.0],
                                    "values": [[1e-6, 2e-6, -1e-6], [3e-6, 0.0, 2e-6], [-2e-6, 4e-6, 1e-6], [0.0, 1e-6, 5e-6]]}},
                "ECX": {"sum": [1e-6, {"poly": [0.0, 1e-8], "of": "Y"},
                                {"table": [[0.0, 0.0], [150.0, 4e-6], [300.0, -2e-6]], "interp": "linear", "of": "Z"}]},
            },
            "Z": {
                "range": [0.0, 300.0], "offset": [0.0, 0.0, 50.0],
                "EX0Z": 0.0005, "EY0Z": -0.0004, "EZ0Z": 0.0003, "EA0Z": -1e-5, "EB0Z": 2e-5,
                "EC0Z": {"value": 4e-6, "per_kelvin": {"ta": -2e-7, "tc": 1e-7}},
                "EZZ": {"poly": [0.0, 5e-6], "reverse": {"poly": [-0.004, 5e-6]}},
                "EXZ": {"table": [[0.0, 0.0], [300.0, 0.002]], "interp": "cubic"},
                "EYZ": {"table": [[0.0, 0.0], [100.0, -0.002], [200.0, 0.001], [300.0, 0.0]], "interp": "cubic"},
                "EAZ": {"value": {"poly": [-5e-6, 5e-8]}, "per_kelvin": {"tc": {"sum": [1e-7, {"poly": [0.0, 1e-9]}]}}},
                "EBZ": {"value": 8e-6, "reverse": -3e-6},
                "ECZ": {"table2d": {"of": ["Z", "X"], "x": [0.0, 300.0], "y": [-100.0, 500.0],
                                    "values": [[1e-6, -1e-6], [2e-6, 3e-6]]}},
            },
        },
        "spindle": {"EXS": 0.002, "EYS": -0.001, "EZS": {"value": 0.0, "per_kelvin": {"tc": -0.0015}},
                    "EAS": 5e-6, "EBS": {"value": -4e-6, "per_kelvin": {"ta": 1e-7}}},
    }


def forms3_csv(s):
    x = "position,EAX\n" + "".join(f"{p},{v * s!r}\n" for p, v in
                                    [(-100, 0.0), (0, 3e-6), (120, -2e-6), (250, 1e-6), (400, 4e-6), (500, 0.0)])
    y = "# Y table\npos,EXY,EBY\n" + "".join(f"{p},{a * s!r},{b * s!r}\n" for p, a, b in
                                           [(0, 0.0, 1e-6), (100, 0.002, -2e-6), (200, 0.001, 3e-6),
                                            (300, -0.001, 0.0), (400, 0.0, 2e-6)])
    return {"x.csv": x, "y.csv": y}


def trunnion():
    """A trunnion table: Y on the bed, A on Y, C on A (work); X, Z on the tool side. Rotary
    offsets, every location error of the rotary axes, periodic linear/quadratic/cubic tables,
    a non-periodic rotary table, of a rotary axis, reversal of C, thermal on rotary errors,
    direction = -1 on A, positions of C beyond one turn."""
    return {
        "name": "trunnion", "chain": "FYACFXZ",
        "tool": {"offset": [0.0, 0.0, -180.0]},
        "thermal": {"reference_C": 20.0, "inputs": ["table"]},
        "axes": {
            "Y": {"range": [-200.0, 200.0], "EYY": {"poly": [0.0, 4e-6]}, "EC0Y": 1e-5,
                  "EZY": {"table": [[-200.0, 0.0], [0.0, 0.003], [200.0, 0.0]], "interp": "quadratic"},
                  "EAY": {"poly": [2e-6, 1e-8]}},
            "A": {"range": [-120.0, 30.0], "offset": [0.0, 0.0, 200.0], "direction": -1,
                  "EX0A": 0.004, "EY0A": -0.006, "EZ0A": 0.003, "EA0A": 1.2e-5, "EB0A": -2e-5, "EC0A": 1.7e-5,
                  "EXA": {"table": [[-120.0, 0.001], [-60.0, -0.002], [0.0, 0.0], [30.0, 0.0015]], "interp": "cubic"},
                  "EYA": {"poly": [0.0, 1e-5, 5e-8]},
                  "EZA": {"poly": [0.002, 0.0, -1e-7], "per_kelvin": {"table": {"poly": [0.0, -2e-6]}}},
                  "EAA": {"table": [[-120.0, -1e-5], [-45.0, 5e-6], [30.0, 8e-6]], "interp": "quadratic",
                          "reverse": {"table": [[-120.0, -2e-5], [30.0, 1e-5]], "interp": "linear"}},
                  "EBA": {"poly": [3e-6, 0.0, 2e-10], "of": "C"},
                  "ECA": {"table": [[0.0, 2e-6], [180.0, -2e-6]], "interp": "linear", "of": "C", "periodic": True}},
            "C": {"range": [-400.0, 400.0], "offset": [0.0, 0.0, 60.0],
                  "EX0C": 0.008, "EY0C": -0.005, "EZ0C": 0.002, "EA0C": 2.5e-5, "EB0C": -1.8e-5,
                  "EC0C": {"value": 1e-5, "per_kelvin": {"table": 1e-6}},
                  "ECC": {"table": [[0.0, 0.0], [45.0, 1.2e-5], [90.0, 6e-6], [135.0, -4e-6], [180.0, -1e-5],
                                    [225.0, -3e-6], [270.0, 7e-6], [315.0, 9e-6]], "interp": "cubic", "periodic": True,
                          "reverse": {"table": [[0.0, 5e-6], [120.0, -5e-6], [240.0, 2e-6]], "interp": "cubic",
                                      "periodic": True}},
                  "EXC": {"table": [[-90.0, 0.002], [0.0, 0.0], [90.0, -0.002], [180.0, 0.0]], "interp": "quadratic",
                          "periodic": True},
                  "EYC": {"table": [[10.0, 0.0], [100.0, 0.002], [190.0, 0.0], [280.0, -0.002], [370.0, 0.0]],
                          "interp": "cubic", "periodic": True},
                  "EZC": {"table": [[0.0, 0.001], [120.0, -0.0005], [240.0, 0.0015]], "interp": "linear",
                          "periodic": True},
                  "EAC": {"table2d": {"of": ["C", "A"], "x": [-400.0, 0.0, 400.0], "y": [-120.0, 30.0],
                                      "values": [[4e-6, 0.0], [-4e-6, 2e-6], [1e-6, 3e-6]]}},
                  "EBC": {"sum": [{"poly": [0.0, 1e-8]}, {"table": [[0.0, 4e-6], [180.0, -4e-6]],
                                                          "interp": "linear"}]}},
            "X": {"range": [-300.0, 300.0], "EXX": {"poly": [0.0, 5e-6]}, "EBX": 3e-6, "ECX": {"poly": [0.0, 1e-8]}},
            "Z": {"range": [-100.0, 400.0], "EA0Z": 1e-5, "EB0Z": -1.5e-5, "EZZ": {"poly": [0.0, -3e-6]},
                  "EXZ": {"poly": [0.0, 1e-5, -2e-8]}},
        },
        "spindle": {"EXS": 0.001, "EYS": 0.0008, "EZS": 0.002, "EAS": 5e-6, "EBS": -4e-6},
    }


def head():
    """A head machine: the work on X and Y; Z, C and A (with direction = -1 on C) on the tool side,
    offsets on the rotary axes, spindle errors and a long tool."""
    return {
        "name": "head", "chain": "FXYFZCA",
        "tool": {"offset": [1.5, -0.5, -220.0]},
        "axes": {
            "X": {"range": [0.0, 1000.0], "EXX": {"poly": [0.0, 6e-6]}, "EYX": {"poly": [0.0, 1e-5, -1e-8]},
                  "EAX": {"poly": [-3e-6, 6e-9]}, "EBX": 4e-6, "ECX": {"poly": [1e-6, -2e-9]}},
            "Y": {"range": [0.0, 800.0], "EC0Y": -1.2e-5, "EX0Y": 0.01, "EYY": {"poly": [0.0, -4e-6]},
                  "EZY": {"table": [[0.0, 0.0], [400.0, 0.004], [800.0, 0.0]], "interp": "quadratic"},
                  "EBY": {"poly": [5e-6, -1.25e-8]}},
            "Z": {"range": [0.0, 600.0], "offset": [0.0, 0.0, 400.0], "EA0Z": 1.1e-5, "EB0Z": -9e-6,
                  "EZZ": {"poly": [0.0, 8e-6], "reverse": {"poly": [0.003, 8e-6]}},
                  "EXZ": {"poly": [0.0, 3e-6]}, "EAZ": {"poly": [0.0, 1e-8]}, "ECZ": 2e-6},
            "C": {"range": [-360.0, 360.0], "direction": -1, "offset": [0.0, 0.0, -50.0],
                  "EX0C": 0.003, "EY0C": 0.002, "EA0C": -1.5e-5, "EB0C": 2.2e-5, "EC0C": 5e-6,
                  "ECC": {"table": [[0.0, 0.0], [90.0, 1e-5], [180.0, -5e-6], [270.0, 3e-6]], "interp": "cubic",
                          "periodic": True},
                  "EXC": {"poly": [0.0, 2e-6]}, "EZC": {"poly": [0.001, 0.0, 1e-8]},
                  "EAC": {"poly": [0.0, 2e-8]}, "EBC": {"poly": [0.0, -1e-8]}},
            "A": {"range": [-100.0, 100.0], "offset": [0.0, 20.0, -100.0],
                  "EY0A": 0.005, "EZ0A": -0.004, "EB0A": 2e-5, "EC0A": -3e-5,
                  "EAA": {"poly": [0.0, 1e-7, 2e-10], "reverse": {"poly": [2e-5, 1e-7, 2e-10]}},
                  "EYA": {"poly": [0.0, 1.5e-5]}, "EZA": {"poly": [0.001, 0.0, -8e-8]},
                  "EBA": {"poly": [0.0, 5e-8]}, "ECA": {"poly": [2e-6, -4e-8]}},
        },
        "spindle": {"EXS": 0.001, "EYS": 0.0008, "EZS": 0.002, "EAS": 5e-6, "EBS": -4e-6},
    }


def iso_trunnion():
    """The trunnion machine with its chain written as an ISO 10791 structural code."""
    m = trunnion()
    m["name"] = "trunnion-iso"
    m["chain"] = "w C' A' Y' b X Z t"
    return m


OWN = {"forms3": (forms3, forms3_csv), "trunnion": (trunnion, None), "head": (head, None),
       "trunnion-iso": (iso_trunnion, None)}


# ---------------------------------------------------------------- running
def read_csv(text):
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], rows[1:]


def run(cmd):
    p = subprocess.run(["nice", "-n", "10"] + cmd, capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def points(machine, n, rng, rotary_in_csv):
    axes = machine["axes"]
    cols = ["id", "X", "Y", "Z"] + [a for a in ROTARY if a in axes and rotary_in_csv]
    rows = []
    for i in range(n):
        row = [str(i)]
        for c in cols[1:]:
            lo, hi = axes[c]["range"] if c in axes else (0.0, 0.0)
            if i < 2:  # both ends of every travel
                v = (lo, hi)[i]
            elif c in ROTARY and i % 10 == 2:  # where periodic tables wrap and have nodes
                special = [v for v in (-370.0, -360.0, -270.0, -180.0, -90.0, 0.0, 45.0, 90.0, 100.0,
                                       180.0, 190.0, 270.0, 280.0, 360.0, 370.0) if lo <= v <= hi]
                v = rng.choice(special)
            else:
                v = rng.uniform(lo, hi)
                if rng.random() < 0.05:  # now and then a round position (table nodes)
                    v = float(round(v / 10.0) * 10.0)
                    v = min(max(v, lo), hi)
            row.append(repr(v))
        rows.append(row)
    return ",".join(cols) + "\n" + "".join(",".join(r) + "\n" for r in rows)


def variants(machine, rng):
    axes = list(machine["axes"])
    inputs = machine.get("thermal", {}).get("inputs", [])
    out = [("default", [])]
    out.append(("all-", ["--approach", ",".join(f"{a}=-" for a in axes)]))
    mix = ",".join(f"{a}={rng.choice('+-')}" for a in axes)
    temps = ",".join(f"{s}={rng.uniform(10.0, 35.0):.3f}" for s in inputs)
    args = ["--approach", mix]
    if temps:
        args += ["--temperatures", temps]
        out.append(("temps", ["--temperatures", temps]))
    out.append(("mixed" + ("+temps" if temps else ""), args))
    if temps:
        out.append(("all-+temps", out[1][1] + ["--temperatures", temps]))
    return out


def compare(binary, name, machine_arg, machine, folder, n, rng, report, failures):
    for rotary_in_csv in ([True, False] if any(a in machine["axes"] for a in ROTARY) else [True]):
        pts = points(machine, n, rng, rotary_in_csv)
        ppath = os.path.join(folder, f"points-{int(rotary_in_csv)}.csv")
        with open(ppath, "w") as f:
            f.write(pts)
        for vname, vargs in variants(machine, rng):
            extra = list(vargs)
            label = vname
            if not rotary_in_csv:
                pose = ",".join(f"{a}={rng.uniform(*machine['axes'][a]['range']):.4f}"
                                for a in ROTARY if a in machine["axes"])
                extra += ["--pose", pose]
                label += " pose " + pose
            rc1, out1, err1 = run([binary, "sample", "--exact", "--machine", machine_arg, "--points", ppath,
                                   "--device", "cpu"] + extra)
            rc2, out2, err2 = run([sys.executable, MODEL, os.path.join(folder, "machine.toml"), ppath] + extra)
            if rc1 != 0 or rc2 != 0:
                report.append((name, label, "FAILED", f"volmap rc={rc1} {err1.strip()[:300]} | model rc={rc2} {err2.strip()[:300]}"))
                failures.append((name, label, "run failed"))
                continue
            h1, r1 = read_csv(out1)
            h2, r2 = read_csv(out2)
            assert h1 == h2, (h1, h2)
            assert len(r1) == len(r2)
            k = h1.index("VE.X")
            dve = doe = ve = oe = 0.0
            worst = None
            same_text = 0
            for a, b in zip(r1, r2):
                assert a[:k] == b[:k]
                same_text += a == b
                va, vb = [float(x) for x in a[k:]], [float(x) for x in b[k:]]
                d1 = max(abs(va[i] - vb[i]) for i in range(3))
                d2 = max(abs(va[i] - vb[i]) for i in range(3, 6))
                ve = max(ve, math.sqrt(sum(x * x for x in va[:3])))
                oe = max(oe, math.sqrt(sum(x * x for x in va[3:])))
                if d1 > dve or d2 > doe:
                    if d1 / TOL_VE + d2 / TOL_OE > (dve / TOL_VE + doe / TOL_OE):
                        worst = (a, b)
                dve, doe = max(dve, d1), max(doe, d2)
            report.append((name, label, len(r1), dve, doe, ve, oe, same_text))
            if dve > TOL_VE or doe > TOL_OE:
                failures.append((name, label, worst, h1, extra))


def main(argv):
    binary = argv[1]
    if "--probes-only" in argv:
        return 1 if probes(binary, argv[argv.index("--keep") + 1] if "--keep" in argv else tempfile.mkdtemp()) else 0
    n = int(argv[argv.index("--points") + 1]) if "--points" in argv else 300
    seed = int(argv[argv.index("--seed") + 1]) if "--seed" in argv else 1
    keep = argv[argv.index("--keep") + 1] if "--keep" in argv else None
    only = argv[argv.index("--only") + 1] if "--only" in argv else ""
    rng = random.Random(seed)
    base = keep or tempfile.mkdtemp(prefix="model-check-")
    report, failures = [], []
    cases = []
    for name in EMBEDDED:
        text = subprocess.run([binary, "machines", "--show", name], capture_output=True, text=True, check=True).stdout
        cases.append((name, tomllib.loads(text), None, text))
    for name, (make, csvs) in OWN.items():
        cases.append((name, make(), csvs, None))
    for name, machine, csvs, text in cases:
        for scale in (1.0, SCALE):
            label = name + ("" if scale == 1.0 else f" x{SCALE:g}")
            if only and only not in label:
                continue
            folder = os.path.join(base, label.replace(" ", "-"))
            os.makedirs(folder, exist_ok=True)
            m = machine if scale == 1.0 else scale_machine(machine, scale)
            body = text if (text is not None and scale == 1.0) else toml_machine(m)
            with open(os.path.join(folder, "machine.toml"), "w") as f:
                f.write(body)
            for fname, content in (csvs(scale) if csvs else {}).items():
                with open(os.path.join(folder, fname), "w") as f:
                    f.write(content)
            machine_arg = name if (text is not None and scale == 1.0) else os.path.join(folder, "machine.toml")
            compare(binary, label, machine_arg, m, folder, n, rng, report, failures)
    print(f"{'machine':22} {'inputs':34} {'pts':>4} {'max dVE mm':>10} {'max dOE rad':>11} {'max|VE| mm':>10} {'max|OE| rad':>11} same-text")
    for r in report:
        if r[2] == "FAILED":
            print(f"{r[0]:22} {r[1][:34]:34} FAILED {r[3]}")
        else:
            print(f"{r[0]:22} {r[1][:34]:34} {r[2]:4d} {r[3]:10.2e} {r[4]:11.2e} {r[5]:10.3g} {r[6]:11.3g} {r[7]}/{r[2]}")
    for f in failures:
        print("DISAGREEMENT:", f)
    bad = probes(binary, base) if not only else []
    print(f"files in {base}")
    return 1 if failures or bad else 0



# ---------------------------------------------------------------- the machine file's rules
BASE = """name = "probe"
chain = "FYXFZ"
{top}
[tool]
offset = [0.0, 0.0, -100.0]
[axes.Y]
range = [0.0, 400.0]
{y}
[axes.X]
range = [0.0, 500.0]
{x}
[axes.Z]
range = [0.0, 300.0]
{z}
{rest}
"""
THERMAL = '[thermal]\nreference_C = 20.0\ninputs = ["t"]'

# (what, docs/model.md's verdict: "refuse" | "accept" | "open", machine parts, evaluation flags)
PROBES = [
    ("unknown key in an axis section", "refuse", {"x": "FOO = 1.0"}, []),
    ("unknown key in an error value", "refuse", {"x": "EXX = { poly = [0.0, 1e-6], foo = 1 }"}, []),
    ("component error of another axis in a section", "refuse", {"x": "EXY = 0.001"}, []),
    ("of an axis not in the chain", "refuse", {"x": 'EXX = { poly = [0.0, 1e-6], of = "B" }'}, []),
    ("per_kelvin input not declared", "refuse",
     {"top": "", "x": "EXX = { value = 0.0, per_kelvin = { t = 1e-6 } }"}, []),
    ("reverse on a location error", "refuse", {"y": "EC0Y = { value = 1e-5, reverse = 2e-5 }"}, []),
    ("a section for an axis not in the chain", "refuse", {"rest": "[axes.B]\nrange = [0.0, 10.0]"}, []),
    ("a location error given as a poly", "refuse", {"y": "EC0Y = { poly = [1e-5, 1e-8] }"}, []),
    ("a location error's per_kelvin given as a poly", "refuse",
     {"top": THERMAL, "y": "EC0Y = { value = 1e-5, per_kelvin = { t = { poly = [1e-6] } } }"}, []),
    ("quadratic table with an even node count", "refuse",
     {"x": 'EXX = { table = [[0, 0.0], [100, 0.001], [200, 0.002], [500, 0.0]], interp = "quadratic" }'}, []),
    ("periodic quadratic table closing to an even count", "refuse",
     {"rest": ""}, ["ROTARY:ECC = { table = [[0, 0.0], [120, 1e-5], [240, 0.0]], interp = \"quadratic\", periodic = true }"]),
    ("per_kelvin form with its own per_kelvin", "refuse",
     {"top": THERMAL, "x": "EXX = { value = 0.0, per_kelvin = { t = { poly = [0.0, 1e-6], per_kelvin = { t = 1.0 } } } }"}, []),
    ("per_kelvin form with a reverse", "refuse",
     {"top": THERMAL, "x": "EXX = { value = 0.0, per_kelvin = { t = { poly = [0.0, 1e-6], reverse = { poly = [1.0] } } } }"}, []),
    ("reverse on a spindle error", "refuse", {"rest": "[spindle]\nEXS = { value = 0.001, reverse = 0.002 }"}, []),
    ("reverse form with a reverse of its own", "refuse",
     {"x": "EXX = { value = 0.0, reverse = { poly = [0.001], reverse = { poly = [0.002] } } }"}, []),
    ("table2d with a short row", "refuse",
     {"x": 'EBX = { table2d = { of = ["X", "Y"], x = [0.0, 500.0], y = [0.0, 400.0], values = [[1e-6, 2e-6], [1e-6]] } }'}, []),
    ("table2d positions not increasing", "refuse",
     {"x": 'EBX = { table2d = { of = ["X", "Y"], x = [500.0, 0.0], y = [0.0, 400.0], values = [[1e-6, 2e-6], [1e-6, 0.0]] } }'}, []),
    ("table positions not increasing", "refuse",
     {"x": 'EXX = { table = [[0, 0.0], [300, 0.001], [200, 0.002]], interp = "linear" }'}, []),
    ("spindle key ECS (S has no roll)", "refuse", {"rest": "[spindle]\nECS = 1e-5"}, []),
    ("an axis without range", "refuse", {"z": "", "rest": ""}, ["NORANGE"]),
    ("sum inside sum, numbers in a sum", "accept",
     {"x": 'EXX = { sum = [0.001, { sum = [{ poly = [0.0, 1e-6] }, 0.0005] }, { table = [[0, 0.0], [500, 0.002]], interp = "linear" }] }'}, []),
    ("general form with a table2d value and a sum reverse", "accept",
     {"x": 'EYX = { value = { table2d = { of = ["X", "Z"], x = [0.0, 500.0], y = [0.0, 300.0], values = [[0.0, 0.002], [0.001, 0.003]] } }, reverse = { sum = [0.001, { poly = [0.0, 1e-6], of = "Y" }] } }'},
     ["--approach", "X=-"]),
    ("ISO 10791 code for FYXFZ", "accept", {"chain": "w X' Y' b Z t",
                                             "x": "EXX = { poly = [0.0, 1e-5] }\nEC0X = 2e-5"}, []),
    ("periodic table ending at q0 + 360", "accept", {}, [
        "ROTARY:ECC = { table = [[0, 0.0], [90, 1e-5], [180, -5e-6], [270, 3e-6], [360, 0.0]], interp = \"cubic\", periodic = true }"]),
    ("interp left out", "open", {"x": "EXX = { table = [[0, 0.0], [100, 0.003], [300, 0.001], [500, 0.004]] }"}, []),
    ("[thermal] without reference_C", "open",
     {"top": '[thermal]\ninputs = ["t"]', "x": "EXX = { value = 0.0, per_kelvin = { t = { poly = [0.0, 1e-5] } } }"},
     ["--temperatures", "t=30"]),
    ("reverse on an error with of: X=- selects it?", "open",
     {"x": 'EXX = { poly = [0.0], of = "Z", reverse = { poly = [0.001], of = "Z" } }'}, ["--approach", "X=-"]),
    ("reverse on an error with of: Z=- selects it?", "open",
     {"x": 'EXX = { poly = [0.0], of = "Z", reverse = { poly = [0.001], of = "Z" } }'}, ["--approach", "Z=-"]),
    ("of in lower case", "open", {"x": 'EXX = { poly = [0.0, 1e-6], of = "z" }'}, []),
    ("spindle error as a poly of an axis", "open", {"rest": '[spindle]\nEZS = { poly = [0.0, 1e-6], of = "Z" }'}, []),
    ("periodic on a linear axis's table", "open",
     {"x": 'EXX = { table = [[0, 0.0], [100, 0.001]], interp = "linear", periodic = true }'}, []),
    ("a table of one node", "open", {"x": 'EXX = { table = [[100, 0.002]], interp = "linear" }'}, []),
    ("[tool] left out", "open", {"notool": True, "x": "EBX = 1e-4"}, []),
]


def probe_text(parts, flags):
    top = parts.get("top", "")
    text = BASE.format(top=top, x=parts.get("x", ""), y=parts.get("y", ""), z=parts.get("z", ""),
                       rest=parts.get("rest", ""))
    if "chain" in parts:
        text = text.replace('chain = "FYXFZ"', f'chain = "{parts["chain"]}"')
    if parts.get("notool"):
        text = text.replace("[tool]\noffset = [0.0, 0.0, -100.0]\n", "")
    rest_flags = []
    for f in flags:
        if f.startswith("ROTARY:"):
            text = text.replace('chain = "FYXFZ"', 'chain = "FYXCFZ"')
            text += "[axes.C]\nrange = [-360.0, 360.0]\n" + f[len("ROTARY:"):] + "\n"
        elif f == "NORANGE":
            text = text.replace("[axes.Z]\nrange = [0.0, 300.0]\n", "[axes.Z]\nEZZ = 0.001\n")
        else:
            rest_flags.append(f)
    return text, rest_flags


def probes(binary, base):
    folder = os.path.join(base, "probes")
    os.makedirs(folder, exist_ok=True)
    rows, bad = [], []
    for i, (what, verdict, parts, flags) in enumerate(PROBES):
        text, flags = probe_text(parts, flags)
        mpath = os.path.join(folder, f"p{i:02d}.toml")
        with open(mpath, "w") as f:
            f.write(text)
        ppath = os.path.join(folder, f"p{i:02d}.csv")
        with open(ppath, "w") as f:
            f.write("X,Y,Z" + (",C" if "axes.C" in text else "") + "\n" + "420,150,200" +
                    (",-100" if "axes.C" in text else "") + "\n")
        rc1, out1, err1 = run([binary, "sample", "--exact", "--machine", mpath, "--points", ppath,
                               "--device", "cpu"] + flags)
        rc2, out2, err2 = run([sys.executable, MODEL, mpath, ppath] + flags)
        v1 = out1.strip().splitlines()[-1].split(",")[-6:] if rc1 == 0 else err1.strip().splitlines()[0][:160]
        v2 = out2.strip().splitlines()[-1].split(",")[-6:] if rc2 == 0 else err2.strip().splitlines()[0][:160]
        agree = (rc1 == rc2) and (rc1 != 0 or max(abs(float(a) - float(b)) for a, b in zip(v1, v2)) < 1e-12)
        ok = {"refuse": rc1 == 2, "accept": rc1 == 0 and agree, "open": True}[verdict]
        rows.append((i, what, verdict, rc1, rc2, agree, v1, v2))
        if not ok:
            bad.append((i, what))
    print("\nMachine-file rules (p##.toml in", folder + ")")
    for i, what, verdict, rc1, rc2, agree, v1, v2 in rows:
        mark = "" if (verdict == "open" or (i, what) not in bad) else "  <-- against docs/model.md"
        print(f"p{i:02d} [{verdict}] {what}: volmap rc={rc1} model rc={rc2}{' (same)' if agree else ' (DIFFER)'}{mark}")
        if verdict == "open" or not agree or mark:
            print(f"     volmap: {v1}\n     model:  {v2}")
    return bad


if __name__ == "__main__":
    sys.exit(main(sys.argv))
