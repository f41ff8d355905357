/*
 * Unit tests of the symgen C runtime (symgen/backends/c/runtime/), compiled on its own (extern
 * linkage) with a model written here by hand: tests/test_c_runtime.py builds and runs it.
 *
 *   LU and complex LU: solves of random systems (residual to round-off), a zero pivot reported;
 *   singular values: the ratio of a diagonal matrix;
 *   storage: symgen_bind uses SYMGEN_WORK_DOUBLES doubles;
 *   Radau IIA on the DAE of two unit masses on springs, x'' = -x - lam, y'' = -y + lam, held
 *   together by phi = y - x = 0 (index 3, solved with phi, phid, phidd as the emitted models are):
 *   from x(0) = 1 (y assembled from the guess 1.1), v = 0, the closed form x = y = cos(tau),
 *   lam = 0; every output to 1e-8 at rtol 1e-10, the closure to round-off;
 *   the checks: a guess that cannot be assembled fails with the runtime's message; bad arguments;
 *   (built with -DRUNTIME_TEST_MISMATCH and other compiled sizes) a start refused.
 * Prints one line per check and exits 0 if every check passed.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "symgen_runtime.h"

static int failures = 0;

static void check(int ok, const char *what, double value)
{
    printf("%s %s (%.3g)\n", ok ? "ok  " : "FAIL", what, value);
    if (!ok) failures++;
}

/* ------------------------------------------------------------------ the model */
/* q = [x, y], lam = [lam]; w = [x, y, vx, vy, ax, ay, lam] (3 n + m = 7 columns) */
static void m_phi(double t, const double *q, const double *v, const double *a, const double *lam, const double *p,
                  double *out)
{
    (void)t; (void)v; (void)a; (void)lam; (void)p;
    out[0] = q[1] - q[0];
}

static void m_phid(double t, const double *q, const double *v, const double *a, const double *lam, const double *p,
                   double *out)
{
    (void)t; (void)q; (void)a; (void)lam; (void)p;
    out[0] = v[1] - v[0];
}

static void m_phidd(double t, const double *q, const double *v, const double *a, const double *lam, const double *p,
                    double *out)
{
    (void)t; (void)q; (void)v; (void)lam; (void)p;
    out[0] = a[1] - a[0];
}

static void m_res(double t, const double *q, const double *v, const double *a, const double *lam, const double *p,
                  double *out)
{
    (void)t; (void)v; (void)p;
    out[0] = a[0] + q[0] - lam[0];
    out[1] = a[1] + q[1] + lam[0];
}

static void m_out(double t, const double *q, const double *v, const double *a, const double *lam, const double *p,
                  double *out)
{
    (void)t; (void)a; (void)p;
    out[0] = q[0];
    out[1] = q[1];
    out[2] = v[0];
    out[3] = lam[0];
}

static void m_closure(double t, const double *q, const double *v, const double *a, const double *lam, const double *p,
                      double *out)
{
    m_phi(t, q, v, a, lam, p, out);
}

static void m_phi_jac(double t, const double *q, const double *v, const double *a, const double *lam, const double *p,
                      double *jac)
{
    (void)t; (void)q; (void)v; (void)a; (void)lam; (void)p;
    memset(jac, 0, 7 * sizeof(double));
    jac[0] = -1.0;
    jac[1] = 1.0;
}

static void m_phid_jac(double t, const double *q, const double *v, const double *a, const double *lam,
                       const double *p, double *jac)
{
    (void)t; (void)q; (void)v; (void)a; (void)lam; (void)p;
    memset(jac, 0, 7 * sizeof(double));
    jac[2] = -1.0;
    jac[3] = 1.0;
}

static void m_phidd_jac(double t, const double *q, const double *v, const double *a, const double *lam,
                        const double *p, double *jac)
{
    (void)t; (void)q; (void)v; (void)a; (void)lam; (void)p;
    memset(jac, 0, 7 * sizeof(double));
    jac[4] = -1.0;
    jac[5] = 1.0;
}

static void m_res_jac(double t, const double *q, const double *v, const double *a, const double *lam, const double *p,
                      double *jac)
{
    (void)t; (void)q; (void)v; (void)a; (void)lam; (void)p;
    memset(jac, 0, 14 * sizeof(double));
    jac[0] = 1.0;  jac[4] = 1.0;  jac[6] = -1.0;           /* row x: dx, dax, dlam */
    jac[7 + 1] = 1.0;  jac[7 + 5] = 1.0;  jac[7 + 6] = 1.0; /* row y: dy, day, dlam */
}

