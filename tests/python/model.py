"""An independent implementation of the kinematic error model (docs/model.md) in Python, written
from the specification alone, to cross-check volmap's f64 reference (`volmap sample --exact`).

usage: model.py MACHINE.toml POINTS.csv [--pose B=30,C=-45] [--temperatures k=v,...]
                [--approach X=-,...] [--outside error|skip|nan]

Writes to standard output the CSV that `volmap sample --exact --machine MACHINE --points POINTS`
writes: the input's columns as written, then VE.X VE.Y VE.Z (mm) and OE.X OE.Y OE.Z (rad).

The model (docs/model.md, "Transforms" and "Outputs"):
  linear axis  A_k(q) = L_k · Trans(q·u_k) · E_k(q)
  rotary axis  A_k(q) = L_k · E_k(q) · Rot_u(q)
  L_k = Trans(o_k + (EX0k, EY0k, EZ0k)) · Rot(EA0k, EB0k, EC0k),  Rot(a, b, c) = Rx(a)·Ry(b)·Rz(c)
  E_rel = A_wm ⋯ A_w1 · A_t1 ⋯ A_tn · S · Trans(tool)
  VE = translation(E_rel) − translation(E_rel ideal),  OE = rotvec(R_real · R_idealᵀ)

Choices where the specification is silent (see the module's AMBIGUITIES list, printed by
`model.py --ambiguities`).
"""
import csv
import math
import os
import sys
import tomllib

import numpy as np

AXIS_LETTERS = "XYZABC"
LINEAR = "XYZ"
ROTARY = "ABC"
UNIT = {"X": 0, "Y": 1, "Z": 2, "A": 0, "B": 1, "C": 2}
COMPONENTS = "XYZABC"  # E<c><axis>: dx dy dz ea eb ec
SPINDLE_KEYS = ["EXS", "EYS", "EZS", "EAS", "EBS"]

AMBIGUITIES = """\
- interp left out of a table: taken as "linear".
- [thermal] without reference_C: taken as 20 °C (ISO 1); a machine without [thermal] has no inputs.
- [tool] or its offset left out: tool at [0, 0, 0].
- `reverse` on a component error whose form has `of`: the approach direction that selects it is the
  one of the error's own axis ("that axis"), not of the `of` axis.
- a table of one node: that value everywhere.
- a periodic table whose last node is at q0 + 360 exactly: used as is (its value there should equal
  v0; not checked); a last node beyond q0 + 360: refused.
- a periodic table's position wraps as q0 + ((q - q0) mod 360), then is looked up as usual.
- `periodic` on a table whose argument is a linear axis: refused.
- spindle errors: a number or { value = number, per_kelvin = { input = number } } as location errors
  (the specification calls S constant); other forms refused.
- CSV tables: the column is matched letter case aside; the first column is the position.
- `of` names an axis by its upper-case letter only (as volmap does).
- points CSV: a CSV column for a rotary axis wins over --pose for that axis.
- the commanded linear positions X Y Z of an axis the machine lacks are ignored.
- range is inclusive at both ends.
"""


# The forms (transforms, interpolation, error values) live beside this file.
from model_forms import (  # noqa: E402
    ErrorValue, ModelError, Reader, check_keys, err_transform, number, rot, rot_about, rotvec,
    trans,
)

# ---------------------------------------------------------------- machine
def parse_chain(chain):
    """Returns (work branch bed outward, tool branch bed outward)."""
    s = chain.strip()
    if s.startswith("F") and "w" not in s:
        body = s[1:]
        if body.count("F") != 1:
            raise ModelError(f"chain {chain!r}: needs F, the work branch, F, the tool branch")
        work, tool = body.split("F")
        work, tool = list(work), list(tool)
    else:
        # ISO 10791 structural code, workpiece to tool: w C' X' Y' b Z B t
        tokens = []
        t = s.replace(" ", "")
        i = 0
        while i < len(t):
            ch = t[i]
            if i + 1 < len(t) and t[i + 1] == "'":
                tokens.append(ch + "'")
                i += 2
            else:
                tokens.append(ch)
                i += 1
        if not tokens or tokens[0] != "w" or tokens[-1] != "t" or tokens.count("b") != 1:
            raise ModelError(f"chain {chain!r}: neither F notation nor an ISO 10791 code")
        bi = tokens.index("b")
        primed = tokens[1:bi]
        unprimed = tokens[bi + 1:-1]
        if any(not p.endswith("'") for p in primed) or any(p.endswith("'") for p in unprimed):
            raise ModelError(f"chain {chain!r}: primed letters belong before b, plain after")
        work = [p[0] for p in reversed(primed)]
        tool = list(unprimed)
    axes = work + tool
    for a in axes:
        if a not in AXIS_LETTERS:
            raise ModelError(f"chain {chain!r}: {a!r} is not an axis letter")
    if len(set(axes)) != len(axes):
        raise ModelError(f"chain {chain!r}: an axis twice")
    return work, tool


