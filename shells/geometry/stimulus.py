"""Natural-curvature fields (model layer): the stimulus λ K(x) of b̄ = b° + λ K, shared by the
surface model and the axisymmetric model.

The paper imposes one uniform, isotropic natural curvature, K = a° (b̄ = b° + κ a°). Here

    K(x) = f(x) (f1 e1⊗e1 + f2 e2⊗e2),

with λ the continuation parameter (the models' ``kappa``), f a scalar field of the reference
position, and (f1, f2) an anisotropy in the principal directions of a surface of revolution, e1
along the meridian and e2 along the parallel (the model of a bilayer whose layers are oriented).
f = 1, (f1, f2) = (1, 1) is the paper's K = a°: both models then build exactly the forms they
build without a field.

The field is a text (``--kappa-field``) parsed once into a small expression tree: numbers, the
reference coordinates ``x, y, z``, ``r`` (distance from the axis), ``phi`` (azimuth) and
``theta`` (polar angle from +z seen from the origin: the angle from the pole on spheres and
caps), the constants ``pi`` and ``R`` (the shape's pole radius), arithmetic, comparisons,
``and``/``or``, and the functions of ``FUNCTIONS`` (``where(c, a, b)`` for piecewise fields by
region, ``step(s, w)`` = (1 + tanh(s/w))/2 for smoothed ones). Only these names and nodes are
accepted (no attribute access, no other calls), evaluated with NumPy. The models interpolate f
into a finite-element function of the reference surface (``interpolate``) and read (f1, f2) as
Constants: one compiled kernel serves every field (the forms of the uniform stimulus are the
ones without a field).
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from shells.errors import InputError

__all__ = ["FUNCTIONS", "TABLE_SUFFIXES", "UNIFORM", "VARIABLES", "CurvatureField",
           "field_radius", "names_table"]

#: names a field may use for the reference position
VARIABLES = ("x", "y", "z", "r", "phi", "theta")
#: functions a field may call, with their number of arguments
FUNCTIONS = {"sin": 1, "cos": 1, "tan": 1, "exp": 1, "log": 1, "sqrt": 1, "tanh": 1,
             "sinh": 1, "cosh": 1, "atan": 1, "asin": 1, "acos": 1, "abs": 1, "atan2": 2,
             "min": 2, "max": 2, "where": 3, "step": 2}
_CONSTANTS = ("pi", "R")
_BINOPS = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)
_CMPOPS = (ast.Lt, ast.LtE, ast.Gt, ast.GtE)
#: longest field text accepted (a field is a formula, not a program)
MAX_LENGTH = 2000


def _parse(text: str) -> ast.Expression:
    if not isinstance(text, str) or not text.strip():
        raise InputError("the kappa field must be a non-empty expression, e.g. "
                         "'where(theta < 0.3, 1, 0)'")
    if len(text) > MAX_LENGTH:
        raise InputError(f"the kappa field is {len(text)} characters long (at most "
                         f"{MAX_LENGTH})")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as e:
        raise InputError(f"the kappa field {text!r} is not an expression: {e.msg}") from None
    except (ValueError, RecursionError, MemoryError):  # null bytes, nesting beyond the parser
        raise InputError(f"the kappa field {text!r} is not an expression") from None
    for node in ast.walk(tree):
        ok = isinstance(node, (ast.Expression, ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Load,
                               ast.USub, ast.UAdd, ast.And, ast.Or, *_BINOPS, *_CMPOPS))
        if isinstance(node, ast.Constant):
            ok = isinstance(node.value, (int, float)) and not isinstance(node.value, bool)
        elif isinstance(node, ast.Name):
            ok = node.id in VARIABLES or node.id in _CONSTANTS or node.id in FUNCTIONS
            if not ok:
                raise InputError(f"unknown name {node.id!r} in the kappa field {text!r} "
                                 f"(variables: {', '.join(VARIABLES)}; constants: pi, R; "
                                 f"functions: {', '.join(FUNCTIONS)})")
        elif isinstance(node, ast.Compare):
            ok = len(node.ops) == 1 and isinstance(node.ops[0], _CMPOPS)
        elif isinstance(node, ast.Call):
            name = node.func.id if isinstance(node.func, ast.Name) else None
            if name not in FUNCTIONS:
                raise InputError(f"in the kappa field {text!r}: {ast.unparse(node.func)!r} is "
                                 f"not a function (functions: {', '.join(FUNCTIONS)})")
            if node.keywords or len(node.args) != FUNCTIONS[name]:
                raise InputError(f"in the kappa field {text!r}: {name} takes "
                                 f"{FUNCTIONS[name]} positional argument(s)")
            ok = True
        if not ok:
            raise InputError(f"the kappa field {text!r} uses {type(node).__name__}, which a "
                             "field may not (numbers, x y z r phi theta pi R, + - * / **, "
                             "< <= > >=, and/or, and the listed functions)")
    called = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    for node in ast.walk(tree):  # a function name used as a value (e.g. "sin + 1")
        if isinstance(node, ast.Name) and node.id in FUNCTIONS and id(node) not in called:
            raise InputError(f"in the kappa field {text!r}: {node.id!r} is a function")
    return tree


class _Algebra:
    """The tree's operations on NumPy arrays."""

    fn: dict[str, Callable[..., Any]] = {
        "sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
        "sqrt": np.sqrt, "tanh": np.tanh, "sinh": np.sinh, "cosh": np.cosh,
        "atan": np.arctan, "asin": np.arcsin, "acos": np.arccos, "abs": np.abs,
        "atan2": np.arctan2, "min": np.minimum, "max": np.maximum,
        "where": lambda c, a, b: np.where(c, a, b),
        "step": lambda s, w: 0.5 * (1 + np.tanh(np.asarray(s) / w))}
    cmp = {ast.Lt: np.less, ast.LtE: np.less_equal, ast.Gt: np.greater,
           ast.GtE: np.greater_equal}
    boolop = {ast.And: np.logical_and, ast.Or: np.logical_or}

    def eval(self, node: ast.AST, env: dict[str, Any]) -> Any:
        if isinstance(node, ast.Expression):
            return self.eval(node.body, env)
        if isinstance(node, ast.Constant):  # NumPy scalars: 0**-1 is inf, not an exception
            return np.float64(node.value)
        if isinstance(node, ast.Name):
            return env[node.id]
        if isinstance(node, ast.UnaryOp):
            v = self.eval(node.operand, env)
            return -v if isinstance(node.op, ast.USub) else v
        if isinstance(node, ast.BinOp):
            a, b = self.eval(node.left, env), self.eval(node.right, env)
            op = type(node.op)
            return (a + b if op is ast.Add else a - b if op is ast.Sub else a * b
                    if op is ast.Mult else a / b if op is ast.Div else a ** b)
        if isinstance(node, ast.Compare):
            a, b = self.eval(node.left, env), self.eval(node.comparators[0], env)
            return self.cmp[type(node.ops[0])](a, b)
        if isinstance(node, ast.BoolOp):
            vals = [self.eval(v, env) for v in node.values]
            out = vals[0]
            for v in vals[1:]:
                out = self.boolop[type(node.op)](out, v)
            return out
        if isinstance(node, ast.Call):
            return self.fn[node.func.id](*(self.eval(a, env) for a in node.args))
        raise InputError(f"cannot evaluate {type(node).__name__} in a kappa field")


