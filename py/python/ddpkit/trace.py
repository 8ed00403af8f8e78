"""Tracing Python functions and reading CasADi SX functions into ddpkit tapes.

``ddpkit.Dynamics.from_function``, ``ddpkit.Cost.from_function`` and
``ddpkit.Constraint.from_function`` call a user's function **once** with symbolic inputs: ``x``
and ``u`` are numpy arrays of :class:`Sym` scalars, and every ``+ - * / **``, ``np.sin``,
``np.cos``, ``np.tan``, ``np.exp``, ``np.log``, ``np.sqrt``, ``np.arctan2``, ``np.tanh``,
``np.abs``, ``np.minimum``, ``np.maximum``, ``np.where``, indexing, stacking and ``@`` on small
matrices records a node of an expression graph. The graph goes to Rust as a tape (the JSON file
format of the ``ddp-tape`` crate), where common subexpressions are shared, constants folded, and
the solvers evaluate it with exact first and second derivatives: no Python runs during a solve.

What cannot be traced is an error naming the function and the reason, raised when the model is
built: branching in Python on a symbolic value (``if x[0] > 0:``; use ``np.where``), converting
one to a number (``float(x[0])``, ``math.sin``), an unsupported numpy function, a non-finite
constant, or an output of the wrong shape.

``from_casadi_json`` reads the algorithm of a CasADi ``SX`` ``Function`` (its instruction list)
into the same tape format; casadi is imported only by the caller that passes such a function.
"""

from __future__ import annotations

import json
import math
import numbers
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ddpkit._ddpkit import InvalidInputError, ShapeError


class TraceError(Exception):
    """A function cannot be traced (internal: re-raised as ``InvalidInputError`` naming it)."""


class _Graph:
    """The nodes recorded while one function is traced."""

    def __init__(self) -> None:
        self.nodes: List[list] = []
        self.consts: Dict[float, int] = {}

    def add(self, *node: Any) -> "Sym":
        self.nodes.append(list(node))
        return Sym(self, len(self.nodes) - 1)

    def const(self, v: float) -> "Sym":
        v = float(v)
        if not math.isfinite(v):
            raise TraceError(f"uses the non-finite constant {v}")
        if v not in self.consts:
            self.nodes.append(["const", v])
            self.consts[v] = len(self.nodes) - 1
        return Sym(self, self.consts[v])


_CURRENT: List[_Graph] = []


def _lift(v: Any, g: _Graph) -> "Sym":
    if isinstance(v, Sym):
        if v.graph is not g:
            raise TraceError("mixes symbolic values of two different traced functions")
        return v
    if isinstance(v, (bool, np.bool_)):
        return g.const(1.0 if v else 0.0)
    if isinstance(v, numbers.Real):
        return g.const(float(v))
    if isinstance(v, np.ndarray) and v.ndim == 0:
        return _lift(v.item(), g)
    raise TraceError(f"combines a symbolic value with {type(v).__name__} {v!r}")


def _unary(op: str) -> Callable[[Any], Any]:
    def f(a: Any) -> Any:
        if isinstance(a, Sym):
            return a.graph.add(op, a.index)
        return _NUMERIC[op](float(a))

    return f


def _binary(op: str) -> Callable[[Any, Any], Any]:
    def f(a: Any, b: Any) -> Any:
        g = a.graph if isinstance(a, Sym) else b.graph if isinstance(b, Sym) else None
        if g is None:
            return _NUMERIC[op](float(a), float(b))
        return g.add(op, _lift(a, g).index, _lift(b, g).index)

    return f


