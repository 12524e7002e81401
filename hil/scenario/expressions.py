"""Expressions of time t from scenario files, such as the paper's d_s = [sin(pi*t), cos(pi*t), cos(pi*t)].

The text is parsed into a Python AST and every node is checked against a whitelist (numbers,
t, pi, e, + − * / ** %, unary minus, calls to a fixed set of math functions) before it is
compiled, so no attribute access, subscript, name lookup or builtin can run.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable

FUNCTIONS: dict[str, Callable[..., float]] = {
    "sin": math.sin, "cos": math.cos, "tan": math.tan, "asin": math.asin, "acos": math.acos,
    "atan": math.atan, "atan2": math.atan2, "exp": math.exp, "log": math.log, "sqrt": math.sqrt,
    "abs": abs, "min": min, "max": max, "floor": math.floor, "sign": lambda x: math.copysign(1.0, x) if x else 0.0,
    "step": lambda x: 1.0 if x >= 0 else 0.0,  # Heaviside: step(t - 5) switches on at 5 s
}
CONSTANTS = {"pi": math.pi, "e": math.e}
_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Name, ast.Load, ast.Call,
          ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.Mod, ast.USub, ast.UAdd)


class ExpressionError(ValueError):
    pass


def compile_expression(text: str | float | int) -> Callable[[float], float]:
    """A function of t; raises ExpressionError naming what is not allowed."""
    if isinstance(text, (int, float)):
        value = float(text)
        return lambda t: value
    try:
        tree = ast.parse(str(text), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"'{text}' is not a valid expression ({exc.msg})") from exc
    for node in ast.walk(tree):
        if not isinstance(node, _NODES):
            raise ExpressionError(f"'{text}': {type(node).__name__} is not allowed")
        if isinstance(node, ast.Constant) and not isinstance(node.value, (int, float)):
            raise ExpressionError(f"'{text}': only numbers are allowed as constants")
        if isinstance(node, ast.Name) and node.id not in FUNCTIONS and node.id not in CONSTANTS and node.id != "t":
            raise ExpressionError(f"'{text}': unknown name '{node.id}' (use t, pi, e, {', '.join(FUNCTIONS)})")
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS or node.keywords:
                raise ExpressionError(f"'{text}': only calls to {', '.join(FUNCTIONS)} are allowed")
    code = compile(tree, "<scenario expression>", "eval")
    namespace = {"__builtins__": {}, **FUNCTIONS, **CONSTANTS}

    def evaluate(t: float) -> float:
        return float(eval(code, namespace, {"t": t}))  # noqa: S307 - the AST was whitelisted above

    try:
        evaluate(0.0)
    except (ArithmeticError, ValueError, TypeError) as exc:
        raise ExpressionError(f"'{text}' fails at t = 0: {exc}") from exc
    return evaluate