static int m_valid(int k, double value)
{
    return k == 0 && fabs(value) <= 1e300;
}

static const int independent[1] = { 0 }, dependent[1] = { 1 };
/* y = [x, vx, y, vy, ax, ay, lam]: nx = 2, a0 = nx + 2 nd = 4 */
static const int ypos_q[2] = { 0, 2 }, ypos_v[2] = { 1, 3 }, ycol[7] = { 0, 2, 1, 3, 4, 5, 6 };
static const int accel[2] = { 0, 1 }, sing_rows[1] = { 0 }, sing_cols[1] = { 1 };
static const int unused[1] = { -1 };
static double q_guess[2] = { 1.0, 1.1 };
static const double v_guess[2] = { 0.0, 0.0 };
static const char *const coordinate_names[2] = { "x", "y" };
static const char *const parameter_names[1] = { "k" };
static const char *const parameter_range[1] = { "finite" };
static const double parameter_defaults[1] = { 1.0 };
static const symgen_amplitude_check no_checks[1] = { { 0, 0, 0, 0, 0, 0, NULL, NULL, "", "", 0, -1, 0, NULL } };

static symgen_model model = {
    2, 1, 1, 1,  1, 1, 0, 2, 1,
    independent, dependent, dependent, ypos_q, ypos_v, ycol, unused, accel, sing_rows, sing_cols,
    q_guess, v_guess, 0, unused, unused, 0,   /* no angle driver (n_angle, angle_coords, angle_rows), quasi_static */
    1e-6, 1e-8, 1.0, "in (0, 1), or <= 0 for the model's",
    coordinate_names, parameter_names, parameter_range, parameter_defaults, m_valid,
    0, no_checks, unused,
    m_phi, m_phid, m_phidd, m_res, m_out, m_closure, m_phi_jac, m_phid_jac, m_phidd_jac, m_res_jac,
    { 1e-13, 1e-10, 60, 1e-4, 0.5, 1e-7, 0.05, 1e-6, 1e-12, 1e-8, 1e-4, 50, 1e-13, 8, 1e-4, 0.7, 0.1, 1e-9, 1e-6, 1e-13, 1e-8, 30, 4 },
    { { 0.15505102572168219018, 0.64494897427831780982, 1.0 },
      { { 0.0944387624889752414875, -0.141255295020954208428, -0.0300291941051474244919 },
        { 0.250213122965333311377, 0.204129352293799931996, 0.382942112757261937795 },
        { 1.0, 1.0, 0.0 } },
      { { 4.17871859155190472735, 0.327682820761062387083, 0.52337644549944954804 },
        { -4.17871859155190472735, -0.327682820761062387083, 0.47662355450055045196 },
        { -0.502872634945786875951, 2.57192694985560542919, -0.596039204828224924969 } },
      { -10.0488093998274155625, 1.38214273316074889579, -0.333333333333333333333 },
      3.63783425274449573221, 2.6810828736277521339, 3.05043019924741056943,
      7, 0.001, 0.9, 5.0, 0.125, 1.0, 1.2 },
    4,   /* nout */
    0, NULL, 0, NULL,   /* no continuum start (n_free, free_params, n_start_forces, start_forces) */
    0, NULL,   /* no quasi-static amplitude (nh, quasi) */
    0, 0, NULL, NULL   /* no axial amplitude following a held bending (nfollow, nmoving, follow, moving) */
};

/* ------------------------------------------------------------------ checks */
static double uniform(unsigned long *state)
{
    *state = *state * 6364136223846793005UL + 1442695040888963407UL;
    return (double)(*state >> 11) / 9007199254740992.0 * 2.0 - 1.0;
}