_NUMERIC: Dict[str, Callable[..., float]] = {
    "neg": lambda a: -a,
    "sin": math.sin,
    "cos": math.cos,
    "tan": math.tan,
    "exp": math.exp,
    "log": math.log,
    "sqrt": math.sqrt,
    "tanh": math.tanh,
    "abs": abs,
    "asin": math.asin,
    "acos": math.acos,
    "atan": math.atan,
    "sinh": math.sinh,
    "cosh": math.cosh,
    "asinh": math.asinh,
    "acosh": math.acosh,
    "atanh": math.atanh,
    "sign": lambda a: float(np.sign(a)),
    "floor": math.floor,
    "ceil": math.ceil,
    "not": lambda a: float(a == 0),
    "add": lambda a, b: a + b,
    "sub": lambda a, b: a - b,
    "mul": lambda a, b: a * b,
    "div": lambda a, b: a / b,
    "pow": lambda a, b: a**b,
    "atan2": math.atan2,
    "hypot": math.hypot,
    "min": min,
    "max": max,
    "lt": lambda a, b: float(a < b),
    "le": lambda a, b: float(a <= b),
    "eq": lambda a, b: float(a == b),
    "ne": lambda a, b: float(a != b),
    "and": lambda a, b: float(a != 0 and b != 0),
    "or": lambda a, b: float(a != 0 or b != 0),
}


def _where(c: Any, a: Any, b: Any) -> Any:
    if not isinstance(c, Sym):
        return a if c else b
    g = c.graph
    yes = g.add("if_else_zero", c.index, _lift(a, g).index)
    no = g.add("if_else_zero", g.add("not", c.index).index, _lift(b, g).index)
    return yes + no


# numpy ufunc name -> function of Sym / float scalars.
_UFUNCS: Dict[str, Callable[..., Any]] = {
    "add": lambda a, b: a + b,
    "subtract": lambda a, b: a - b,
    "multiply": lambda a, b: a * b,
    "true_divide": lambda a, b: a / b,
    "divide": lambda a, b: a / b,
    "power": lambda a, b: a**b,
    "float_power": lambda a, b: a**b,
    "negative": lambda a: -a,
    "positive": lambda a: a,
    "absolute": _unary("abs"),
    "fabs": _unary("abs"),
    "sin": _unary("sin"),
    "cos": _unary("cos"),
    "tan": _unary("tan"),
    "exp": _unary("exp"),
    "log": _unary("log"),
    "sqrt": _unary("sqrt"),
    "tanh": _unary("tanh"),
    "arcsin": _unary("asin"),
    "arccos": _unary("acos"),
    "arctan": _unary("atan"),
    "sinh": _unary("sinh"),
    "cosh": _unary("cosh"),
    "arcsinh": _unary("asinh"),
    "arccosh": _unary("acosh"),
    "arctanh": _unary("atanh"),
    "sign": _unary("sign"),
    "floor": _unary("floor"),
    "ceil": _unary("ceil"),
    "logical_not": _unary("not"),
    "arctan2": _binary("atan2"),
    "hypot": _binary("hypot"),
    "minimum": _binary("min"),
    "maximum": _binary("max"),
    "fmin": _binary("min"),
    "fmax": _binary("max"),
    "less": _binary("lt"),
    "less_equal": _binary("le"),
    "greater": lambda a, b: _binary("lt")(b, a),
    "greater_equal": lambda a, b: _binary("le")(b, a),
    "equal": _binary("eq"),
    "not_equal": _binary("ne"),
    "logical_and": _binary("and"),
    "logical_or": _binary("or"),
    "square": lambda a: a * a,
    "reciprocal": lambda a: 1.0 / a,
    "exp2": lambda a: 2.0**a,
    "expm1": lambda a: _unary("exp")(a) - 1.0,
    "log1p": lambda a: _unary("log")(1.0 + a),
    "log2": lambda a: _unary("log")(a) / math.log(2.0),
    "log10": lambda a: _unary("log")(a) / math.log(10.0),
    "deg2rad": lambda a: a * (math.pi / 180.0),
    "rad2deg": lambda a: a * (180.0 / math.pi),
    "radians": lambda a: a * (math.pi / 180.0),
    "degrees": lambda a: a * (180.0 / math.pi),
    "conjugate": lambda a: a,
}