@dataclass(frozen=True)
class CurvatureField:
    """The natural-curvature stimulus K = f(x) (f1 e1⊗e1 + f2 e2⊗e2) (validated).

    Attributes:
        expr: f as a text of the reference position (see the module's docstring); "1" is the
            paper's uniform natural curvature. With a ``table``, the name of its file.
        anisotropy: (f1, f2), meridian and parallel factors; (1, 1) is isotropic.
        table: f given as values instead (``from_file``): rows (θ, f), piecewise linear in the
            polar angle θ (an axisymmetric profile), or rows (x, y, z, f) at points of the
            reference surface, interpolated by linear radial basis functions of the 16 nearest
            points (exact at the points).
    """

    expr: str = "1"
    anisotropy: tuple[float, float] = (1.0, 1.0)
    table: tuple[tuple[float, ...], ...] = ()

    def __post_init__(self) -> None:
        if self.table:
            object.__setattr__(self, "table", _check_table(self.table, self.expr))
            object.__setattr__(self, "_tree", None)
        else:
            object.__setattr__(self, "_tree", _parse(self.expr))
        an = self.anisotropy
        try:
            an = tuple(float(v) for v in an)
        except (TypeError, ValueError):
            raise InputError(f"anisotropy must be two numbers F1 F2, got {an!r}") from None
        if len(an) != 2 or not all(math.isfinite(v) for v in an) or an == (0.0, 0.0):
            raise InputError(f"anisotropy must be two finite numbers F1 F2, not both 0, "
                             f"got {self.anisotropy!r}")
        object.__setattr__(self, "anisotropy", an)

    # -- what the field is ---------------------------------------------------------------------
    @property
    def constant(self) -> float | None:
        """f's value if the text is a number (possibly signed), else None."""
        if self.table:
            return None
        body = self._tree.body  # type: ignore[attr-defined]
        return float(_Algebra().eval(body, {})) if _is_number(body) else None

    @property
    def isotropic(self) -> bool:
        return self.anisotropy[0] == self.anisotropy[1]

    @property
    def uniform(self) -> bool:
        """The paper's stimulus K = a° exactly (f = 1, isotropic with factor 1)."""
        return self.constant == 1.0 and self.anisotropy == (1.0, 1.0)

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (recorded with a run's parameters; a table with its rows)."""
        d: dict[str, Any] = {"kappa_field": self.expr.strip(),
                             "anisotropy": list(self.anisotropy)}
        if self.table:
            d["kappa_field_table"] = [list(r) for r in self.table]
        return d

    def header_entry(self) -> dict[str, Any]:
        """A run header's entry for the field: {"field": ``describe()``}, none for the uniform
        stimulus (so that the headers of uniform runs match those of files without fields)."""
        return {} if self.uniform else {"field": self.describe()}

    @classmethod
    def from_description(cls, d: dict[str, Any]) -> CurvatureField:
        """The field of a run description: its ``header_entry()``, else uniform."""
        fd = d.get("field")
        if not fd:
            return UNIFORM
        table = tuple(tuple(r) for r in fd.get("kappa_field_table", ()))
        return cls(fd["kappa_field"], tuple(fd["anisotropy"]), table)

    @classmethod
    def from_file(cls, path: str, anisotropy: tuple[float, float] = (1.0, 1.0)
                  ) -> CurvatureField:
        """A table of f from a text file (``TABLE_SUFFIXES``): rows "θ f" or "x y z f",
        separated by spaces, tabs, commas or semicolons, lines starting with # ignored; a header
        row names the columns (``theta,f`` or ``x,y,z,f``, in any order)."""
        from shells.files import read_number_rows

        rows = read_number_rows(path, "the kappa field file", "'theta f' or 'x y z f'",
                                columns=(("x", "y", "z", "f"), ("theta", "f")))
        return cls(path, anisotropy, rows)

    # -- evaluation ----------------------------------------------------------------------------
    def values(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, R: float = 1.0) -> np.ndarray:
        """f at reference points (NumPy)."""
        x, y, z = (np.asarray(v, dtype=float) for v in (x, y, z))
        r = np.hypot(x, y)
        if self.table:
            return self._table_values(x, y, z, r)
        env = {"x": x, "y": y, "z": z, "r": r, "phi": np.arctan2(y, x),
               "theta": np.arctan2(r, z), "pi": math.pi, "R": float(R)}
        try:
            with np.errstate(all="ignore"):
                v = _Algebra().eval(self._tree, env)  # type: ignore[attr-defined]
            v = np.asarray(v, dtype=float)
        except (ArithmeticError, ValueError, TypeError, RecursionError) as e:
            raise InputError(f"the kappa field {self.expr!r} cannot be evaluated: "
                             f"{type(e).__name__}") from None
        return np.broadcast_to(v, np.broadcast(x, y, z).shape)

    def _table_values(self, x: np.ndarray, y: np.ndarray, z: np.ndarray,
                      r: np.ndarray) -> np.ndarray:
        t = np.asarray(self.table)
        shape = np.broadcast(x, y, z).shape
        if t.shape[1] == 2:
            return np.interp(np.arctan2(r, z), t[:, 0], t[:, 1]).reshape(shape)
        from scipy.interpolate import RBFInterpolator

        if not hasattr(self, "_rbf"):
            object.__setattr__(self, "_rbf", RBFInterpolator(
                t[:, :3], t[:, 3], kernel="linear", neighbors=min(16, len(t))))
        pts = np.stack([np.broadcast_to(v, shape).ravel() for v in (x, y, z)], axis=1)
        return self._rbf(pts).reshape(shape)  # type: ignore[attr-defined]

    @property
    def scattered(self) -> bool:
        """f given at scattered points (a 4-column table)."""
        return bool(self.table) and len(self.table[0]) == 4

    def meridian_values(self, r: np.ndarray, z: np.ndarray, R: float = 1.0) -> np.ndarray:
        """f on the meridian (r, z) for the axisymmetric model: f(r, 0, z); a table of
        scattered points is averaged over 32 azimuths (it is axisymmetric only up to its
        interpolation error)."""
        if not self.scattered:
            return self.values(r, 0.0 * r, z, R)
        phis = np.linspace(0, 2 * math.pi, 32, endpoint=False)
        return np.mean([self.values(r * math.cos(p), r * math.sin(p), z, R) for p in phis],
                       axis=0)

    def interpolate(self, space: Any, position: Callable[[np.ndarray], tuple],
                    R: float, axisymmetric: bool = False) -> Any:
        """f as a ``fem.Function`` of the scalar ``space``: the models' forms read f as a
        coefficient, so one compiled kernel serves every field. ``position`` maps the
        interpolation points (3, N) to the reference coordinates (x, y, z); ``axisymmetric``:
        to (r, ·, z) of the meridian (``meridian_values``)."""
        from dolfinx import fem

        def values(p: np.ndarray) -> np.ndarray:
            x, y, z = position(p)
            v = self.meridian_values(x, z, R) if axisymmetric else self.values(x, y, z, R)
            return np.array(v, dtype=float)

        f = fem.Function(space, name="kappa_field")
        f.interpolate(values)
        f.x.scatter_forward()
        return f

    def check_on(self, shape: Any, axisymmetric: bool = False) -> None:
        """Refuse (InputError) a field that is not finite on ``shape``, vanishes on all of it,
        or (``axisymmetric``: the 1D model) depends on the azimuth. On a surface known only by
        its mesh (no meridian, no parallels): checked at its nodes, and isotropic only."""
        if not getattr(shape, "of_revolution", True):
            if self.anisotropy != (1.0, 1.0):
                raise InputError("an anisotropic natural curvature needs the meridian and "
                                 "parallel directions of a surface of revolution; this mesh "
                                 "is not one")
            x = shape.nodes
            f = self.values(x[:, 0], x[:, 1], x[:, 2], field_radius(shape))
            if not np.all(np.isfinite(f)):
                raise InputError(f"the kappa field {self.expr!r} is not finite on the mesh "
                                 f"(at the node {x[~np.isfinite(f)][0]})")
            if not np.any(f != 0):
                raise InputError(f"the kappa field {self.expr!r} vanishes on the whole shape: "
                                 "kappa would impose nothing")
            return
        t = np.linspace(0.0, shape.t_max, 401)
        rr, zz = shape.meridian(t)
        rr, zz = np.asarray(rr, dtype=float), np.asarray(zz, dtype=float)
        R = field_radius(shape)
        f0 = self.values(rr, 0 * rr, zz, R)
        if not np.all(np.isfinite(f0)):
            bad = t[~np.isfinite(f0)][0]
            raise InputError(f"the kappa field {self.expr!r} is not finite on the shape "
                             f"(at the meridian parameter t = {bad:.4g})")
        scale = max(float(np.max(np.abs(f0))), 0.0)
        fs = [f0]
        for phi in np.linspace(0.0, 2 * math.pi, 13)[1:-1]:
            f = self.values(rr * math.cos(phi), rr * math.sin(phi), zz, R)
            if not np.all(np.isfinite(f)):
                raise InputError(f"the kappa field {self.expr!r} is not finite on the shape "
                                 f"(at the azimuth phi = {phi:.4g})")
            fs.append(f)
            scale = max(scale, float(np.max(np.abs(f))))
        if scale == 0.0:
            raise InputError(f"the kappa field {self.expr!r} vanishes on the whole shape: "
                             "kappa would impose nothing")
        if axisymmetric:
            dev = max(float(np.max(np.abs(f - f0))) for f in fs)
            # scattered values: axisymmetric up to their interpolation (a few %); else exactly
            if dev > (0.05 if self.scattered else 1e-12) * scale:
                raise InputError(f"the kappa field {self.expr!r} depends on the azimuth phi "
                                 f"(by up to {dev / scale:.2g} of its largest value): the "
                                 "axisymmetric model needs a field of r, z or theta only; use "
                                 "--model surface")


#: file names --kappa-field reads as a table (anything else is an expression)
TABLE_SUFFIXES = (".csv", ".txt", ".dat", ".tsv")


def names_table(text: str) -> bool:
    """Whether a --kappa-field text names a table file (``TABLE_SUFFIXES``), not an expression.

    Args:
        text: the option's text.

    Returns:
        True for a table file's name.
    """
    return text.strip().lower().endswith(TABLE_SUFFIXES)
#: most rows a table may have
MAX_TABLE_ROWS = 200000


def _check_table(table: Any, name: str) -> tuple[tuple[float, ...], ...]:
    try:
        t = np.asarray(table, dtype=float)
    except (TypeError, ValueError):
        t = np.zeros((0,))  # ragged or not numbers
    if t.ndim != 2 or t.shape[1] not in (2, 4):
        raise InputError(f"the kappa field table {name!r} must have rows of 2 numbers "
                         "(theta f) or of 4 (x y z f), all rows alike")
    if not 2 <= len(t) <= MAX_TABLE_ROWS:
        raise InputError(f"the kappa field table {name!r} has {len(t)} rows (2 to "
                         f"{MAX_TABLE_ROWS})")
    if not np.all(np.isfinite(t)):
        raise InputError(f"the kappa field table {name!r} holds a value that is not finite")
    if t.shape[1] == 2 and not (np.all(np.diff(t[:, 0]) > 0) and t[0, 0] >= 0
                                and t[-1, 0] <= math.pi + 1e-12):
        raise InputError(f"the kappa field table {name!r}: theta (first column, radians) must "
                         "increase within [0, pi]; outside its range f is the nearest end's")
    if t.shape[1] == 4 and len(np.unique(t[:, :3], axis=0)) < len(t):
        raise InputError(f"the kappa field table {name!r} gives two values at one point")
    return tuple(tuple(float(v) for v in row) for row in t)


def field_radius(shape: Any) -> float:
    """The value of the field's constant ``R``.

    Args:
        shape: the shape.

    Returns:
        The shape's pole radius (the disk's radius).
    """
    return float(shape.R) if math.isfinite(shape.R) else float(shape.characteristic_size())


def _is_number(node: ast.AST) -> bool:
    if isinstance(node, ast.Constant):
        return True
    return isinstance(node, ast.UnaryOp) and _is_number(node.operand)


#: the paper's stimulus, K = a°
UNIFORM = CurvatureField()
