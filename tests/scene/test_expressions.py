"""The grammar of scene expressions of tau (symgen.scene.expressions): what it builds, what it
refuses and why, its bounds, and that every function it accepts reaches CasADi and C intact."""

from __future__ import annotations

import math
import shutil
import subprocess
import time

import pytest
import sympy as sp

from symgen.scene.expressions import (
    ALLOWED_FUNCTIONS,
    ALLOWED_NAMES,
    EXPRESSION_HINT,
    MAX_DEPTH,
    MAX_LENGTH,
    parse_tau_expression,
    tau_symbol,
)

TAU = tau_symbol()
P = parse_tau_expression


def test_tau_is_the_real_symbol_of_the_derivation():
    from symgen.model.derive import TAU as DAE_TAU

    assert TAU == DAE_TAU and TAU.is_real
    assert P("tau") == DAE_TAU and P("τ") == DAE_TAU and P("π") == sp.pi


@pytest.mark.parametrize(
    "text,expected",
    [
        ("0.1*sin(2*tau)", sp.Float("0.1") * sp.sin(2 * TAU)),
        ("1 + 2*3", sp.Integer(7)),
        ("(1 + 2)*3", sp.Integer(9)),
        ("8/4/2", sp.Integer(1)),  # left-associative
        ("2 - 3 - 4", sp.Integer(-5)),
        ("2^3^2", sp.Integer(512)),  # right-associative
        ("2**3**2", sp.Integer(512)),
        ("2^3**2", sp.Integer(512)),  # ^ and ** are one operator
        ("(2^3)^2", sp.Integer(64)),
        ("-tau^2", -(TAU**2)),  # power binds tighter than the sign
        ("-2^2", sp.Integer(-4)),
        ("2^-1", sp.Rational(1, 2)),  # a signed exponent
        ("2^-1^2", sp.Rational(1, 2)),  # 2^(-(1^2))
        ("--tau", TAU),
        ("+-+tau", -TAU),
        ("tau/2", TAU / 2),
        ("1/3*tau", TAU / 3),  # exact, as SymPy's own parser made it
        ("1.5", sp.Float("1.5")),
        (".5e1", sp.Float("5.0")),
        ("1.e2", sp.Float("100.0")),
        ("2.5E-3*tau", sp.Float("2.5e-3") * TAU),
        ("0.12345678901234567890*tau", sp.Float("0.12345678901234567890") * TAU),  # digits kept
        (" \t0.5 *\n Heaviside( tau - 1 ) ", sp.Float("0.5") * sp.Heaviside(TAU - 1)),
        ("abs(-tau) + Abs(tau)", 2 * sp.Abs(TAU)),
        ("sqrt(tau)*exp(-tau)*log(1 + tau)", sp.sqrt(TAU) * sp.exp(-TAU) * sp.log(1 + TAU)),
        ("tan(tau) + cos(tau)", sp.tan(TAU) + sp.cos(TAU)),
        ("min(tau, 1) + max(tau, 0, 2)", sp.Min(TAU, 1) + sp.Max(TAU, 2)),
        ("sign(tau - 1) + atan2(1, tau)", sp.sign(TAU - 1) + sp.atan2(1, TAU)),
        ("sinh(tau) + cosh(tau) + tanh(tau)", sp.sinh(TAU) + sp.cosh(TAU) + sp.tanh(TAU)),
        ("sin(pi/6)", sp.Rational(1, 2)),
        ("0*sin(tau)", sp.Integer(0)),
        ("sqrt(4)*tau + 2^10", 2 * TAU + 1024),
    ],
)
def test_grammar_builds_the_sympy_expression(text, expected):
    got = P(text)
    assert got == expected and sp.srepr(got) == sp.srepr(expected)


def test_same_expressions_as_sympy_parser_for_the_forms_in_use():
    """The scenes' forms give the very objects SymPy's parser gave (fingerprints unchanged)."""
    from sympy.parsing.sympy_parser import parse_expr  # reference only: trusted literal text

    local = {
        "tau": TAU,
        "pi": sp.pi,
        **{n: getattr(sp, n) for n in ("sin", "cos", "tan", "exp", "log", "sqrt", "Abs", "Heaviside")},
    }
    for text in [
        "0.1*sin(tau)",
        "0.2*cos(tau)",
        "0.5*Heaviside(tau - 1)",
        "2*tau**2 - 3*tau + 1",
        "exp(-tau)*sin(3*tau)",
        "0.05*sin(2*pi*tau) + 0.01*cos(4*pi*tau)",
        "(1 + tau)**-2",
        "-(tau - 1)**3",
        "Heaviside(tau - 0.5) - Heaviside(tau - 1.5)",
        "3.0*tau**0.5",
        "Abs(sin(tau))",
        "1e-3*tau",
        "-0.3",
    ]:
        old = parse_expr(text, local_dict=dict(local))
        assert sp.srepr(P(text)) == sp.srepr(old), text


