"""Constants of the 3-stage Radau IIA method (order 5, stiffly accurate, L-stable) used by the
emitted C solver, as decimal strings (21 digits: every literal rounds to the nearest double).

The stage equations are solved by simplified Newton in transformed variables, as in Hairer &
Wanner's RADAU5: with ``A`` the Butcher matrix, ``TI @ inv(A) @ T`` is block-diagonal
``[[GAMMA, 0, 0], [0, ALPHA, -BETA], [0, BETA, ALPHA]]``, which splits the 3N x 3N Newton
matrix into one real and one complex N x N matrix. ``DD`` are the weights of the embedded
error estimate: ``sum(DD * C) = -1``, ``sum(DD * C**2) = sum(DD * C**3) = 0``.
``tests/test_emit_c.py`` checks all of these identities.
"""

from __future__ import annotations

C = ("0.15505102572168219018", "0.64494897427831780982", "1.0")
A = (
    ("0.196815477223660425868", "-0.0655354258501983881085", "0.0237709743482201524204"),
    ("0.394424314739087276997", "0.292073411665228463021", "-0.0415487521259979301982"),
    ("0.37640306270046727505", "0.512485826188421613839", "0.111111111111111111111"),
)
GAMMA = "3.63783425274449573221"
ALPHA = "2.6810828736277521339"
BETA = "3.05043019924741056943"
T = (
    ("0.0944387624889752414875", "-0.141255295020954208428", "-0.0300291941051474244919"),
    ("0.250213122965333311377", "0.204129352293799931996", "0.382942112757261937795"),
    ("1.0", "1.0", "0.0"),
)
TI = (
    ("4.17871859155190472735", "0.327682820761062387083", "0.52337644549944954804"),
    ("-4.17871859155190472735", "-0.327682820761062387083", "0.47662355450055045196"),
    ("-0.502872634945786875951", "2.57192694985560542919", "-0.596039204828224924969"),
)
DD = ("-10.0488093998274155625", "1.38214273316074889579", "-0.333333333333333333333")

# Step control and Newton (RADAU5's names and meanings). THET: a new Jacobian is computed after
# an accepted step whose Newton iterations contracted slower than this (RADAU5: 0.001 when the
# Jacobian is cheap, about 0.1 when it is costly). The emitted solver's Jacobian costs the
# model's Jacobian functions, the dense LU of the algebraic block g_z (the polish's) and a
# refactorization of the sparse Newton matrices (their pivots kept: symgen_splu_covers), about
# a step's Newton iterations: 0.03 takes 92 Jacobians instead of 713 on the paper's slider-crank
# (benchmarks/validation, accuracy 0.01, 2653 steps instead of 2631 at its rtol 1e-8: 14.2 ms
# instead of 16.3; 991 instead of 982 at the C rule's rtol 3e-5: 6.4 ms instead of 7.7) with the
# same error against the Exudyn reference (0.269 %); 0.1 is no faster. QUOT1, QUOT2: a
# step-size ratio in [QUOT1, QUOT2] keeps h (and the LU); RADAU5's (0.99, 2) for large systems
# and (1, 1.5) were within the noise of (1, 1.2) there.
NIT = 7  # at most NIT Newton iterations per step
THET = "0.03"
SAFE = "0.9"  # safety factor of the step-size choice
FACL = "5.0"  # h_new / h in [1 / FACL, 1 / FACR]
FACR = "0.125"
QUOT1 = "1.0"
QUOT2 = "1.2"


def constants() -> dict:
    """The constants for the template context."""
    return {
        "c": C,
        "A": A,
        "gamma": GAMMA,
        "alpha": ALPHA,
        "beta": BETA,
        "T": T,
        "TI": TI,
        "dd": DD,
        "nit": NIT,
        "thet": THET,
        "safe": SAFE,
        "facl": FACL,
        "facr": FACR,
        "quot1": QUOT1,
        "quot2": QUOT2,
    }