static void test_lu(void)
{
    enum { N = 12 };
    double A[N * N], LU[N * N], b[N], x[N], ai[N * N], ar[N * N], br[N], bi[N], xr[N], xi[N];
    int piv[N], i, j, n, singular;
    unsigned long seed = 7;
    double worst = 0.0, worst_c = 0.0;
    for (n = 1; n <= N; ++n) {
        for (i = 0; i < n * n; ++i) { A[i] = uniform(&seed); ai[i] = uniform(&seed); }
        for (i = 0; i < n; ++i) { b[i] = uniform(&seed); bi[i] = uniform(&seed); }
        memcpy(LU, A, sizeof(double) * n * n);
        memcpy(x, b, sizeof(double) * n);
        if (symgen_lu(LU, n, piv) == 0) {
            symgen_lu_solve(LU, n, piv, x);
            for (i = 0; i < n; ++i) {
                double r = -b[i];
                for (j = 0; j < n; ++j) r += A[i * n + j] * x[j];
                worst = fmax(worst, fabs(r));
            }
        } else {
            worst = HUGE_VAL;
        }
        memcpy(ar, A, sizeof(double) * n * n);
        memcpy(LU, ai, sizeof(double) * n * n);
        memcpy(xr, b, sizeof(double) * n);
        memcpy(xi, bi, sizeof(double) * n);
        if (symgen_clu(ar, LU, n, piv) == 0) {
            symgen_clu_solve(ar, LU, n, piv, xr, xi);
            for (i = 0; i < n; ++i) {      /* (A + i Ai)(xr + i xi) - (b + i bi) */
                double rr = -b[i], ri = -bi[i];
                for (j = 0; j < n; ++j) {
                    rr += A[i * n + j] * xr[j] - ai[i * n + j] * xi[j];
                    ri += A[i * n + j] * xi[j] + ai[i * n + j] * xr[j];
                }
                worst_c = fmax(worst_c, hypot(rr, ri));
            }
        } else {
            worst_c = HUGE_VAL;
        }
        (void)br;
    }
    check(worst < 1e-12, "LU solves random systems of size 1..12 (max residual)", worst);
    check(worst_c < 1e-12, "complex LU solves random systems of size 1..12 (max residual)", worst_c);
    memset(LU, 0, sizeof(LU));
    LU[0] = 1.0;
    LU[1 * 3 + 1] = 2.0;                 /* third pivot zero */
    singular = symgen_lu(LU, 3, piv);
    check(singular == 3, "LU reports the zero pivot (k + 1)", singular);
}

/* sparse LU: arrow-shaped saddle-point matrices (a block diagonal, a dense last rows and columns
   block, zero-diagonal constraint rows: the pattern of a chain's Newton matrix) of sizes 1..40,
   solved to round-off against their own residual; refactored with the kept pivots after the
   values change, real and complex; the fill-in stays small where dense LU would fill in all;
   a kept pivot that no longer holds and a singular matrix are reported (k + 1) */
#define SPN 40
static int sp_idx[SPN * SPN], sp_mark[SPN * SPN], sp_prow[SPN], sp_pcol[SPN], sp_rc[SPN], sp_cc[SPN];
static int sp_lptr[SPN + 1], sp_uptr[SPN];
static double sp_A[SPN * SPN], sp_LU[SPN * SPN], sp_Ai[SPN * SPN], sp_LUi[SPN * SPN];
static double sp_v[SPN * SPN + SPN], sp_vi[SPN * SPN + SPN];

static void arrow(double *A, int n, unsigned long *seed)
{
    int i, j, nc = n >= 4 ? 2 : 0;       /* the last nc rows and columns: constraints */
    memset(A, 0, sizeof(double) * n * n);
    for (i = 0; i < n - nc; ++i) {
        for (j = 0; j < n - nc; ++j) {
            if (i / 3 == j / 3) A[i * n + j] = uniform(seed) + (i == j ? 4.0 : 0.0);   /* blocks of 3 */
        }
    }
    for (i = 0; i < n - nc; ++i) {
        for (j = n - nc; j < n; ++j) {
            if (i % 5 == 0 || i < 2) { A[i * n + j] = uniform(seed); A[j * n + i] = A[i * n + j]; }
        }
    }
}

static double residual(const double *A, const double *Ai, int n, const double *b, const double *bi, const double *x,
                       const double *xi)
{
    double worst = 0.0;
    int i, j;
    for (i = 0; i < n; ++i) {
        double rr = -b[i], ri = Ai ? -bi[i] : 0.0;
        for (j = 0; j < n; ++j) {
            rr += A[i * n + j] * x[j] - (Ai ? Ai[i * n + j] * xi[j] : 0.0);
            if (Ai) ri += A[i * n + j] * xi[j] + Ai[i * n + j] * x[j];
        }
        worst = fmax(worst, hypot(rr, ri));
    }
    return worst;
}