def test_named_parameters():
    a, w = sp.Symbol("a", real=True), sp.Symbol("omega_1", real=True)
    assert P("a*sin(omega_1*tau)", {"a": a, "omega_1": w}) == a * sp.sin(w * TAU)
    with pytest.raises(ValueError, match="unknown name 'b'.*the names are tau, pi, a"):
        P("b*tau", {"a": a})
    with pytest.raises(ValueError, match="a is not a function"):
        P("a(tau)", {"a": a})
    for bad in ("sin", "tau", "pi", "_a", "a.b", "if"):
        with pytest.raises(ValueError, match="parameter name"):
            P("tau", {bad: a})


@pytest.mark.parametrize(
    "text,reason",
    [
        ("0 and sin(tau)", "'and' is a Python keyword"),
        ("1 if tau else 0", "'if' is a Python keyword"),
        ("tau or 1", "'or' is a Python keyword"),
        ("not tau", "'not' is a Python keyword"),
        ("lambda: 0", "'lambda' is a Python keyword"),
        ('0*sin(\'__import__("os").system("touch PWNED")\')', "strings are not allowed (at character 7)"),
        ('sin("1")', "strings are not allowed"),
        ("tau.real", "attribute access is not allowed"),
        ("().__class__", "attribute access is not allowed"),
        ("x[0]", "subscripts and lists are not allowed"),
        ("[tau]", "subscripts and lists are not allowed"),
        ("{1: 2}", "braces are not allowed"),
        ("tau == 1", "comparisons and assignments are not allowed"),
        ("tau < 1", "comparisons are not allowed"),
        ("tau; 1", "only one expression"),
        ("tau % 2", "'%' is not an operator"),
        ("1, 2", "',' outside a function call"),
        ("(1, 2)", "',' outside a function call"),
        ("sin(tau), 2", "',' outside a function call"),
        ("__import__", "names starting with '_' are not allowed"),
        ("_tau", "names starting with '_' are not allowed"),
        ("T0*sin(tau)", "unknown name 'T0'"),
        ("e", "unknown name 'e'"),
        ("erf(tau)", "unknown function 'erf'"),
        ("Piecewise(tau)", "unknown function 'Piecewise'"),
        ("eval(tau)", "unknown function 'eval'"),
        ("sin", "sin is a function: write sin(...)"),
        ("tau(2)", "tau is not a function"),
        ("sin(1, 2)", "sin takes 1 argument, got 2"),
        ("sin()", "sin takes 1 argument, got 0"),
        ("atan2(1)", "atan2 takes 2 arguments, got 1"),
        ("min(1)", "min takes at least 2 arguments, got 1"),
        ("2tau", "malformed number '2tau'"),
        ("1.2.3", "malformed number '1.2.3'"),
        ("0x10", "malformed number '0x10'"),
        ("1_000", "malformed number '1_000'"),
        ("1j", "malformed number '1j'"),
        ("sin(tau", "the '(' at character 4 is never closed"),
        ("tau)", "')' at character 4 closes nothing"),
        ("()", "empty parentheses"),
        ("1 +", "ends too early"),
        ("* 2", "an operand is missing before '*'"),
        ("2 3", "unexpected '3' at character 3 after a complete expression"),
        ("sin(tau) cos(tau)", "after a complete expression"),
        ("", "the expression is empty"),
        ("   ", "the expression is empty"),
        ("τ·2", "the character '·' is not allowed"),
        ("tau²", "the character '²' is not allowed"),
        ("é*tau", "names are ASCII"),
    ],
)
def test_rejected_with_a_reason(text, reason):
    with pytest.raises(ValueError) as exc:
        P(text)
    assert reason in str(exc.value)


def test_not_text_is_rejected():
    with pytest.raises(ValueError, match="must be text"):
        P(1.5)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "text,reason",
    [
        ("1e400", "the number 1e400 is not a finite double"),
        ("-1e309*tau", "the number 1e309 is not a finite double"),
        ("1" * 400, "is not a finite double"),
        ("1e-400", "below the smallest double"),
        ("1/0", "division by zero"),
        ("tau/(tau - tau)", "division by zero"),
        ("0^-1", "division by zero"),
        ("sqrt(-1)", "sqrt of the negative number -1 is not real"),
        ("log(0)", "log(0) is not finite"),
        ("log(-2)*tau", "is not real"),
        ("(-8)^(1/3)", "is not real"),
        ("(-2)^tau", "a negative base"),
        ("exp(1000)", "exp(1000) is too large"),
        ("cosh(800)*tau", "too large"),
        ("1e300*1e300", "too large"),
        ("10^400", "too large"),
        ("tan(pi/2)", "is not finite"),
        ("atan2(0, 0)", "atan2(0, 0) is undefined"),
        ("tau^10000", "the exponent 10000 is too large (at most 1000"),
        ("(3/7)^1000", "below the smallest double"),
    ],
)
def test_constants_must_be_finite_real_doubles(text, reason):
    with pytest.raises(ValueError) as exc:
        P(text)
    assert reason in str(exc.value)


