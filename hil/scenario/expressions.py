"""Expressions of time t from scenario files, such as the paper's d_s = [sin(pi*t), cos(pi*t), cos(pi*t)].

The text is parsed into a Python AST and every node is checked against a whitelist (numbers,
t, pi, e, + − * / ** %, unary minus, calls to a fixed set of math functions) before it is
compiled, so no attribute access, subscript, name lookup or builtin can run.

The work is bounded as well: the text is at most MAX_LENGTH characters and its tree at most MAX_DEPTH
levels deep (checked before the recursive compiler sees it), and every number is a float, so `9**9**9`
or `10**10000000` overflows at once instead of computing an integer of millions of digits.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Iterable

FUNCTIONS: dict[str, Callable[..., float]] = {
    "sin": math.sin, "cos": math.cos, "tan": math.tan, "asin": math.asin, "acos": math.acos,
    "atan": math.atan, "atan2": math.atan2, "exp": math.exp, "log": math.log, "sqrt": math.sqrt,
    "abs": abs, "min": min, "max": max, "floor": lambda x: float(math.floor(x)),  # a float: no big integers
    "sign": lambda x: math.copysign(1.0, x) if x else 0.0,
    "step": lambda x: 1.0 if x >= 0 else 0.0,  # Heaviside: step(t - 5) switches on at 5 s
}
CONSTANTS = {"pi": math.pi, "e": math.e}
_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Name, ast.Load, ast.Call,
          ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.Mod, ast.USub, ast.UAdd)
MAX_LENGTH = 500  # characters; the paper's expressions have about 20
MAX_DEPTH = 100  # levels of the syntax tree: sin(pi*t) has 5, a sum of n terms n + 2
ECHO_CHARS = 80


def echo(value: object) -> str:
    """`value` as an error message quotes it: its repr, cut to ECHO_CHARS (a 100 kB literal is not shown)."""
    text = repr(value)
    return text if len(text) <= ECHO_CHARS else text[:ECHO_CHARS - 1] + "…"


class ExpressionError(ValueError):
    """The text is not an allowed expression, or it fails at one of the times it was tried at."""


class EvaluationError(ExpressionError):
    """An expression failed at time t: carries the expression, the scenario field it came from (if the
    caller named it) and t, so that the message can say which of a scenario's expressions broke, and when."""

    def __init__(self, expression: str, field: str, t: float, reason: str) -> None:
        self.expression, self.field, self.t, self.reason = expression, field, t, reason
        where = f"{field}: " if field else ""
        super().__init__(f"{where}{echo(expression)} fails at t = {t:g} s: {reason}")


def _depth(tree: ast.AST) -> int:
    """Levels of the tree, counted without recursion."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    return deepest


def _parse(text: str) -> ast.Expression:
    """The whitelisted tree of `text`, its numbers made floats."""
    shown = echo(text)
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"{shown} is {len(text)} characters long; at most {MAX_LENGTH} are allowed")
    try:
        tree = ast.parse(text, mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        raise ExpressionError(f"{shown} is not a valid expression ({getattr(exc, 'msg', exc)})") from None
    if _depth(tree) > MAX_DEPTH:
        raise ExpressionError(f"{shown} nests deeper than {MAX_DEPTH} levels; write it more simply")
    for node in ast.walk(tree):
        if not isinstance(node, _NODES):
            raise ExpressionError(f"{shown}: {type(node).__name__} is not allowed")
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise ExpressionError(f"{shown}: only numbers are allowed as constants")
            try:
                node.value = float(node.value)
            except OverflowError:
                raise ExpressionError(f"{shown}: a number too large for a float (above 1.8e308)") from None
        if isinstance(node, ast.Name) and node.id not in FUNCTIONS and node.id not in CONSTANTS and node.id != "t":
            raise ExpressionError(f"{shown}: unknown name '{node.id}' (use t, pi, e, {', '.join(FUNCTIONS)})")
        if isinstance(node, ast.Call) and (not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS
                                           or node.keywords):
            raise ExpressionError(f"{shown}: only calls to {', '.join(FUNCTIONS)} are allowed")
    return tree


def _reason(exc: Exception) -> str:
    if isinstance(exc, OverflowError):
        return "the result overflows a float (above 1.8e308)"
    return str(exc) or type(exc).__name__


def compile_expression(text: str | float, field: str = "",
                       sample_times: Iterable[float] = (0.0,)) -> Callable[[float], float]:
    """A function of t that returns a finite float or raises EvaluationError (naming `field`); it is tried at
    `sample_times` first, so a mistake such as 1/t is an ExpressionError here rather than during a run."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value = float(text)
        if not math.isfinite(value):
            raise ExpressionError(f"found {value}, expected a finite number or an expression of t")
        return lambda t: value
    source = str(text)
    code = compile(_parse(source), "<scenario expression>", "eval")
    namespace = {"__builtins__": {}, **FUNCTIONS, **CONSTANTS}

    def evaluate(t: float) -> float:
        try:
            value = float(eval(code, namespace, {"t": float(t)}))  # the AST was whitelisted above
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise EvaluationError(source, field, t, _reason(exc)) from None
        if not math.isfinite(value):
            raise EvaluationError(source, field, t, f"the result is {value}, not a finite number")
        return value

    for t in sample_times:
        evaluate(t)
    return evaluate