static void test_sparse_lu(void)
{
    symgen_splu f;
    double b[SPN], bi[SPN], rhs[SPN], rhsi[SPN], x[SPN], xi[SPN];
    double worst = 0.0, worst_re = 0.0, worst_c = 0.0;
    unsigned long seed = 11;
    int i, n, rc, fill_ok = 1;
    f.prow = sp_prow; f.pcol = sp_pcol; f.rcount = sp_rc; f.ccount = sp_cc;
    f.lptr = sp_lptr; f.uptr = sp_uptr; f.idx = sp_idx; f.mark = sp_mark;
    for (n = 1; n <= SPN; ++n) {
        int nnz_a = 0;
        f.n = n;
        arrow(sp_A, n, &seed);
        for (i = 0; i < n * n; ++i) nnz_a += sp_A[i] != 0.0;
        for (i = 0; i < n; ++i) { b[i] = uniform(&seed); bi[i] = uniform(&seed); }
        memcpy(sp_LU, sp_A, sizeof(double) * n * n);
        rc = symgen_splu_analyze(&f, sp_LU, 0.1);
        memcpy(rhs, b, sizeof(double) * n);
        if (rc == 0) { symgen_splu_pack(&f, sp_LU, sp_v); symgen_splu_solve(&f, sp_v, rhs, x); }
        worst = fmax(worst, rc == 0 ? residual(sp_A, NULL, n, b, NULL, x, NULL) : HUGE_VAL);
        if (n == SPN && !(f.nnz < 2 * nnz_a && f.flops < n * n * n / 20)) fill_ok = 0;
        /* new values on the same pattern: the kept pivots */
        for (i = 0; i < n * n; ++i) {
            if (sp_A[i] != 0.0) sp_A[i] *= 1.0 + 0.3 * uniform(&seed);
        }
        symgen_splu_gather(&f, sp_A, 1.0, sp_LU);
        rc = symgen_splu_refactor(&f, sp_LU, 0.01);
        memcpy(rhs, b, sizeof(double) * n);
        if (rc == 0) { symgen_splu_pack(&f, sp_LU, sp_v); symgen_splu_solve(&f, sp_v, rhs, x); }
        worst_re = fmax(worst_re, rc == 0 ? residual(sp_A, NULL, n, b, NULL, x, NULL) : HUGE_VAL);
        /* complex: A + i D (D diagonal on the first rows, as the Radau matrix E2) */
        memset(sp_Ai, 0, sizeof(double) * n * n);
        for (i = 0; i < n - (n >= 4 ? 2 : 0); ++i) sp_Ai[i * n + i] = 2.0 * uniform(&seed);
        symgen_splu_gather(&f, sp_A, 1.0, sp_LU);
        symgen_splu_gather(&f, sp_Ai, 1.0, sp_LUi);
        rc = symgen_splu_crefactor(&f, sp_LU, sp_LUi, 0.01);
        memcpy(rhs, b, sizeof(double) * n);
        memcpy(rhsi, bi, sizeof(double) * n);
        if (rc == 0) {
            symgen_splu_pack(&f, sp_LU, sp_v);
            symgen_splu_pack(&f, sp_LUi, sp_vi);
            symgen_splu_csolve(&f, sp_v, sp_vi, rhs, rhsi, x, xi);
        }
        worst_c = fmax(worst_c, rc == 0 ? residual(sp_A, sp_Ai, n, b, bi, x, xi) : HUGE_VAL);
    }
    check(worst < 1e-12, "sparse LU solves arrow saddle-point systems of size 1..40 (max residual)", worst);
    check(worst_re < 1e-12, "sparse LU with the kept pivots after new values (max residual)", worst_re);
    check(worst_c < 1e-12, "complex sparse LU with the kept pivots (max residual)", worst_c);
    check(fill_ok, "sparse LU of size 40: fill-in under the matrix's own entries, flops under n^3/20", (double)f.flops);
    /* the analysed pattern (A's nonzeros and the fill-in): a matrix with a new nonzero at a
       fill-in position is covered and factored exactly by the kept pivots (the solver keeps them
       across Jacobians); one off the pattern is not covered (the solver chooses them again) */
    {
        int fill = -1, off = -1, covered_same, covered_fill, covered_off;
        n = SPN;
        f.n = n;
        arrow(sp_A, n, &seed);
        memcpy(sp_LU, sp_A, sizeof(double) * n * n);
        rc = symgen_splu_analyze(&f, sp_LU, 0.1);
        covered_same = symgen_splu_covers(&f, sp_A, n);
        for (i = 0; i < n * n; ++i) {
            if (fill < 0 && sp_A[i] == 0.0 && sp_mark[i]) fill = i;
            if (off < 0 && !sp_mark[i]) off = i;
        }
        sp_A[fill] = 0.1 * uniform(&seed);
        covered_fill = symgen_splu_covers(&f, sp_A, n);
        symgen_splu_gather(&f, sp_A, 1.0, sp_LU);
        rc = rc || symgen_splu_refactor(&f, sp_LU, 0.01);
        memcpy(rhs, b, sizeof(double) * n);
        if (rc == 0) { symgen_splu_pack(&f, sp_LU, sp_v); symgen_splu_solve(&f, sp_v, rhs, x); }
        worst = rc == 0 ? residual(sp_A, NULL, n, b, NULL, x, NULL) : HUGE_VAL;
        sp_A[off] = 1.0;
        covered_off = symgen_splu_covers(&f, sp_A, 0);
        sp_A[off] = 0.0;
        check(fill >= 0 && off >= 0 && covered_same && covered_fill && !covered_off,
              "sparse LU: the analysed pattern covers its matrix and a fill-in entry, not an entry off it", 0.0);
        check(worst < 1e-12, "sparse LU with the kept pivots after a new entry at a fill-in position (max residual)",
              worst);
        /* the first nd diagonal entries are required on the pattern, zero or not */
        memset(sp_LU, 0, sizeof(double) * 9);
        sp_LU[0] = 1.0; sp_LU[5] = 2.0; sp_LU[7] = 3.0;   /* (1, 1) and (2, 2) off the pattern */
        f.n = 3;
        rc = symgen_splu_analyze(&f, sp_LU, 0.1);
        memset(sp_A, 0, sizeof(double) * 9);
        check(rc == 0 && symgen_splu_covers(&f, sp_A, 1) && !symgen_splu_covers(&f, sp_A, 2),
              "sparse LU: a required diagonal entry off the pattern is not covered", 0.0);
    }
    /* a kept pivot gone to zero: reported, k + 1 */
    n = 3;
    f.n = n;
    memset(sp_A, 0, sizeof(double) * 9);
    sp_A[0] = 2.0; sp_A[4] = 3.0; sp_A[8] = 5.0; sp_A[1] = 1.0; sp_A[3] = 1.0;
    memcpy(sp_LU, sp_A, sizeof(sp_A[0]) * 9);
    rc = symgen_splu_analyze(&f, sp_LU, 0.1);
    for (i = 0; i < 9; ++i) sp_A[i] = sp_A[i] == 0.0 ? 0.0 : 1e-20;
    sp_A[sp_prow[0] * 3 + sp_pcol[0]] = 0.0;
    symgen_splu_gather(&f, sp_A, 1.0, sp_LU);
    check(rc == 0 && symgen_splu_refactor(&f, sp_LU, 0.01) == 1, "sparse LU: a kept pivot gone to zero is reported", 0.0);
    memset(sp_LU, 0, sizeof(sp_A[0]) * 9);
    sp_LU[0] = 1.0; sp_LU[4] = 2.0;      /* the third row and column empty */
    rc = symgen_splu_analyze(&f, sp_LU, 0.1);
    check(rc == 3, "sparse LU reports a singular matrix (k + 1)", rc);
}