class Axis:
    pass


class Machine:
    def __init__(self, path):
        with open(path, "rb") as f:
            doc = tomllib.load(f)
        check_keys(doc, ["name", "chain", "description", "tool", "axes", "spindle", "thermal"], "machine")
        self.work, self.tool_branch = parse_chain(doc["chain"])
        chain_axes = self.work + self.tool_branch
        thermal = doc.get("thermal", {})
        check_keys(thermal, ["reference_C", "inputs"], "thermal")
        self.reference = number(thermal.get("reference_C", 20.0), "thermal.reference_C")
        self.inputs = list(thermal.get("inputs", []))
        reader = Reader(os.path.dirname(os.path.abspath(path)), chain_axes, self.inputs)
        tool = doc.get("tool", {})
        check_keys(tool, ["offset"], "tool")
        self.tool = [number(v, "tool.offset") for v in tool.get("offset", [0.0, 0.0, 0.0])]
        sections = doc.get("axes", {})
        for name in sections:
            if name not in chain_axes:
                raise ModelError(f"axes.{name}: not an axis of the chain")
        self.axes = {}
        for name in chain_axes:
            if name not in sections:
                raise ModelError(f"axes.{name}: missing")
            sec = sections[name]
            where = f"axes.{name}"
            ax = Axis()
            ax.name = name
            ax.rotary = name in ROTARY
            ax.index = UNIT[name]
            ax.sign = 1.0
            allowed = ["range", "offset", "direction"]
            allowed += [f"E{c}{name}" for c in COMPONENTS] + [f"E{c}0{name}" for c in COMPONENTS]
            check_keys(sec, allowed, where)
            if "direction" in sec:
                if sec["direction"] not in (1, -1):
                    raise ModelError(f"{where}.direction must be 1 or -1")
                ax.sign = float(sec["direction"])
            if "range" not in sec or not isinstance(sec["range"], list) or len(sec["range"]) != 2:
                raise ModelError(f"{where}.range: missing, or not [low, high]")
            lo, hi = (number(v, where + ".range") for v in sec["range"])
            if not lo < hi:
                raise ModelError(f"{where}.range: low must be below high")
            ax.range = (lo, hi)
            ax.offset = [number(v, where + ".offset") for v in sec.get("offset", [0.0, 0.0, 0.0])]
            zero = ErrorValue(lambda pos: 0.0, None, {}, None)
            ax.component = [reader.component(sec[f"E{c}{name}"], name, f"{where}.E{c}{name}")
                            if f"E{c}{name}" in sec else zero for c in COMPONENTS]
            ax.location = [reader.constant(sec[f"E{c}0{name}"], f"{where}.E{c}0{name}")
                           if f"E{c}0{name}" in sec else zero for c in COMPONENTS]
            self.axes[name] = ax
        sp = doc.get("spindle", {})
        check_keys(sp, SPINDLE_KEYS, "spindle")
        zero = ErrorValue(lambda pos: 0.0, None, {}, None)
        self.spindle = [reader.constant(sp[k], f"spindle.{k}") if k in sp else zero for k in SPINDLE_KEYS]

    def relative(self, ax, q, pos, approach, temps, ideal):
        ev = lambda e: e(pos, approach, temps, self.reference)
        if ideal:
            loc = trans(ax.offset)
            err = np.eye(4)
        else:
            l = [ev(e) for e in ax.location]
            loc = trans([ax.offset[i] + l[i] for i in range(3)]) @ rot(l[3], l[4], l[5])
            err = err_transform(*[ev(e) for e in ax.component])
        if ax.rotary:
            return loc @ err @ rot_about(ax.index, ax.sign, math.radians(q))
        u = np.zeros(3)
        u[ax.index] = ax.sign * q
        return loc @ trans(u) @ err

    def e_rel(self, pos, approach, temps, ideal):
        t = np.eye(4)
        for name in reversed(self.work):
            t = t @ self.relative(self.axes[name], pos[name], pos, approach, temps, ideal)
        for name in self.tool_branch:
            t = t @ self.relative(self.axes[name], pos[name], pos, approach, temps, ideal)
        if not ideal:
            s = [e(pos, approach, temps, self.reference) for e in self.spindle]
            t = t @ err_transform(s[0], s[1], s[2], s[3], s[4], 0.0)
        return t @ trans(self.tool)

    def errors(self, pos, approach, temps):
        real = self.e_rel(pos, approach, temps, False)
        ideal = self.e_rel(pos, approach, temps, True)
        ve = real[:3, 3] - ideal[:3, 3]
        oe = rotvec(real[:3, :3] @ ideal[:3, :3].T)
        return ve, oe


