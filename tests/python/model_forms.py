"""The forms of the independent model (model.py), as docs/model.md defines them: transforms,
numbers, 1-D and 2-D interpolation, and the error values of a machine file."""
import math
import os

import numpy as np

ROTARY = "ABC"

class ModelError(Exception):
    pass


# ---------------------------------------------------------------- transforms
def trans(v):
    t = np.eye(4)
    t[:3, 3] = v
    return t


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], dtype=float)


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]], dtype=float)


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)


def rot(a, b, c):
    return rx(a) @ ry(b) @ rz(c)


def err_transform(dx, dy, dz, ea, eb, ec):
    return trans([dx, dy, dz]) @ rot(ea, eb, ec)


def rot_about(index, sign, theta):
    return (rx, ry, rz)[index](sign * theta)


def rotvec(r):
    """Rotation vector (axis · angle) of a rotation matrix."""
    v = 0.5 * np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    s = float(np.linalg.norm(v))
    c = 0.5 * (r[0, 0] + r[1, 1] + r[2, 2] - 1.0)
    if s < 1e-300:
        return np.zeros(3)
    theta = math.atan2(s, c)
    if theta > 3.0:  # near pi the antisymmetric part loses the axis; not needed for errors
        raise ModelError("orientation error near pi")
    return v * (theta / s)


# ---------------------------------------------------------------- numbers
def is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def number(v, where):
    if not is_number(v) or not math.isfinite(float(v)):
        raise ModelError(f"{where}: expected a finite number, got {v!r}")
    return float(v)


def check_keys(d, allowed, where):
    extra = set(d) - set(allowed)
    if extra:
        raise ModelError(f"{where}: unknown key(s) {sorted(extra)}")


# ---------------------------------------------------------------- 1-D interpolation
def natural_spline_m(x, y):
    """Second derivatives of the natural cubic spline through (x, y)."""
    n = len(x)
    m = np.zeros(n)
    if n < 3:
        return m
    a = np.zeros((n, n))
    b = np.zeros(n)
    a[0, 0] = a[-1, -1] = 1.0
    for i in range(1, n - 1):
        h0, h1 = x[i] - x[i - 1], x[i + 1] - x[i]
        a[i, i - 1] = h0
        a[i, i] = 2 * (h0 + h1)
        a[i, i + 1] = h1
        b[i] = 6 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0)
    return np.linalg.solve(a, b)


def periodic_spline_m(x, y):
    """Second derivatives of the periodic cubic spline through (x, y), y[-1] == y[0]."""
    n = len(x) - 1  # intervals; unknowns m_0..m_{n-1}, m_n = m_0
    if n < 2:
        return np.zeros(n + 1)
    h = [x[i + 1] - x[i] for i in range(n)]
    a = np.zeros((n, n))
    b = np.zeros(n)
    for i in range(n):
        hp = h[i - 1]  # interval before node i (wrapping: h[-1] is the last interval)
        hn = h[i]
        yp = y[i - 1] if i > 0 else y[n - 1]
        a[i, (i - 1) % n] += hp
        a[i, i] += 2 * (hp + hn)
        a[i, (i + 1) % n] += hn
        b[i] = 6 * ((y[i + 1] - y[i]) / hn - (y[i] - yp) / hp)
    m = np.linalg.solve(a, b)
    return np.append(m, m[0])