static void test_singular_ratio(void)
{
    double a[9] = { 3.0, 0.0, 0.0, 0.0, -0.5, 0.0, 0.0, 0.0, 1.5 };
    double r = symgen_singular_ratio(a, 3);
    check(fabs(r - 0.5 / 3.0) < 1e-15, "singular value ratio of diag(3, -0.5, 1.5)", r);
    check(symgen_singular_ratio(a, 0) == 1.0, "singular value ratio of an empty matrix is 1", 1.0);
}

static symgen_solver solver;
static double work[SYMGEN_WORK_DOUBLES(2, 1, 1, 1, 0, 1, 4)];
static int iwork[SYMGEN_WORK_INTS(2, 1, 1, 1, 0)];
static double p[1], y[SYMGEN_NY_(2, 1, 1, 1)];

static void test_radau(void)
{
    double out[4], q[2], v[2], a[2], worst = 0.0, clo = 0.0, lam = 0.0;
    long used = symgen_bind(&solver, &model, p, y, work, iwork);
    int k, rc;
    check(used == (long)(sizeof(work) / sizeof(double)), "symgen_bind uses SYMGEN_WORK_DOUBLES doubles", (double)used);
    rc = symgen_solver_init(&solver, NULL, 0.0, 1e-10, 1e-12);
    check(rc == 0, "start: assembly from the guess y = 1.1, consistent state", rc);
    check(fabs(y[2] - 1.0) < 1e-13, "start: y assembled onto x = 1", y[2] - 1.0);
    for (k = 1; k <= 20 && rc == 0; ++k) {
        const double t = 0.5 * k;
        rc = symgen_solver_advance(&solver, t);
        symgen_model_outputs(&model, solver.t, y, p, q, v, a, out);
        worst = fmax(worst, fmax(fabs(out[0] - cos(t)), fabs(out[1] - cos(t))));
        worst = fmax(worst, fabs(out[2] + sin(t)));
        clo = fmax(clo, fabs(out[1] - out[0]));
        lam = fmax(lam, fabs(out[3]));
        if (solver.t != t) rc = -1;
    }
    check(rc == 0, "Radau IIA reaches tau = 10, landing on every output time", rc);
    check(worst < 1e-8, "x = y = cos(tau), x' = -sin(tau) (max error)", worst);
    check(clo < 1e-14 && solver.closure_max < 1e-14, "closure y - x at round-off", clo);
    check(lam < 1e-10, "multiplier lam = 0", lam);
    check(solver.n_accepted > 0 && solver.n_steps >= solver.n_accepted, "step counters", (double)solver.n_accepted);
    check(solver.sparse && solver.analyzed == 1, "the Newton matrices factored sparse", solver.sparse);
    {   /* the dense path (block elimination) gives the same run to round-off */
        double ys[SYMGEN_NY_(2, 1, 1, 1)], differ = 0.0;
        long steps = solver.n_steps;
        memcpy(ys, y, sizeof(ys));
        rc = symgen_solver_init(&solver, NULL, 0.0, 1e-10, 1e-12);
        solver.dense_newton = 1;
        for (k = 1; k <= 20 && rc == 0; ++k) rc = symgen_solver_advance(&solver, 0.5 * k);
        for (k = 0; k < SYMGEN_NY_(2, 1, 1, 1); ++k) differ = fmax(differ, fabs(y[k] - ys[k]));
        check(rc == 0 && !solver.sparse && differ < 1e-10, "the dense Newton path: the same state at tau = 10 (rtol 1e-10)", differ);
        check(labs(solver.n_steps - steps) <= 2, "the dense Newton path: the same steps (within 2)",
              (double)(solver.n_steps - steps));
    }
}