def _plain(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.view(np.ndarray) if v.dtype == object else v.astype(object)
    if isinstance(v, Sym):
        # A 0-d object array, so that numpy does not hand the loop back to Sym.__array_ufunc__.
        a = np.empty((), dtype=object)
        a[()] = v
        return a
    return v


def _wrap(r: Any) -> Any:
    if isinstance(r, np.ndarray) and r.dtype == object:
        if r.ndim == 0:
            return r.item()
        return r.view(SymArray)
    return r


def _apply_ufunc(ufunc: np.ufunc, method: str, *inputs: Any, **kwargs: Any) -> Any:
    if kwargs.get("out") is not None:
        raise TraceError(f"calls np.{ufunc.__name__} with out=, which traced functions cannot use")
    kwargs.pop("out", None)
    name = ufunc.__name__
    plain = [_plain(v) for v in inputs]
    if name == "matmul" and method == "__call__":
        return _wrap(np.matmul(*plain, **kwargs))
    f = _UFUNCS.get(name)
    if f is None:
        raise TraceError(
            f"calls np.{name}, which traced functions do not support (supported: "
            + ", ".join(sorted(_UFUNCS) + ["matmul"])
            + ")"
        )
    if method == "__call__" and not any(isinstance(v, np.ndarray) for v in inputs):
        return f(*inputs)
    loop = np.frompyfunc(f, ufunc.nin, 1)
    try:
        fn = getattr(loop, method)
    except AttributeError:
        raise TraceError(f"uses np.{name}.{method}, which traced functions do not support") from None
    return _wrap(fn(*plain, **kwargs))


class Sym:
    """A symbolic scalar: a node of the expression graph being traced."""

    __slots__ = ("graph", "index")

    def __init__(self, graph: _Graph, index: int) -> None:
        self.graph = graph
        self.index = index

    def __repr__(self) -> str:
        return f"Sym(node {self.index})"

    def __add__(self, o: Any) -> Any:
        return _binary("add")(self, o) if not isinstance(o, np.ndarray) else NotImplemented

    def __radd__(self, o: Any) -> Any:
        return _binary("add")(o, self)

    def __sub__(self, o: Any) -> Any:
        return _binary("sub")(self, o) if not isinstance(o, np.ndarray) else NotImplemented

    def __rsub__(self, o: Any) -> Any:
        return _binary("sub")(o, self)

    def __mul__(self, o: Any) -> Any:
        return _binary("mul")(self, o) if not isinstance(o, np.ndarray) else NotImplemented

    def __rmul__(self, o: Any) -> Any:
        return _binary("mul")(o, self)

    def __truediv__(self, o: Any) -> Any:
        return _binary("div")(self, o) if not isinstance(o, np.ndarray) else NotImplemented

    def __rtruediv__(self, o: Any) -> Any:
        return _binary("div")(o, self)

    def __pow__(self, o: Any) -> Any:
        return _binary("pow")(self, o) if not isinstance(o, np.ndarray) else NotImplemented

    def __rpow__(self, o: Any) -> Any:
        return _binary("pow")(o, self)

    def __neg__(self) -> "Sym":
        return self.graph.add("neg", self.index)

    def __pos__(self) -> "Sym":
        return self

    def __abs__(self) -> "Sym":
        return self.graph.add("abs", self.index)

    def __lt__(self, o: Any) -> Any:
        return _binary("lt")(self, o)

    def __le__(self, o: Any) -> Any:
        return _binary("le")(self, o)

    def __gt__(self, o: Any) -> Any:
        return _binary("lt")(o, self)

    def __ge__(self, o: Any) -> Any:
        return _binary("le")(o, self)

    def __bool__(self) -> bool:
        raise TraceError(
            "branches in Python on a symbolic value (an `if`, `and`/`or`, `min`/`max` or a comparison "
            "used as a bool); write it with np.where, np.minimum or np.maximum"
        )

    def __float__(self) -> float:
        raise TraceError(
            "converts a symbolic value to a number (float(), math.* or a numeric array); use the numpy "
            "functions (np.sin, np.sqrt, ...) on x and u"
        )

    __int__ = __float__
    __index__ = __float__

    def __array_ufunc__(self, ufunc: np.ufunc, method: str, *inputs: Any, **kwargs: Any) -> Any:
        return _apply_ufunc(ufunc, method, *inputs, **kwargs)

    def __array_function__(self, func: Any, types: Any, args: Any, kwargs: Any) -> Any:
        return _apply_function(func, args, kwargs)

    # Methods numpy's object loops call by name.
    def sin(self) -> "Sym":
        return _unary("sin")(self)

    def cos(self) -> "Sym":
        return _unary("cos")(self)

    def tan(self) -> "Sym":
        return _unary("tan")(self)

    def exp(self) -> "Sym":
        return _unary("exp")(self)

    def log(self) -> "Sym":
        return _unary("log")(self)

    def sqrt(self) -> "Sym":
        return _unary("sqrt")(self)

    def tanh(self) -> "Sym":
        return _unary("tanh")(self)

    def arctan(self) -> "Sym":
        return _unary("atan")(self)

    def arcsin(self) -> "Sym":
        return _unary("asin")(self)

    def arccos(self) -> "Sym":
        return _unary("acos")(self)

    def sinh(self) -> "Sym":
        return _unary("sinh")(self)

    def cosh(self) -> "Sym":
        return _unary("cosh")(self)

    def arctan2(self, o: Any) -> "Sym":
        return _binary("atan2")(self, o)

    def conjugate(self) -> "Sym":
        return self


def _apply_function(func: Any, args: Any, kwargs: Any) -> Any:
    """numpy functions (``np.where``, ``np.stack``, ``np.sum``, ...) on symbolic arguments."""
    if func is np.where and len(args) + len(kwargs) == 3:
        c, a, b = (list(args) + list(kwargs.values()))[:3]
        return _wrap(np.frompyfunc(_where, 3, 1)(_plain(c), _plain(a), _plain(b)))

    def down(v: Any) -> Any:
        if isinstance(v, SymArray):
            return v.view(np.ndarray)
        if isinstance(v, Sym):
            return _plain(v)
        if isinstance(v, (list, tuple)):
            return type(v)(down(i) for i in v)
        return v

    return _wrap(func(*down(args), **{k: down(v) for k, v in kwargs.items()}))


class SymArray(np.ndarray):
    """A numpy object array of :class:`Sym`: numpy functions applied to it are traced."""

    def __array_ufunc__(self, ufunc: np.ufunc, method: str, *inputs: Any, **kwargs: Any) -> Any:
        return _apply_ufunc(ufunc, method, *inputs, **kwargs)

    def __array_function__(self, func: Any, types: Any, args: Any, kwargs: Any) -> Any:
        return _apply_function(func, args, kwargs)


def _symbols(g: _Graph, start: int, n: int) -> SymArray:
    a = np.empty(n, dtype=object)
    for i in range(n):
        a[i] = g.add("input", start + i)
    return a.view(SymArray)


def _fail(name: str, reason: str, cls: type = InvalidInputError) -> Exception:
    e = cls(f"{name}: {reason}")
    e.field = name
    return e


def _node_of(v: Any, g: _Graph, name: str, where: str) -> int:
    try:
        return _lift(v, g).index
    except TraceError as e:
        raise _fail(name, f"{where} {e}") from None


def function_name(f: Any) -> str:
    """A readable name of a callable, for error messages."""
    return str(getattr(f, "__qualname__", None) or getattr(f, "__name__", None) or repr(f))


def trace_json(f: Callable[..., Any], kind: str, nx: int, nu: Optional[int]) -> str:
    """Traces ``f`` and returns the tape document of ``kind`` (``"dynamics"``, ``"cost"``,
    ``"terminal_cost"`` or ``"constraint"``): ``f(x, u)``, or ``f(x)`` where ``nu`` is None."""
    name = function_name(f)
    if not callable(f):
        raise _fail("f", f"must be callable, got {type(f).__name__}")
    g = _Graph()
    x = _symbols(g, 0, nx)
    args: Tuple[Any, ...] = (x,) if nu is None else (x, _symbols(g, nx, nu))
    try:
        out = f(*args)
    except TraceError as e:
        raise _fail(name, str(e)) from None
    try:
        arr = np.asarray(out, dtype=object)
    except TraceError as e:
        raise _fail(name, str(e)) from None
    if kind in ("cost", "terminal_cost"):
        if arr.size != 1 or arr.ndim > 1:
            raise _fail(name, f"must return a scalar cost, returned shape {arr.shape}", ShapeError)
    elif kind == "dynamics":
        if arr.shape != (nx,):
            raise _fail(name, f"must return the next state (or xdot) of shape ({nx},), returned shape {arr.shape}", ShapeError)
    else:
        if arr.ndim > 1 or arr.size == 0:
            raise _fail(name, f"must return a scalar or a 1-D array of constraint rows, returned shape {arr.shape}", ShapeError)
    outputs = [_node_of(v, g, name, f"output {i}") for i, v in enumerate(arr.reshape(-1))]
    doc = {
        "format": "ddpkit-tape",
        "version": 1,
        "kind": kind,
        "nx": nx,
        "nu": nu,
        "nodes": g.nodes,
        "outputs": outputs,
        "source": f"traced from {name}",
    }
    return json.dumps(doc)


# CasADi operations -> tape operations (see casadi/core/calculus.hpp).
_CASADI_UNARY = {
    "OP_NEG": "neg",
    "OP_EXP": "exp",
    "OP_LOG": "log",
    "OP_SQRT": "sqrt",
    "OP_SIN": "sin",
    "OP_COS": "cos",
    "OP_TAN": "tan",
    "OP_ASIN": "asin",
    "OP_ACOS": "acos",
    "OP_ATAN": "atan",
    "OP_SINH": "sinh",
    "OP_COSH": "cosh",
    "OP_TANH": "tanh",
    "OP_ASINH": "asinh",
    "OP_ACOSH": "acosh",
    "OP_ATANH": "atanh",
    "OP_FABS": "abs",
    "OP_SIGN": "sign",
    "OP_FLOOR": "floor",
    "OP_CEIL": "ceil",
    "OP_NOT": "not",
    "OP_INV": "inv",
}
_CASADI_BINARY = {
    "OP_ADD": "add",
    "OP_SUB": "sub",
    "OP_MUL": "mul",
    "OP_DIV": "div",
    "OP_POW": "pow",
    "OP_CONSTPOW": "pow",
    "OP_ATAN2": "atan2",
    "OP_HYPOT": "hypot",
    "OP_FMIN": "min",
    "OP_FMAX": "max",
    "OP_LT": "lt",
    "OP_LE": "le",
    "OP_EQ": "eq",
    "OP_NE": "ne",
    "OP_AND": "and",
    "OP_OR": "or",
    "OP_IF_ELSE_ZERO": "if_else_zero",
}


def casadi_dims(F: Any, what: str) -> List[int]:
    """The sizes of ``F``'s inputs, checking that ``F`` is an SX function of dense vectors."""
    try:
        import casadi  # noqa: F401
    except ImportError:  # pragma: no cover - casadi is in the test requirements
        raise _fail(what, "needs the casadi package (pip install casadi)") from None
    if not hasattr(F, "is_a") or not hasattr(F, "n_instructions"):
        raise _fail(what, f"must be a casadi.Function, got {type(F).__name__}")
    if F.is_a("MXFunction"):
        raise _fail(what, f"'{F.name()}' is an MX function; pass F.expand() (an SX function) instead")
    if not F.is_a("SXFunction"):
        raise _fail(what, f"'{F.name()}' is a {F.class_name()}, not an SX function; pass F.expand()")
    if F.has_free():
        raise _fail(what, f"'{F.name()}' has free variables {F.get_free()}; make them inputs")
    sizes = []
    for i in range(F.n_in()):
        sp = F.sparsity_in(i)
        if not sp.is_dense() or (sp.size1() != 1 and sp.size2() != 1):
            raise _fail(what, f"input {i} of '{F.name()}' must be a dense vector, got {sp.dim()}", ShapeError)
        sizes.append(int(sp.nnz()))
    return sizes


def casadi_json(F: Any, kind: str, nx: int, nu: Optional[int], what: str) -> str:
    """The tape document of the SX function ``F`` (inputs ``(x, u)`` or ``x``, first output)."""
    import casadi as ca

    names = {getattr(ca, n): n for n in dir(ca) if n.startswith("OP_")}
    offsets = [0, nx]
    nodes: List[list] = []
    work: Dict[int, int] = {}
    m = int(F.sparsity_out(0).numel())
    out_nodes: List[Optional[int]] = [None] * m
    sp = F.sparsity_out(0)
    if sp.size1() != 1 and sp.size2() != 1:
        raise _fail(what, f"output 0 of '{F.name()}' must be a vector, got {sp.dim()}", ShapeError)
    rows, cols = sp.get_triplet()
    dense_index = [r + c * sp.size1() for r, c in zip(rows, cols)]

    def new(*node: Any) -> int:
        nodes.append(list(node))
        return len(nodes) - 1

    for k in range(F.n_instructions()):
        op = F.instruction_id(k)
        name = names.get(op, str(op))
        o = F.instruction_output(k)
        i = F.instruction_input(k)
        if name == "OP_INPUT":
            work[o[0]] = new("input", offsets[i[0]] + i[1])
        elif name == "OP_OUTPUT":
            if o[0] == 0:
                out_nodes[dense_index[o[1]]] = work[i[0]]
        elif name == "OP_CONST":
            v = float(F.instruction_constant(k))
            if not math.isfinite(v):
                raise _fail(what, f"'{F.name()}' uses the non-finite constant {v}")
            work[o[0]] = new("const", v)
        elif name == "OP_ASSIGN":
            work[o[0]] = work[i[0]]
        elif name == "OP_SQ":
            work[o[0]] = new("powc", work[i[0]], 2.0)
        elif name == "OP_TWICE":
            work[o[0]] = new("add", work[i[0]], work[i[0]])
        elif name in _CASADI_UNARY:
            work[o[0]] = new(_CASADI_UNARY[name], work[i[0]])
        elif name in _CASADI_BINARY:
            work[o[0]] = new(_CASADI_BINARY[name], work[i[0]], work[i[1]])
        else:
            raise _fail(what, f"'{F.name()}' uses the CasADi operation {name}, which ddpkit does not support")
    zero = None
    outputs = []
    for v in out_nodes:
        if v is None:
            if zero is None:
                zero = new("const", 0.0)
            v = zero
        outputs.append(v)
    doc = {
        "format": "ddpkit-tape",
        "version": 1,
        "kind": kind,
        "nx": nx,
        "nu": nu,
        "nodes": nodes,
        "outputs": outputs,
        "source": f"imported from CasADi function '{F.name()}'",
    }
    return json.dumps(doc)


def from_casadi_json(F: Any, kind: str) -> Tuple[str, int, Optional[int]]:
    """``(document, nx, nu)`` for the CasADi SX function ``F`` as ``kind``: ``"dynamics"``
    (``F(x, u)``), ``"cost"`` (``l(x, u)`` or, with one input, a terminal ``l(x)``) or
    ``"constraint"`` (``g(x, u)`` or ``g(x)``)."""
    what = {"dynamics": "F", "cost": "l", "constraint": "g"}.get(kind, "F")
    sizes = casadi_dims(F, what)
    if kind == "dynamics" and len(sizes) != 2:
        raise _fail(what, f"'{F.name()}' must take two inputs (x, u), takes {len(sizes)}")
    if kind in ("cost", "constraint") and len(sizes) not in (1, 2):
        raise _fail(what, f"'{F.name()}' must take (x, u) or x, takes {len(sizes)} inputs")
    if F.n_out() < 1:
        raise _fail(what, f"'{F.name()}' has no output")
    nx = sizes[0]
    nu = sizes[1] if len(sizes) == 2 else None
    if kind == "cost" and nu is None:
        kind = "terminal_cost"
    return casadi_json(F, kind, nx, nu, what), nx, nu


__all__ = ["Sym", "SymArray", "trace_json", "from_casadi_json", "function_name"]