class Table:
    def __init__(self, nodes, interp, periodic, arg_axis, where):
        if interp not in ("linear", "quadratic", "cubic"):
            raise ModelError(f"{where}: interp must be linear, quadratic or cubic, not {interp!r}")
        if not nodes:
            raise ModelError(f"{where}: empty table")
        xs = [p for p, _ in nodes]
        ys = [v for _, v in nodes]
        for i in range(1, len(xs)):
            if not xs[i] > xs[i - 1]:
                raise ModelError(f"{where}: positions must increase strictly")
        self.periodic = bool(periodic)
        if self.periodic:
            if arg_axis not in ROTARY:
                raise ModelError(f"{where}: periodic table of linear axis {arg_axis}")
            end = xs[0] + 360.0
            if xs[-1] > end:
                raise ModelError(f"{where}: periodic table spans more than 360°")
            if xs[-1] < end:
                xs.append(end)
                ys.append(ys[0])
        if interp == "quadratic" and len(xs) % 2 == 0:
            raise ModelError(f"{where}: quadratic table needs an odd node count, has {len(xs)}")
        self.x, self.y, self.interp = xs, ys, interp
        if interp == "cubic":
            self.m = (periodic_spline_m if self.periodic else natural_spline_m)(xs, ys)

    def __call__(self, q):
        x, y = self.x, self.y
        if self.periodic:
            q = x[0] + math.fmod(q - x[0], 360.0)
            if q < x[0]:
                q += 360.0
            q = min(q, x[-1])
        if len(x) == 1:
            return y[0]
        if q <= x[0]:
            return y[0]
        if q >= x[-1]:
            return y[-1]
        # interval i: x[i] <= q < x[i+1]
        i = max(j for j in range(len(x) - 1) if x[j] <= q)
        if self.interp == "linear":
            t = (q - x[i]) / (x[i + 1] - x[i])
            return y[i] + t * (y[i + 1] - y[i])
        if self.interp == "quadratic":
            e = 2 * (i // 2)
            x0, x1, x2 = x[e], x[e + 1], x[e + 2]
            y0, y1, y2 = y[e], y[e + 1], y[e + 2]
            l0 = (q - x1) * (q - x2) / ((x0 - x1) * (x0 - x2))
            l1 = (q - x0) * (q - x2) / ((x1 - x0) * (x1 - x2))
            l2 = (q - x0) * (q - x1) / ((x2 - x0) * (x2 - x1))
            return y0 * l0 + y1 * l1 + y2 * l2
        h = x[i + 1] - x[i]
        a = (x[i + 1] - q) / h
        b = (q - x[i]) / h
        m = self.m
        return a * y[i] + b * y[i + 1] + ((a ** 3 - a) * m[i] + (b ** 3 - b) * m[i + 1]) * h * h / 6.0


def bilinear(xs, ys, values, u, v):
    def locate(nodes, p):
        if p <= nodes[0]:
            return 0, 0.0
        if p >= nodes[-1]:
            return len(nodes) - 2, 1.0
        i = max(j for j in range(len(nodes) - 1) if nodes[j] <= p)
        return i, (p - nodes[i]) / (nodes[i + 1] - nodes[i])

    if len(xs) == 1 and len(ys) == 1:
        return values[0][0]
    if len(xs) == 1:
        j, t = locate(ys, v)
        return values[0][j] * (1 - t) + values[0][j + 1] * t
    if len(ys) == 1:
        i, s = locate(xs, u)
        return values[i][0] * (1 - s) + values[i + 1][0] * s
    i, s = locate(xs, u)
    j, t = locate(ys, v)
    return ((1 - s) * (1 - t) * values[i][j] + s * (1 - t) * values[i + 1][j]
            + (1 - s) * t * values[i][j + 1] + s * t * values[i + 1][j + 1])


# ---------------------------------------------------------------- error value forms
class Reader:
    def __init__(self, folder, chain_axes, thermal_inputs):
        self.folder = folder
        self.chain_axes = chain_axes
        self.thermal_inputs = thermal_inputs
        self.csv_cache = {}

    def axis_of(self, name, where):
        if not isinstance(name, str) or name not in self.chain_axes:
            raise ModelError(f"{where}: of = {name!r} is not an axis of the chain")
        return name

    def read_csv(self, name, column, where):
        path = os.path.join(self.folder, name)
        if path not in self.csv_cache:
            rows = []
            try:
                with open(path, encoding="utf-8-sig") as f:
                    lines = [(n + 1, l) for n, l in enumerate(f.read().splitlines())]
            except OSError as e:
                raise ModelError(f"{where}: cannot read {name}: {e}")
            lines = [(n, l) for n, l in lines if l.strip() and not l.strip().startswith("#")]
            header = [h.strip() for h in lines[0][1].split(",")]
            for n, l in lines[1:]:
                fields = [f.strip() for f in l.split(",")]
                if len(fields) != len(header):
                    raise ModelError(f"{name}:{n}: {len(fields)} fields, header has {len(header)}")
                rows.append([float(f) for f in fields])
            self.csv_cache[path] = (header, rows)
        header, rows = self.csv_cache[path]
        lower = [h.lower() for h in header]
        if not isinstance(column, str) or column.lower() not in lower:
            raise ModelError(f"{where}: {name} has no column {column!r}")
        j = lower.index(column.lower())
        return [(r[0], r[j]) for r in rows]

    def plain(self, v, own_axis, where, shorthand=False):
        """A form: number, poly, table/csv, table2d, sum. Returns (callable(pos), reverse, per_kelvin)
        where reverse/per_kelvin come only from the poly/table shorthand."""
        if is_number(v):
            c = number(v, where)
            return (lambda pos: c), None, None
        if not isinstance(v, dict):
            raise ModelError(f"{where}: not an error value: {v!r}")
        extra_ok = ["reverse", "per_kelvin"] if shorthand else []
        if "poly" in v:
            check_keys(v, ["poly", "of"] + extra_ok, where)
            coeffs = v["poly"]
            if not isinstance(coeffs, list) or not coeffs:
                raise ModelError(f"{where}: poly must be a non-empty list")
            coeffs = [number(c, f"{where}.poly") for c in coeffs]
            arg = self.axis_of(v["of"], where) if "of" in v else own_axis
            if arg is None:
                raise ModelError(f"{where}: poly without an axis (needs of)")

            def poly(pos, coeffs=coeffs, arg=arg):
                q = pos[arg]
                acc = 0.0
                for c in reversed(coeffs):
                    acc = acc * q + c
                return acc

            f = poly
        elif "table" in v or "csv" in v:
            if "table" in v:
                check_keys(v, ["table", "interp", "periodic", "of"] + extra_ok, where)
                nodes = v["table"]
                if not isinstance(nodes, list):
                    raise ModelError(f"{where}: table must be a list of [position, value]")
                nodes = [(number(p[0], where), number(p[1], where)) for p in nodes]
            else:
                check_keys(v, ["csv", "column", "interp", "periodic", "of"] + extra_ok, where)
                nodes = self.read_csv(v["csv"], v.get("column"), where)
            arg = self.axis_of(v["of"], where) if "of" in v else own_axis
            if arg is None:
                raise ModelError(f"{where}: table without an axis (needs of)")
            table = Table(nodes, v.get("interp", "linear"), v.get("periodic", False), arg, where)
            f = lambda pos, table=table, arg=arg: table(pos[arg])
        elif "table2d" in v:
            check_keys(v, ["table2d"], where)
            t = v["table2d"]
            check_keys(t, ["of", "x", "y", "values"], where + ".table2d")
            of = t["of"]
            if not isinstance(of, list) or len(of) != 2:
                raise ModelError(f"{where}: table2d.of must name two axes")
            ax, ay = self.axis_of(of[0], where), self.axis_of(of[1], where)
            xs = [number(p, where) for p in t["x"]]
            ys = [number(p, where) for p in t["y"]]
            vals = [[number(p, where) for p in row] for row in t["values"]]
            if len(vals) != len(xs) or any(len(r) != len(ys) for r in vals):
                raise ModelError(f"{where}: table2d values must have len(x) rows of len(y)")
            for nodes in (xs, ys):
                if any(not nodes[i] > nodes[i - 1] for i in range(1, len(nodes))) or not nodes:
                    raise ModelError(f"{where}: table2d positions must increase strictly")
            f = lambda pos, xs=xs, ys=ys, vals=vals, ax=ax, ay=ay: bilinear(xs, ys, vals, pos[ax], pos[ay])
        elif "sum" in v:
            check_keys(v, ["sum"], where)
            if not isinstance(v["sum"], list):
                raise ModelError(f"{where}: sum must be a list of forms")
            parts = [self.plain(p, own_axis, f"{where}.sum[{i}]")[0] for i, p in enumerate(v["sum"])]
            f = lambda pos, parts=parts: sum(p(pos) for p in parts)
        else:
            raise ModelError(f"{where}: not an error value form: {sorted(v)}")
        rev = v.get("reverse") if shorthand else None
        pk = v.get("per_kelvin") if shorthand else None
        return f, rev, pk

    def per_kelvin(self, pk, own_axis, where, numbers_only=False):
        if pk is None:
            return {}
        if not isinstance(pk, dict):
            raise ModelError(f"{where}.per_kelvin must be a table of inputs")
        out = {}
        for name, form in pk.items():
            if name not in self.thermal_inputs:
                raise ModelError(f"{where}.per_kelvin: {name!r} is not a declared thermal input")
            if numbers_only:
                c = number(form, f"{where}.per_kelvin.{name}")
                out[name] = lambda pos, c=c: c
            else:
                out[name] = self.plain(form, own_axis, f"{where}.per_kelvin.{name}")[0]
        return out

    def component(self, v, own_axis, where):
        """Returns ErrorValue for a component error of axis own_axis."""
        if isinstance(v, dict) and "value" in v:
            check_keys(v, ["value", "reverse", "per_kelvin"], where)
            value = self.plain(v["value"], own_axis, where + ".value")[0]
            reverse = self.plain(v["reverse"], own_axis, where + ".reverse")[0] if "reverse" in v else None
            pk = self.per_kelvin(v.get("per_kelvin"), own_axis, where)
        else:
            value, rev, pk = self.plain(v, own_axis, where, shorthand=True)
            reverse = self.plain(rev, own_axis, where + ".reverse")[0] if rev is not None else None
            pk = self.per_kelvin(pk, own_axis, where)
        return ErrorValue(value, reverse, pk, own_axis)

    def constant(self, v, where):
        """A location or spindle error: number or { value = number, per_kelvin = { s = number } }."""
        if is_number(v):
            return ErrorValue(lambda pos, c=number(v, where): c, None, {}, None)
        if isinstance(v, dict) and "value" in v:
            if "reverse" in v:
                raise ModelError(f"{where}: reverse is for component errors only")
            check_keys(v, ["value", "per_kelvin"], where)
            c = number(v["value"], where + ".value")
            pk = self.per_kelvin(v.get("per_kelvin"), None, where, numbers_only=True)
            return ErrorValue(lambda pos, c=c: c, None, pk, None)
        raise ModelError(f"{where}: a number or {{ value = number, per_kelvin = ... }}")


class ErrorValue:
    def __init__(self, value, reverse, per_kelvin, axis):
        self.value, self.reverse, self.pk, self.axis = value, reverse, per_kelvin, axis

    def __call__(self, pos, approach, temps, reference):
        base = self.value
        if self.reverse is not None and self.axis is not None and approach.get(self.axis, "+") == "-":
            base = self.reverse
        v = base(pos)
        for name, f in self.pk.items():
            v += f(pos) * (temps.get(name, reference) - reference)
        return v