/* dense output: the same run with rows every 0.01 and every 0.5 takes the same steps (the error
   control's), and every row, between steps too, is the closed form cos(tau) */
static void test_dense(void)
{
    enum { STRIDE = 1 + 4 + 2 * 2 + 1, FINE = 1001, COARSE = 21 };
    static double fine[FINE * STRIDE], coarse[COARSE * STRIDE];
    double worst = 0.0, differ = 0.0, clo = 0.0;
    long done = 0, steps_fine, steps_coarse, i;
    int rc, paused = 0;
    symgen_bind(&solver, &model, p, y, work, iwork);
    rc = symgen_solver_init(&solver, NULL, 0.0, 1e-10, 1e-12);
    while (rc == 0 && done < FINE) {       /* in pieces of at most 7 steps: a pause is resumed */
        rc = symgen_solver_rows(&solver, 0.0, 0.01, FINE, &done, 0, 7, fine + done * STRIDE);
        if (rc == SYMGEN_SOLVER_PAUSED) { paused++; rc = 0; }
    }
    steps_fine = solver.n_steps;
    check(rc == 0 && done == FINE && paused > 1, "dense rows every 0.01 to tau = 10, paused and resumed", paused);
    for (i = 0; i < FINE; ++i) {
        const double *r = fine + i * STRIDE, t = 0.01 * (double)i;
        worst = fmax(worst, fmax(fabs(r[1] - cos(t)), fabs(r[2] - cos(t))));
        worst = fmax(worst, fmax(fabs(r[3] + sin(t)), fabs(r[5] - cos(t))));   /* v_x; q_x again */
        clo = fmax(clo, fabs(r[2] - r[1]));
        if (r[0] != t) worst = HUGE_VAL;
    }
    check(worst < 1e-8, "dense rows: x = y = cos(tau), x' = -sin(tau) between steps (max error)", worst);
    check(clo < 1e-14, "dense rows: closure y - x at round-off (polished)", clo);
    check(steps_fine < FINE / 2, "dense rows: fewer steps than rows (landing on each takes 1000)", (double)steps_fine);
    done = 0;
    rc = symgen_solver_init(&solver, NULL, 0.0, 1e-10, 1e-12);
    if (rc == 0) rc = symgen_solver_rows(&solver, 0.0, 0.5, COARSE, &done, 0, 0, coarse);
    steps_coarse = solver.n_steps;
    for (i = 0; i < COARSE; ++i) {
        const double *a = coarse + i * STRIDE, *b = fine + 50 * i * STRIDE;
        int k;
        for (k = 0; k < STRIDE; ++k) differ = fmax(differ, fabs(a[k] - b[k]));
    }
    check(rc == 0 && steps_coarse == steps_fine, "dense rows every 0.5: the same steps as every 0.01",
          (double)(steps_coarse - steps_fine));
    check(differ < 1e-12, "dense rows every 0.5 equal those every 0.01 at the same times", differ);
    rc = symgen_solver_dense(&solver, 1.0, 10.0, solver.yd);
    check(rc == SYMGEN_SOLVER_BAD_ARGUMENT && strstr(solver.message, "t_out = 1 is not valid"), solver.message, rc);
}