HANGS_ELSEWHERE = [
    "9^9^9^9",
    "9**9**9**9",
    "2^2^2^2^2^2^2^2",
    "(tau+1)^(9^9^9)",
    "10^10^10*tau",
    "((3/7)^900)^900",
    "exp(exp(exp(exp(10))))",
    "sin(2*" * 12 + "2" + ")" * 12,
    "2*sin(-" * 12 + "2" + ")" * 12,
    "tanh(" * 19 + "3" + ")" * 19,
    "exp(3*tau*" * 19 + "tau" + ")" * 19,
    "(2+tau)^(" * 9 + "tau" + ")" * 9,
]


@pytest.mark.parametrize("text", HANGS_ELSEWHERE)
def test_pathological_inputs_end_quickly(text):
    """Inputs on which SymPy's own parser hangs or takes seconds: an answer (a value or a
    ValueError) without hanging. The bound is generous (a loaded CI machine); they take < 0.3 s."""
    P("1")  # SymPy imported beforehand
    t0 = time.perf_counter()
    try:
        P(text)
    except ValueError as exc:
        assert "too large" in str(exc) or "digits" in str(exc) or "below" in str(exc), exc
    assert time.perf_counter() - t0 < 3.0


def test_bounds_on_size_and_nesting():
    with pytest.raises(ValueError, match=f"too long .*at most {MAX_LENGTH}"):
        P("tau+" * 600 + "1")
    with pytest.raises(ValueError, match="more than 600 tokens"):
        P("+".join(["1"] * 400))
    assert P("(" * (MAX_DEPTH - 1) + "tau" + ")" * (MAX_DEPTH - 1)) == TAU
    for deep in (
        "(" * (MAX_DEPTH + 1) + "tau" + ")" * (MAX_DEPTH + 1),
        "-" * 200 + "tau",
        "sin(" * 100 + "tau" + ")" * 100,
        "2^" * 100 + "2",
        "(" * 500,
    ):
        with pytest.raises(ValueError, match="nested too deeply"):
            P(deep)


def test_hint_and_names_are_exported():
    assert set(ALLOWED_NAMES) == {"tau", "pi", *ALLOWED_FUNCTIONS}
    for name in ("sin", "Heaviside", "abs", "^"):
        assert name in EXPRESSION_HINT


# -- every function reaches the emitters with the value of an independent oracle ------------
ORACLE = {  # text -> the same formula in plain Python
    "sin(tau)": math.sin,
    "cos(tau)": math.cos,
    "tan(tau)": math.tan,
    "exp(-tau)": lambda t: math.exp(-t),
    "log(1 + tau)": lambda t: math.log(1 + t),
    "sqrt(tau)": math.sqrt,
    "abs(tau - 1)": lambda t: abs(t - 1),
    "Heaviside(tau - 1)": lambda t: 1.0 if t > 1 else 0.0,
    "sign(tau - 1)": lambda t: math.copysign(1, t - 1),
    "min(tau, 1)": lambda t: min(t, 1),
    "max(tau, 1, 0.5)": lambda t: max(t, 1),
    "atan2(tau, 1 - tau)": lambda t: math.atan2(t, 1 - t),
    "sinh(tau)": math.sinh,
    "cosh(tau)": math.cosh,
    "tanh(tau)": math.tanh,
    "2^-tau*tau^2.5": lambda t: 2**-t * t**2.5,
    "0.1*sin(2*pi*tau)": lambda t: 0.1 * math.sin(2 * math.pi * t),
}
POINTS = (0.3, 1.7)


def test_every_function_converts_to_casadi():
    import casadi as ca

    from symgen.backends.casadi.functions import SympyToCasadi

    t = ca.SX.sym("t")
    for text, oracle in ORACLE.items():
        f = ca.Function("f", [t], [SympyToCasadi({TAU: t})(P(text))])
        for x in POINTS:
            assert float(f(x)) == pytest.approx(oracle(x), rel=1e-14, abs=1e-15), text
        assert sp.latex(P(text))


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_every_function_prints_as_c(tmp_path):
    from symgen.backends.c.printer import CPrinter

    printer = CPrinter({TAU: "t"})
    body = "".join(
        f'    for (int i = 0; i < 2; ++i) {{ double t = pts[i]; printf("%.17g\\n", {printer.doprint(P(x))}); }}\n'
        for x in ORACLE
    )
    src = tmp_path / "e.c"
    src.write_text(
        "#include <math.h>\n#include <stdio.h>\nint main(void) {\n"
        f"    const double pts[2] = {{{POINTS[0]!r}, {POINTS[1]!r}}};\n{body}    return 0;\n}}\n"
    )
    exe = tmp_path / "e"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Werror", "-o", str(exe), str(src), "-lm"], check=True)
    values = [float(v) for v in subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()]
    expected = [oracle(x) for oracle in ORACLE.values() for x in POINTS]
    assert values == pytest.approx(expected, rel=1e-14, abs=1e-15)