# ---------------------------------------------------------------- command line
def fmt(x):
    """Shortest round-trip decimal, as volmap writes it: plain decimals, exponent below 1e-5."""
    if x == 0:
        return "0.0" if math.copysign(1, x) > 0 else "-0.0"
    if not math.isfinite(x):
        return "NaN" if math.isnan(x) else ("inf" if x > 0 else "-inf")
    r = repr(x)
    mant, _, exp = r.partition("e")
    exp = int(exp) if exp else 0
    sign = "-" if mant.startswith("-") else ""
    mant = mant.lstrip("-")
    ip, _, fp = mant.partition(".")
    digits = (ip + fp).lstrip("0")
    point = len(ip) + exp - (len(ip + fp) - len((ip + fp).lstrip("0")))  # decimal point position
    digits = digits.rstrip("0") or "0"
    if abs(x) < 1e-5 or abs(x) >= 1e16:
        m = digits[0] + ("." + digits[1:] if len(digits) > 1 else "")
        return f"{sign}{m}e{point - 1}"
    if point <= 0:
        return sign + "0." + "0" * (-point) + digits
    if point >= len(digits):
        return sign + digits + "0" * (point - len(digits)) + ".0"
    return sign + digits[:point] + "." + digits[point:]


def parse_pairs(text, flag):
    out = {}
    if not text:
        return out
    for item in text.split(","):
        if "=" not in item:
            raise ModelError(f"{flag}: {item!r} is not NAME=VALUE")
        k, v = (s.strip() for s in item.split("=", 1))
        if k in out:
            raise ModelError(f"{flag}: {k} given twice")
        out[k] = v
    return out


def main(argv):
    if argv[1:] == ["--ambiguities"]:
        print(AMBIGUITIES, end="")
        return 0
    args = {"--pose": "", "--temperatures": "", "--approach": "", "--outside": "error"}
    pos_args = []
    i = 1
    while i < len(argv):
        a = argv[i]
        if a in args:
            args[a] = argv[i + 1]
            i += 2
        elif "=" in a and a.split("=", 1)[0] in args:
            k, v = a.split("=", 1)
            args[k] = v
            i += 1
        else:
            pos_args.append(a)
            i += 1
    if len(pos_args) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    machine = Machine(pos_args[0])
    chain_axes = set(machine.axes)
    pose = {k.upper(): float(v) for k, v in parse_pairs(args["--pose"], "--pose").items()}
    for k in pose:
        if k not in ROTARY or k not in chain_axes:
            raise ModelError(f"--pose: {k} is not a rotary axis of the machine")
    temps = {k: float(v) for k, v in parse_pairs(args["--temperatures"], "--temperatures").items()}
    for k in temps:
        if k not in machine.inputs:
            raise ModelError(f"--temperatures: {k!r} is not a thermal input")
    approach = {k.upper(): v for k, v in parse_pairs(args["--approach"], "--approach").items()}
    for k, v in approach.items():
        if k not in chain_axes or v not in "+-" or len(v) != 1:
            raise ModelError(f"--approach: {k}={v}")

    with open(pos_args[1], encoding="utf-8-sig", newline="") as f:
        lines = [l for l in f.read().splitlines()]
    rows = [(n + 1, l) for n, l in enumerate(lines) if l.strip() and not l.strip().startswith("#")]
    header_line = rows[0][1]
    header = [h.strip() for h in header_line.split(",")]
    upper = [h.upper() for h in header]
    for a in "XYZ":
        if a not in upper:
            raise ModelError(f"{pos_args[1]}: no column {a}")
    rotary_cols = [a for a in ROTARY if a in upper]
    for a in rotary_cols:
        if a not in chain_axes:
            raise ModelError(f"{pos_args[1]}: column {a}: the machine has no axis {a}")
    out = sys.stdout
    out.write(header_line.strip() + ",VE.X,VE.Y,VE.Z,OE.X,OE.Y,OE.Z\n")
    for n, line in rows[1:]:
        fields = [s.strip() for s in line.split(",")]
        pos = {a: 0.0 for a in AXIS_LETTERS}
        pos.update({a: v for a, v in pose.items()})
        for a in "XYZ" + "".join(rotary_cols):
            pos[a] = float(fields[upper.index(a)])
        outside = [a for a in chain_axes
                   if not machine.axes[a].range[0] <= pos[a] <= machine.axes[a].range[1]]
        if outside:
            if args["--outside"] == "skip":
                continue
            if args["--outside"] == "error":
                raise ModelError(f"{pos_args[1]}:{n}: {outside[0]} = {pos[outside[0]]} outside the travel")
            vals = [math.nan] * 6
        else:
            ve, oe = machine.errors(pos, approach, temps)
            vals = list(ve) + list(oe)
        out.write(",".join(fields + [fmt(float(v)) for v in vals]) + "\n")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv))
    except ModelError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