static void test_checks(void)
{
    int rc;
    symgen_bind(&solver, &model, p, y, work, iwork);
    rc = symgen_solver_init(&solver, NULL, 0.0, 2.0, 0.0);
    check(rc == SYMGEN_SOLVER_BAD_ARGUMENT && strstr(solver.message, "rtol = 2 is not valid: it must be in (0, 1)"),
          solver.message, rc);
    rc = symgen_solver_init(&solver, NULL, NAN, 0.0, 0.0);
    check(rc == SYMGEN_SOLVER_BAD_ARGUMENT && strstr(solver.message, "t0 = nan is not valid"), solver.message, rc);
    model.phi_jac = m_phid_jac;          /* a closure Jacobian without position columns: no assembly */
    q_guess[1] = 1.5;
    rc = symgen_solver_init(&solver, NULL, 0.0, 0.0, 0.0);
    check(rc == SYMGEN_SOLVER_FAILED && strstr(solver.message, "at tau = 0: the mechanism cannot be assembled"),
          solver.message, rc);
    check(symgen_solver_advance(&solver, 1.0) == SYMGEN_SOLVER_FAILED, "a failed run stays failed", 0.0);
    model.phi_jac = m_phi_jac;
    q_guess[1] = 1.1;
}

#ifdef RUNTIME_TEST_MISMATCH
/* built with the solver's sizes fixed to others than the model's (-D'SYMGEN_NQ(s)=3'): init refuses */
int main(void)
{
    int rc;
    symgen_bind(&solver, &model, p, y, work, iwork);
    rc = symgen_solver_init(&solver, NULL, 0.0, 0.0, 0.0);
    check(rc == SYMGEN_SOLVER_FAILED && strstr(solver.message, "compiled for other sizes than its model's"),
          solver.message, rc);
    check(symgen_solver_advance(&solver, 1.0) == SYMGEN_SOLVER_FAILED, "and advance refuses", 0.0);
    printf("%d failed\n", failures);
    return failures != 0;
}
#else
int main(void)
{
    test_lu();
    test_sparse_lu();
    test_singular_ratio();
    test_radau();
    test_dense();
    test_checks();
    printf("%d failed\n", failures);
    return failures != 0;
}
#endif
