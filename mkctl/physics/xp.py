"""The math namespaces every equation is written on: one function, three ways to run it.

An equation of mkctl is written once on a namespace ``xp`` (``xp.sqrt``, ``xp.tanh``, ``xp.where``,
...) that the caller picks by the kind of value it holds: Python floats (the math module: cheap on
one value), numpy arrays, or sympy expressions (the compiled core's generator traces the equations
into C and differentiates them exactly). Effect terms (model-spec section 4c) and mechanisms
(section 3b) receive the namespace as their ``xp`` argument.

Example
-------
>>> from mkctl.physics.xp import math_for
>>> math_for(0.5).tanh(0.5) == math_for(0.5).tanh(0.5)
True
>>> import numpy as np
>>> math_for(np.array([0.5])) is np
True
"""
from __future__ import annotations

import math
import sys

import numpy as np


def is_symbolic(x) -> bool:
    """True for a sympy expression: :mod:`mkctl.native` evaluates the equations on symbols.

    sympy is looked up, not imported: if nothing imported it, no value can be symbolic.

    Parameters
    ----------
    x : object
        Any value: a float, an array, a sympy expression.

    Returns
    -------
    bool
        Whether x is a sympy expression (the compiled core's generator traces these into C).

    References
    ----------
    .. [1] model-spec section 4c (effect terms run on floats, arrays and sympy alike).
    """
    sympy = sys.modules.get("sympy")
    return sympy is not None and isinstance(x, sympy.Basic)


def as_values(x):
    """Scalars become Python floats, sympy expressions pass through, the rest float arrays.

    Scalar arithmetic on Python floats is fast (numpy's is not, on one value); a sympy expression
    is kept as it is so that the same equation can be traced.

    Parameters
    ----------
    x : float, int, numpy scalar, array_like or sympy expression
        A physical quantity in SI units (its unit is kept).

    Returns
    -------
    float, numpy.ndarray or sympy expression
        x as a Python float (for any real scalar but a bool), unchanged (a sympy expression), or a
        float numpy array (anything else).

    References
    ----------
    .. [1] model-spec section 1 (SI units everywhere inside the code).
    """
    if type(x) is float:
        return x
    if isinstance(x, (int, np.floating, np.integer)) and not isinstance(x, bool):
        return float(x)
    if is_symbolic(x):
        return x
    return np.asarray(x, dtype=float)


class _ScalarMath:
    """The few numpy functions the models use, for Python floats (much cheaper than numpy on
    scalars)."""

    sqrt, sin, cos, tanh, arctan2, arcsin, arccos, hypot, exp = (math.sqrt, math.sin, math.cos,
                                                                 math.tanh, math.atan2, math.asin,
                                                                 math.acos, math.hypot, math.exp)
    maximum, minimum, abs = staticmethod(max), staticmethod(min), staticmethod(abs)
    log = staticmethod(math.log)
    pi = math.pi

    @staticmethod
    def sign(x):
        return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)

    @staticmethod
    def where(condition, a, b):
        return a if condition else b


#: What every math namespace offers besides arithmetic (floats, numpy, sympy): the functions an
#: effect's terms may use (model-spec section 4c; :mod:`mkctl.analysis.effect_files`).
MATH_FUNCTIONS = ("sqrt", "exp", "log", "sin", "cos", "tanh", "abs", "sign", "maximum", "minimum",
                  "where", "pi")


class _SymbolicMath:
    """The same functions for sympy expressions (filled in on first use: sympy is imported only
    then)."""


def _symbolic_math():
    if not hasattr(_SymbolicMath, "sqrt"):
        import sympy

        # Max and Min are built unevaluated: sympy's own evaluation compares the arguments (whether
        # the tension can be negative, say) and took a third of the compiled core's generation; the
        # generated C is the same.
        def maximum(a, b):
            return sympy.Max(a, b, evaluate=False)

        def minimum(a, b):
            return sympy.Min(a, b, evaluate=False)

        for name, function in {
            "sqrt": sympy.sqrt, "sin": sympy.sin, "cos": sympy.cos, "tanh": sympy.tanh,
            "arctan2": sympy.atan2, "arcsin": sympy.asin, "arccos": sympy.acos, "exp": sympy.exp,
            "maximum": maximum, "pi": sympy.pi, "minimum": minimum, "abs": sympy.Abs,
            "sign": sympy.sign, "log": sympy.log,
            "hypot": lambda a, b: sympy.sqrt(a * a + b * b),
            "where": lambda condition, a, b: sympy.Piecewise((a, condition), (b, True)),
        }.items():
            # read on the class, never an instance: no staticmethod needed
            setattr(_SymbolicMath, name, function)
    return _SymbolicMath


def symbolic_math():
    """The math namespace for sympy expressions (numpy's names, :data:`MATH_FUNCTIONS` among them).

    What effect terms are traced with, by the compiled core's generator and by the effect-file
    checks alike. sympy is imported on the first call only.

    Returns
    -------
    namespace
        A class whose attributes (``sqrt``, ``exp``, ``maximum`` unevaluated, ``where`` as a
        ``Piecewise``, ``pi``, ...) build sympy expressions.

    References
    ----------
    .. [1] model-spec section 4c (your own effects: the functions a term may use).
    """
    return _symbolic_math()


def math_for(x):
    """The math namespace for x: scalar functions, numpy, or sympy. Same equations, every way.

    Parameters
    ----------
    x : float, array_like or sympy expression
        The value an equation is about to be evaluated on.

    Returns
    -------
    namespace
        The math module's functions under numpy's names for a Python float (cheap on one value),
        :mod:`numpy` for anything else that is not symbolic, :func:`symbolic_math` for a sympy
        expression.

    References
    ----------
    .. [1] model-spec sections 3b and 4c (mechanisms and effect terms receive it as ``xp``).
    """
    if type(x) is float:
        return _ScalarMath
    return _symbolic_math() if is_symbolic(x) else np


def math_for_all(*values):
    """The one namespace for several values: sympy if any is symbolic, numpy if any is an array.

    Parameters
    ----------
    *values : float, array_like or sympy expression
        The values one equation combines.

    Returns
    -------
    namespace
        :func:`symbolic_math` if any value is symbolic, else :mod:`numpy` if any is not a Python
        float, else the scalar functions (as :func:`math_for` gives for a float).

    References
    ----------
    .. [1] model-spec sections 3b and 4c.
    """
    for x in values:
        if type(x) is not float:
            break
    else:
        return _ScalarMath
    if any(is_symbolic(x) for x in values):
        return _symbolic_math()
    return np
