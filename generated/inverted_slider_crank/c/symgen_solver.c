/*
 * symgen C runtime: the DAE solver of an emitted model (plain C99 + libm; see symgen_runtime.h).
 *
 * Index-1 DAE of the mechanism, as in the Python path (symgen/numerics/mechanism.py, simulate.py):
 * the rigid coordinates are split into independent ones and dependent ones q_D (one per closure
 * row; the model's partition was chosen by symgen where the closure Jacobian is best
 * conditioned); deformation amplitudes are independent. With x = [q_I, v_I] differential and
 * z = [q_D, v_D, a, lam] algebraic:
 *     x' = [v_I; a_I],    0 = [phi; phid; res; phidd](t, q, v, a, lam)
 * Quasi-static amplitudes h (model->quasi) are algebraic, as in the Python path
 * (symgen/numerics/index1.py): v_h = a_h = 0 in every equation, q_h in the slot of a_h in z.
 * y = [x; z] is integrated by the 3-stage Radau IIA method (order 5, L-stable, stiffly accurate:
 * every step ends on the algebraic equations) with simplified Newton iterations on the stage
 * equations using the analytic Jacobians of the model, and Hairer & Wanner's (RADAU5) error
 * estimate and step-size control. The solver lands exactly on every output time and polishes z
 * there by Newton on the algebraic equations (position closure to round-off).
 *
 * The start (assembly, quasi-static deformation, consistent velocities, accelerations and
 * multipliers) and the run checks (singular position, range of the bar models, divergence of a
 * quasi-static start) are the Python runners' (symgen.numerics.mechanism, checks), with the
 * limits of the model's policy (symgen/policy.py).
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "symgen_runtime.h"

/* The model's sizes as the solver reads them: from the solver (symgen_bind), unless defined
   before this file is included. An emitted solver defines them as its model's numbers (they
   equal the descriptor's): the loops then have fixed bounds, as fast as a solver written for
   the model. */
#ifndef SYMGEN_NQ
#define SYMGEN_NQ(s) ((s)->nq)
#endif
#ifndef SYMGEN_NL
#define SYMGEN_NL(s) ((s)->nl)
#endif
#ifndef SYMGEN_NP
#define SYMGEN_NP(s) ((s)->np)
#endif
#ifndef SYMGEN_NI
#define SYMGEN_NI(s) ((s)->ni)
#endif
#ifndef SYMGEN_ND
#define SYMGEN_ND(s) ((s)->nd)
#endif
#ifndef SYMGEN_NE
#define SYMGEN_NE(s) ((s)->ne)
#endif
#ifndef SYMGEN_NR
#define SYMGEN_NR(s) ((s)->nr)
#endif
#ifndef SYMGEN_NS
#define SYMGEN_NS(s) ((s)->ns)
#endif
#ifndef SYMGEN_NCLO
#define SYMGEN_NCLO(s) ((s)->nclo)
#endif
#ifndef SYMGEN_NX
#define SYMGEN_NX(s) ((s)->nx)
#endif
#ifndef SYMGEN_NZ
#define SYMGEN_NZ(s) ((s)->nz)
#endif
#ifndef SYMGEN_NY
#define SYMGEN_NY(s) ((s)->ny)
#endif
#ifndef SYMGEN_NALG
#define SYMGEN_NALG(s) ((s)->nalg)
#endif
#ifndef SYMGEN_NW
#define SYMGEN_NW(s) ((s)->nw)
#endif
#ifndef SYMGEN_A0
#define SYMGEN_A0(s) ((s)->a0)
#endif

/* ------------------------------------------------------------------ storage */
static double *symgen_take_(double **next, long count)
{
    double *p = *next;
    *next += count;
    return p;
}

static int *symgen_itake_(int **next, long count)
{
    int *p = *next;
    *next += count;
    return p;
}

SYMGEN_API long symgen_bind(symgen_solver *s, const symgen_model *model, double *p, double *y, double *work,
                            int *iwork)
{
    double *d = work;
    int *k = iwork;
    long ny, nz, nx, nalg, nw, n2, n, m, ni;
    s->model = model;
    s->nq = model->n;
    s->nl = model->m;
    s->np = model->np;
    s->ni = model->ni;
    s->nd = model->nd;
    s->ne = model->ne;
    s->nr = model->nr;
    s->ns = model->ns;
    s->nclo = model->nclosure;
    s->nx = SYMGEN_NX_(model->ni);
    s->nz = SYMGEN_NZ_(model->n, model->m, model->nd);
    s->ny = s->nx + s->nz;
    s->nalg = SYMGEN_NALG_(model->n, model->m);
    s->nw = SYMGEN_NW_(model->n, model->m);
    s->a0 = s->nx + 2 * model->nd;
    s->p = p;
    s->y = y;
    s->work = work;
    s->iwork = iwork;
    n = s->nq, m = s->nl, ni = s->ni, nx = s->nx, nz = s->nz, ny = s->ny, nalg = s->nalg, nw = s->nw, n2 = 2 * s->ne;
    s->yd = symgen_take_(&d, ny);
    s->y0 = symgen_take_(&d, ny);
    s->f0 = symgen_take_(&d, ny);
    s->scal = symgen_take_(&d, ny);
    s->ymax = symgen_take_(&d, ny);
    s->tmp = symgen_take_(&d, ny);
    s->tmp2 = symgen_take_(&d, ny);
    s->tmp3 = symgen_take_(&d, ny);
    s->z = symgen_take_(&d, 3 * ny);
    s->w = symgen_take_(&d, 3 * ny);
    s->f = symgen_take_(&d, 3 * ny);
    s->dw = symgen_take_(&d, 3 * ny);
    s->cont = symgen_take_(&d, 3 * ny);
    s->jac = symgen_take_(&d, ny * ny);
    s->gzz = symgen_take_(&d, nz * nz);
    s->kzx = symgen_take_(&d, nz * nx);
    s->uz = symgen_take_(&d, nz);
    s->uzi = symgen_take_(&d, nz);
    s->jred = symgen_take_(&d, nx * nx);
    s->e1 = symgen_take_(&d, ni * ni);
    s->e2r = symgen_take_(&d, ni * ni);
    s->e2i = symgen_take_(&d, ni * ni);
    s->galg = symgen_take_(&d, nalg * nw);
    s->sq = symgen_take_(&d, nalg * nalg);
    s->sv = symgen_take_(&d, nalg);
    s->sr = symgen_take_(&d, nalg);
    s->qs_u = symgen_take_(&d, nalg);
    s->q = symgen_take_(&d, n);
    s->v = symgen_take_(&d, n);
    s->qs = symgen_take_(&d, n);
    s->vs = symgen_take_(&d, n);
    s->qe = symgen_take_(&d, n);
    s->qf = symgen_take_(&d, n);
    s->q_last = symgen_take_(&d, n);
    s->start_q = symgen_take_(&d, n);
    s->start_v = symgen_take_(&d, n);
    s->start_a = symgen_take_(&d, n);
    s->qs_a = symgen_take_(&d, n);
    s->qs_ah = symgen_take_(&d, n);     /* the accelerations a quasi-static re-solve holds */
    s->dv_a = symgen_take_(&d, n);
    s->as_trial = symgen_take_(&d, n);
    s->zeros = symgen_take_(&d, n + m);      /* stands for inputs a model function does not read */
    s->start_lam = symgen_take_(&d, m);
    s->qs_lam = symgen_take_(&d, m);
    s->dv_lam = symgen_take_(&d, m);
    s->as_r = symgen_take_(&d, m);
    s->as_rt = symgen_take_(&d, m);
    s->as_dq = symgen_take_(&d, m);
    s->vel_r = symgen_take_(&d, m);
    s->drv_r = symgen_take_(&d, m);
    s->clo = symgen_take_(&d, m);
    s->dva = symgen_take_(&d, n2 * n2);
    s->dvh = symgen_take_(&d, n2 * n2);
    s->dvwr = symgen_take_(&d, n2);
    s->dvwi = symgen_take_(&d, n2);
    s->dvx = symgen_take_(&d, n2);
    s->dvu = symgen_take_(&d, n2);
    s->ct_p = symgen_take_(&d, model->np);
    s->ct_a = symgen_take_(&d, n);
    s->ct_lam = symgen_take_(&d, m);
    s->start_out = symgen_take_(&d, model->nout);
    s->ct_out = symgen_take_(&d, model->nout);
    s->ya = symgen_take_(&d, n);
    s->range_rec = symgen_take_(&d, SYMGEN_RANGE_FIELDS * n);
    s->pivz = symgen_itake_(&k, nz);
    s->zrow = symgen_itake_(&k, nz + 1);
    s->zmid = symgen_itake_(&k, nz);
    s->zcol = symgen_itake_(&k, nz * nz);
    s->piv1 = symgen_itake_(&k, ni);
    s->piv2 = symgen_itake_(&k, ni);
    s->sp = symgen_itake_(&k, nalg);
    s->qs_col = symgen_itake_(&k, nalg);
    s->dvpiv = symgen_itake_(&k, n2);
    s->dvidx = symgen_itake_(&k, s->ne);
    s->spa = symgen_take_(&d, ny * ny);
    s->spr = symgen_take_(&d, ny * ny);
    s->spi = symgen_take_(&d, ny * ny);
    s->spx = symgen_take_(&d, ny);
    s->spxi = symgen_take_(&d, ny);
    s->spv = symgen_take_(&d, ny * ny + ny);
    s->spvr = symgen_take_(&d, ny * ny + ny);
    s->spvi = symgen_take_(&d, ny * ny + ny);
    s->lu.n = (int)ny;
    s->lu.prow = symgen_itake_(&k, ny);
    s->lu.pcol = symgen_itake_(&k, ny);
    s->lu.rcount = symgen_itake_(&k, ny);
    s->lu.ccount = symgen_itake_(&k, ny);
    s->lu.lptr = symgen_itake_(&k, ny + 1);
    s->lu.uptr = symgen_itake_(&k, ny);
    s->lu.idx = symgen_itake_(&k, ny * ny);
    s->lu.mark = symgen_itake_(&k, ny * ny);
    /* the sizes the solver's loops use (constants of an emitted solver) are the descriptor's */
    s->sizes_differ = !(SYMGEN_NQ(s) == model->n && SYMGEN_NL(s) == model->m && SYMGEN_NP(s) == model->np
                        && SYMGEN_NI(s) == model->ni && SYMGEN_ND(s) == model->nd && SYMGEN_NE(s) == model->ne
                        && SYMGEN_NR(s) == model->nr && SYMGEN_NS(s) == model->ns && SYMGEN_NCLO(s) == model->nclosure
                        && SYMGEN_NX(s) == s->nx && SYMGEN_NZ(s) == s->nz && SYMGEN_NY(s) == s->ny
                        && SYMGEN_NALG(s) == s->nalg && SYMGEN_NW(s) == s->nw && SYMGEN_A0(s) == s->a0);
    return (long)(d - work) + 1;
}

/* ------------------------------------------------------------------ the model in y */
/* q, v from y (lam is a slice of y; a is, but for the quasi-static amplitudes: symgen_accel_) */
static void symgen_unpack_(const symgen_solver *s, const double *y, double *q, double *v)
{
    int i;
    for (i = 0; i < SYMGEN_NQ(s); ++i) {
        const int iv = s->model->ypos_v[i];
        q[i] = y[s->model->ypos_q[i]];
        v[i] = iv >= 0 ? y[iv] : 0.0;      /* a quasi-static amplitude: no rate */
    }
}

/* the accelerations a of y: its slice, or (quasi-static amplitudes, whose slots hold q_h) a copy
   in s->ya with a_h = 0 */
static const double *symgen_accel_(symgen_solver *s, const double *y)
{
    const symgen_model *M = s->model;
    int k;
    if (M->nh == 0) return y + SYMGEN_A0(s);
    memcpy(s->ya, y + SYMGEN_A0(s), sizeof(double) * SYMGEN_NQ(s));
    for (k = 0; k < M->nh; ++k) s->ya[M->quasi[k]] = 0.0;
    return s->ya;
}

/* y of a state (q, v, a, lam): a quasi-static amplitude's q in the slot of its a (its v and a
   are not in y) */
static void symgen_pack_(const symgen_solver *s, const double *q, const double *v, const double *a, const double *lam,
                         double *y)
{
    int k;
    for (k = 0; k < SYMGEN_NQ(s); ++k) y[SYMGEN_A0(s) + k] = a[k];
    for (k = 0; k < SYMGEN_NL(s); ++k) y[SYMGEN_A0(s) + SYMGEN_NQ(s) + k] = lam[k];
    for (k = 0; k < SYMGEN_NQ(s); ++k) {
        y[s->model->ypos_q[k]] = q[k];
        if (s->model->ypos_v[k] >= 0) y[s->model->ypos_v[k]] = v[k];
    }
}

/* algebraic equations g = [phi; phid; res; phidd] */
static void symgen_alg_(const symgen_solver *s, double t, const double *q, const double *v, const double *a,
                       const double *lam, double *g)
{
    s->model->phi(t, q, v, a, lam, s->p, g);
    s->model->phid(t, q, v, a, lam, s->p, g + SYMGEN_NL(s));
    s->model->res(t, q, v, a, lam, s->p, g + 2 * SYMGEN_NL(s));
    s->model->phidd(t, q, v, a, lam, s->p, g + 2 * SYMGEN_NL(s) + SYMGEN_NQ(s));
}

/* their Jacobian in w = [q; v; a; lam], row-major NALG x NW, into s->galg */
static void symgen_alg_jac_(symgen_solver *s, double t, const double *q, const double *v, const double *a,
                           const double *lam)
{
    s->model->phi_jac(t, q, v, a, lam, s->p, s->galg);
    s->model->phid_jac(t, q, v, a, lam, s->p, s->galg + SYMGEN_NL(s) * SYMGEN_NW(s));
    s->model->res_jac(t, q, v, a, lam, s->p, s->galg + 2 * SYMGEN_NL(s) * SYMGEN_NW(s));
    s->model->phidd_jac(t, q, v, a, lam, s->p, s->galg + (2 * SYMGEN_NL(s) + SYMGEN_NQ(s)) * SYMGEN_NW(s));
}

/* M y' = F(t, y): F = [v_I; a_I; g] */
static void symgen_rhs_(symgen_solver *s, double t, const double *y, double *out)
{
    int k;
    const double *a = symgen_accel_(s, y);
    const double *lam = y + SYMGEN_A0(s) + SYMGEN_NQ(s);
    symgen_unpack_(s, y, s->q, s->v);
    for (k = 0; k < SYMGEN_NI(s); ++k) {
        out[k] = y[SYMGEN_NI(s) + k];
        out[SYMGEN_NI(s) + k] = a[s->model->independent[k]];
    }
    symgen_alg_(s, t, s->q, s->v, a, lam, out + SYMGEN_NX(s));
    s->n_residuals++;
}

/* dF/dy into s->jac */
static void symgen_rhs_jac_(symgen_solver *s, double t, const double *y)
{
    int k, r, c;
    const int ny = SYMGEN_NY(s);
    symgen_unpack_(s, y, s->q, s->v);
    symgen_alg_jac_(s, t, s->q, s->v, symgen_accel_(s, y), y + SYMGEN_A0(s) + SYMGEN_NQ(s));
    memset(s->jac, 0, sizeof(double) * ny * ny);
    for (k = 0; k < SYMGEN_NI(s); ++k) {
        s->jac[k * ny + SYMGEN_NI(s) + k] = 1.0;
        s->jac[(SYMGEN_NI(s) + k) * ny + SYMGEN_A0(s) + s->model->independent[k]] = 1.0;
    }
    for (r = 0; r < SYMGEN_NALG(s); ++r) {
        for (c = 0; c < SYMGEN_NW(s); ++c) {
            const int col = s->model->ycol[c];
            if (col >= 0) s->jac[(SYMGEN_NX(s) + r) * ny + col] = s->galg[r * SYMGEN_NW(s) + c];
        }
    }
    s->n_jacobians++;
}

/* ------------------------------------------------------------------ consistent start */
static int symgen_fail_(symgen_solver *s, double t, const char *what, double value, const char *hint)
{
    s->status = SYMGEN_SOLVER_FAILED;
    if (value == value && value != 0.0) {
        snprintf(s->message, SYMGEN_MESSAGE_SIZE, "at tau = %.6g: %s (%.3g); %s", t, what, value, hint);
    } else {
        snprintf(s->message, SYMGEN_MESSAGE_SIZE, "at tau = %.6g: %s; %s", t, what, hint);
    }
    return SYMGEN_SOLVER_FAILED;
}

/* phi_q restricted to the columns `cols` (NL x NL) into s->sq, factored; 0 if regular */
static int symgen_closure_matrix_(symgen_solver *s, double t, const double *q, const int *cols)
{
    int r, k;
    s->model->phi_jac(t, q, s->zeros, s->zeros, s->zeros, s->p, s->galg);
    for (r = 0; r < SYMGEN_NL(s); ++r) {
        for (k = 0; k < SYMGEN_NL(s); ++k) s->sq[r * SYMGEN_NL(s) + k] = s->galg[r * SYMGEN_NW(s) + cols[k]];
    }
    return symgen_lu(s->sq, SYMGEN_NL(s), s->sp);
}

/* smallest / largest singular value of the loop rows of phi_q in the dependent rigid
   coordinates: the distance to a singular position (Mechanism.singular_ratio: the same measure) */
static double symgen_closure_ratio_(symgen_solver *s, double t, const double *q)
{
    const int n = SYMGEN_NS(s);
    int r, k;
    if (n == 0) return 1.0;
    s->model->phi_jac(t, q, s->zeros, s->zeros, s->zeros, s->p, s->galg);
    for (r = 0; r < n; ++r) {
        for (k = 0; k < n; ++k) s->sq[r * n + k] = s->galg[s->model->sing_rows[r] * SYMGEN_NW(s) + s->model->sing_cols[k]];
    }
    return symgen_singular_ratio(s->sq, n);
}

/* theta, theta', theta'' angle driver k prescribes at t, from its row of phi, phid, phidd
   (Mechanism.driver_motion): the same law the equations use, whatever its form */
static void symgen_driver_motion_(symgen_solver *s, int k, double t, double *m3)
{
    double *r = s->drv_r;
    const int row = s->model->angle_rows[k];
    s->model->phi(t, s->zeros, s->zeros, s->zeros, s->zeros, s->p, r);
    m3[0] = -r[row];
    s->model->phid(t, s->zeros, s->zeros, s->zeros, s->zeros, s->p, r);
    m3[1] = -r[row];
    s->model->phidd(t, s->zeros, s->zeros, s->zeros, s->zeros, s->p, r);
    m3[2] = -r[row];
}

/* damped Newton on phi(t, q) = 0 in the coordinates `dep` (Mechanism.assemble; tolerances
   and limits of symgen.policy, as in Python) */
static int symgen_assemble_(symgen_solver *s, double t, double *q, const int *dep)
{
    const double tol = s->model->policy.assembly_tol;
    double *r = s->as_r, *rt = s->as_rt, *dq = s->as_dq, *trial = s->as_trial;
    double rn, step;
    int it, k;
    if (SYMGEN_NL(s) == 0) return 0;
    s->model->phi(t, q, s->zeros, s->zeros, s->zeros, s->p, r);
    rn = symgen_max_abs(r, SYMGEN_NL(s));
    for (it = 0; it < s->model->policy.assembly_maxit; ++it) {
        int accepted = 0;
        if (rn < tol) return 0;
        if (symgen_closure_matrix_(s, t, q, dep)) break;
        for (k = 0; k < SYMGEN_NL(s); ++k) dq[k] = -r[k];
        symgen_lu_solve(s->sq, SYMGEN_NL(s), s->sp, dq);
        for (step = 1.0; step > s->model->policy.assembly_min_step; step /= 2) {
            double rtn;
            memcpy(trial, q, sizeof(double) * SYMGEN_NQ(s));
            for (k = 0; k < SYMGEN_NL(s); ++k) trial[dep[k]] += step * dq[k];
            s->model->phi(t, trial, s->zeros, s->zeros, s->zeros, s->p, rt);
            rtn = symgen_max_abs(rt, SYMGEN_NL(s));
            if (rtn < rn * (1 - s->model->policy.armijo * step) || rtn < tol) {
                memcpy(q, trial, sizeof(double) * SYMGEN_NQ(s));
                memcpy(r, rt, sizeof(double) * SYMGEN_NL(s));
                rn = rtn;
                accepted = 1;
                break;
            }
        }
        if (!accepted) break;
    }
    if (rn < s->model->policy.assembly_accept) return 0;
    return symgen_fail_(s, t, "the mechanism cannot be assembled near the initial guess: the closure keeps a residual", rn,
                       "give initial.guess angles (rad) near a real assembly, and check lengths and ground points");
}

/* dependent velocities from phid = 0 (Mechanism.velocities) */
static int symgen_velocities_(symgen_solver *s, double t, const double *q, double *v)
{
    double *r = s->vel_r;
    int k;
    if (SYMGEN_NL(s) == 0) return 0;
    for (k = 0; k < SYMGEN_ND(s); ++k) v[s->model->dependent[k]] = 0.0;
    s->model->phid(t, q, v, s->zeros, s->zeros, s->p, r);
    if (symgen_closure_matrix_(s, t, q, s->model->dependent)) {
        return symgen_fail_(s, t, "the closure Jacobian is singular in the dependent coordinates", 0.0,
                           "the rigid mechanism is at a singular position");
    }
    for (k = 0; k < SYMGEN_NL(s); ++k) r[k] = -r[k];
    symgen_lu_solve(s->sq, SYMGEN_NL(s), s->sp, r);
    for (k = 0; k < SYMGEN_ND(s); ++k) v[s->model->dependent[k]] = r[k];
    return 0;
}

/* accelerations and multipliers from [res; phidd] = 0 with the parameters s->p: 0, or 1 when
   the matrix is singular (nothing reported) */
static int symgen_kkt_solve_(symgen_solver *s, double t, const double *q, const double *v, double *a, double *lam)
{
    const int nk = SYMGEN_NQ(s) + SYMGEN_NL(s);
    int r, c;
    memset(a, 0, sizeof(double) * SYMGEN_NQ(s));
    memset(lam, 0, sizeof(double) * SYMGEN_NL(s));
    symgen_alg_(s, t, q, v, a, lam, s->sr);
    symgen_alg_jac_(s, t, q, v, a, lam);
    for (r = 0; r < nk; ++r) {
        for (c = 0; c < nk; ++c) s->sq[r * nk + c] = s->galg[(2 * SYMGEN_NL(s) + r) * SYMGEN_NW(s) + 2 * SYMGEN_NQ(s) + c];
        s->sv[r] = -s->sr[2 * SYMGEN_NL(s) + r];
    }
    if (symgen_lu(s->sq, nk, s->sp)) return 1;
    symgen_lu_solve(s->sq, nk, s->sp, s->sv);
    for (c = 0; c < SYMGEN_NQ(s); ++c) a[c] = s->sv[c];
    for (c = 0; c < SYMGEN_NL(s); ++c) lam[c] = s->sv[SYMGEN_NQ(s) + c];
    return 0;
}

/* accelerations and multipliers from [res; phidd] = 0 (Mechanism.accelerations) */
static int symgen_accelerations_(symgen_solver *s, double t, const double *q, const double *v, double *a, double *lam)
{
    if (symgen_kkt_solve_(s, t, q, v, a, lam)) {
        return symgen_fail_(s, t, "the accelerations are not determined (singular mass / constraint matrix)", 0.0,
                           "check masses and the driver");
    }
    return 0;
}

/* The joint forces of the start (q, v) at t0 as a continuum gives them
   (symgen.numerics.start.continuum_start_outputs): where the model lists start_forces and the
   start is unstressed (every deformation amplitude and its rate exactly 0), the outputs with
   the free_params (the elastic bars' masses) scaled by f = policy.free_inertia_factor and by
   2 f, extrapolated to 0: 2 y(f) - y(2 f), into s->start_out, and s->continuum_start = 1. A KKT
   matrix singular with the masses scaled keeps the model's own outputs (continuum_start 0). */
static void symgen_continuum_start_(symgen_solver *s, double t0, const double *q, const double *v)
{
    const symgen_model *M = s->model;
    double *p = s->p;
    int k, pass, singular = 0;
    s->continuum_start = 0;
    s->t_start = t0;
    if (M->n_start_forces == 0) return;
    for (k = 0; k < SYMGEN_NE(s); ++k) {
        if (q[M->elastic[k]] != 0.0 || v[M->elastic[k]] != 0.0) return;
    }
    for (pass = 0; pass < 2 && !singular; ++pass) {
        const double f = pass ? 2.0 * M->policy.free_inertia_factor : M->policy.free_inertia_factor;
        double *out = pass ? s->ct_out : s->start_out;
        memcpy(s->ct_p, p, sizeof(double) * SYMGEN_NP(s));
        for (k = 0; k < M->n_free; ++k) s->ct_p[M->free_params[k]] *= f;
        s->p = s->ct_p;   /* the model functions read s->p */
        singular = symgen_kkt_solve_(s, t0, q, v, s->ct_a, s->ct_lam);
        s->p = p;
        if (!singular) M->out(t0, q, v, s->ct_a, s->ct_lam, s->ct_p, out);
    }
    if (singular) return;
    for (k = 0; k < M->nout; ++k) s->start_out[k] = 2.0 * s->start_out[k] - s->ct_out[k];
    s->continuum_start = 1;
}

static int symgen_beyond_range_(symgen_solver *s, double t);

/* is coordinate i one of the model's `moving` amplitudes (StartPlan.moving)? */
static int symgen_moving_(const symgen_solver *s, int i)
{
    int k;
    for (k = 0; k < s->model->nmoving; ++k)
        if (s->model->moving[k] == i) return 1;
    return 0;
}

/* quasi-static deformation for the rigid state in (q, v) (start.quasi_static_state):
   unknowns u = [u_E, q_D, v_D, a_R, lam], u_E the amplitudes' positions; their rates and
   accelerations zero (hold 0) or held, the rates at v's and the accelerations at s->qs_ah's
   (hold 1: their loads in the state, quasi_static_state's rates and accels); hold 2: the
   `moving` amplitudes keep the position and rate of (q, v) and u_E holds their accelerations
   instead, the others' rates and accelerations zero (quasi_static_state's moving: the axial
   amplitudes following the bending's held motion, start.quasi_static_start) */
static int symgen_quasi_static_(symgen_solver *s, double t, double *q, double *v, int hold)
{
    const int nu = SYMGEN_NALG(s);
    double *u = s->qs_u, *a = s->qs_a, *lam = s->qs_lam;
    double Fmax = 0.0;
    int it, k, r, *col = s->qs_col, converged = 0;
    int off = 0;
    for (k = 0; k < SYMGEN_NE(s); ++k) {
        const int i = s->model->elastic[k];
        const int moves = hold == 2 && symgen_moving_(s, i);
        u[off + k] = moves ? 0.0 : q[i];
        col[off + k] = moves ? 2 * SYMGEN_NQ(s) + i : i;
    }
    off += SYMGEN_NE(s);
    for (k = 0; k < SYMGEN_ND(s); ++k) { u[off + k] = q[s->model->dependent[k]]; col[off + k] = s->model->dependent[k]; }
    off += SYMGEN_ND(s);
    for (k = 0; k < SYMGEN_ND(s); ++k) { u[off + k] = v[s->model->dependent[k]]; col[off + k] = SYMGEN_NQ(s) + s->model->dependent[k]; }
    off += SYMGEN_ND(s);
    for (k = 0; k < SYMGEN_NR(s); ++k) { u[off + k] = 0.0; col[off + k] = 2 * SYMGEN_NQ(s) + s->model->accel[k]; }
    off += SYMGEN_NR(s);
    for (k = 0; k < SYMGEN_NL(s); ++k) { u[off + k] = 0.0; col[off + k] = 3 * SYMGEN_NQ(s) + k; }
    for (it = 1; it <= s->model->policy.quasi_static_maxit + 1; ++it) {
        /* state of u */
        off = 0;
        memset(a, 0, sizeof(double) * SYMGEN_NQ(s));
        for (k = 0; k < SYMGEN_NE(s); ++k) {
            const int i = s->model->elastic[k];
            if (hold == 2 && col[off + k] != i) a[i] = u[off + k];   /* moving: on its held motion */
            else {
                q[i] = u[off + k];
                if (hold == 1) a[i] = s->qs_ah[i];
                else v[i] = 0.0;
            }
        }
        off += SYMGEN_NE(s);
        for (k = 0; k < SYMGEN_ND(s); ++k) q[s->model->dependent[k]] = u[off + k];
        off += SYMGEN_ND(s);
        for (k = 0; k < SYMGEN_ND(s); ++k) v[s->model->dependent[k]] = u[off + k];
        off += SYMGEN_ND(s);
        for (k = 0; k < SYMGEN_NR(s); ++k) a[s->model->accel[k]] = u[off + k];
        off += SYMGEN_NR(s);
        for (k = 0; k < SYMGEN_NL(s); ++k) lam[k] = u[off + k];
        if (it == s->model->policy.quasi_static_maxit + 1) break;
        symgen_alg_(s, t, q, v, a, lam, s->sr);
        Fmax = symgen_max_abs(s->sr, nu);
        if (Fmax < s->model->policy.quasi_static_tol) { converged = 1; break; }
        symgen_alg_jac_(s, t, q, v, a, lam);
        for (r = 0; r < nu; ++r) {
            for (k = 0; k < nu; ++k) s->sq[r * nu + k] = s->galg[r * SYMGEN_NW(s) + col[k]];
        }
        if (symgen_lu(s->sq, nu, s->sp)) break;
        symgen_lu_solve(s->sq, nu, s->sp, s->sr);
        for (k = 0; k < nu; ++k) u[k] -= s->sr[k];
    }
    if (!converged) {
        symgen_alg_(s, t, q, v, a, lam, s->sr);
        Fmax = symgen_max_abs(s->sr, nu);
        if (!(Fmax <= s->model->policy.quasi_static_accept)) {
            /* the real cause first: near a state beyond the range of the bar models (as in Python) */
            if (Fmax <= s->model->policy.quasi_static_near) {
                memcpy(s->q, q, sizeof(double) * SYMGEN_NQ(s));
                if (symgen_beyond_range_(s, t)) return 1;
            }
            return symgen_fail_(s, t, "the quasi-static state did not converge (residual)", Fmax,
                               "the mechanism may be near buckling or a singular position");
        }
    }
    return 0;
}

static void symgen_reduce_(symgen_solver *s);

/* The divergence check of a quasi-static start (Mechanism.divergent_deformation). The linearised
   motion of the independent amplitudes q_E about the state (q, v), the rigid independent
   coordinates held and the dependent ones following the closure, is
       d/dtau [dq_E; dv_E] = A [dq_E; dv_E],   A = [[0, I], [da_E/dq_E, da_E/dv_E]],
   whose lower rows are those of dz/dx = -g_z^-1 g_x of the index-1 system (rows of a_E in z,
   columns of q_E and v_E in x): the integrator's own Jacobian (rhs_jac) and reduction (reduce,
   K = g_z^-1 g_x). A real eigenvalue s of A (|Im s| <= tol, tol = divergence_rtol max(1, max |s|))
   above tol is a divergence: the state is an unstable equilibrium, beyond a buckling load, and
   the start is refused, naming the largest such rate and the amplitude that dominates its
   eigenvector (largest |component| among the q_E; by inverse iteration with A - s I). 0, or fail.
   The amplitudes E are the run's dynamic ones (in x): quasi-static amplitudes follow them in z,
   their stiffness in K (the linearised motion of the DAE the solver integrates). */
static int symgen_divergence_(symgen_solver *s, double t, const double *q, const double *v)
{
    const int nx = SYMGEN_NX(s);
    double *a = s->dv_a, *lam = s->dv_lam, scale = 1.0, tol, rate = 0.0, big;
    int *E = s->dvidx, ne = 0, n2, i, j, k, it, coord = -1, regular = 0;
    s->divergence_rate = 0.0;
    for (k = 0; k < SYMGEN_NE(s); ++k) {
        if (s->model->ypos_q[s->model->elastic[k]] < nx) E[ne++] = s->model->elastic[k];
    }
    n2 = 2 * ne;
    if (ne == 0) return 0;
    if (symgen_accelerations_(s, t, q, v, a, lam)) return 1;
    symgen_pack_(s, q, v, a, lam, s->y);
    symgen_rhs_jac_(s, t, s->y);
    symgen_reduce_(s);
    if (s->gzz_singular) {
        return symgen_fail_(s, t, "the quasi-static state's algebraic equations are singular (no linearised motion)", 0.0,
                           "the rigid mechanism may be at a singular position");
    }
    memset(s->dva, 0, sizeof(double) * n2 * n2);
    for (i = 0; i < ne; ++i) {
        const int row = 2 * SYMGEN_ND(s) + E[i];      /* a_E[i] in z */
        s->dva[i * n2 + ne + i] = 1.0;
        for (j = 0; j < ne; ++j) {
            s->dva[(ne + i) * n2 + j] = -s->kzx[row * nx + s->model->ypos_q[E[j]]];
            s->dva[(ne + i) * n2 + ne + j] = -s->kzx[row * nx + s->model->ypos_v[E[j]]];
        }
    }
    if (!(symgen_max_abs(s->dva, n2 * n2) <= DBL_MAX)) {
        return symgen_fail_(s, t, "the linearised motion of the quasi-static state is not finite", 0.0,
                           "check the loads and stiffness of the bars");
    }
    memcpy(s->dvh, s->dva, sizeof(double) * n2 * n2);
    if (symgen_eigenvalues(s->dvh, n2, s->dvu, s->dvwr, s->dvwi)) {
        return symgen_fail_(s, t, "the stability of the quasi-static state is not known: its eigenvalues did not converge", 0.0,
                           "check the loads and stiffness of the bars");
    }
    for (k = 0; k < n2; ++k) scale = fmax(scale, hypot(s->dvwr[k], s->dvwi[k]));
    tol = s->model->policy.divergence_rtol * scale;
    for (k = 0; k < n2; ++k) {
        if (fabs(s->dvwi[k]) <= tol && s->dvwr[k] > tol && s->dvwr[k] > rate) rate = s->dvwr[k];
    }
    if (rate == 0.0) return 0;
    s->divergence_rate = rate;
    /* its eigenvector: inverse iteration x := (A - sigma I)^-1 x from x = 1 with sigma = rate (moved
       by eps scale should the LU meet an exact zero pivot): A - sigma I is singular to the
       eigenvalue's round-off, so each step multiplies the other eigenvectors' share of x by
       about that round-off over their distance to rate; 3 steps (Wilkinson: 1 or 2 suffice) */
    for (it = 0; it < 2 && !regular; ++it) {
        memcpy(s->dvh, s->dva, sizeof(double) * n2 * n2);
        for (k = 0; k < n2; ++k) s->dvh[k * n2 + k] -= rate + it * DBL_EPSILON * scale;
        regular = symgen_lu(s->dvh, n2, s->dvpiv) == 0;
    }
    for (k = 0; k < n2; ++k) s->dvx[k] = 1.0;
    for (it = 0; regular && it < 3; ++it) {
        memcpy(s->dvu, s->dvx, sizeof(double) * n2);
        symgen_lu_solve(s->dvh, n2, s->dvpiv, s->dvu);
        big = symgen_max_abs(s->dvu, n2);
        if (!(big > 0.0 && big <= DBL_MAX)) break;          /* keep the last finite iterate */
        for (k = 0; k < n2; ++k) s->dvx[k] = s->dvu[k] / big;
    }
    for (k = 0, big = -1.0; regular && k < ne; ++k) {       /* the q_E half: the amplitudes */
        if (fabs(s->dvx[k]) > big) { big = fabs(s->dvx[k]); coord = E[k]; }
    }
    s->status = SYMGEN_SOLVER_FAILED;
    snprintf(s->message, SYMGEN_MESSAGE_SIZE, "at tau = %.6g: the quasi-static state is unstable: the deformation grows "
             "at rate %.3g (per unit tau) along %s, a load beyond a buckling load; lower the load or stiffen the bar; "
             "or start undeformed (remove initial.deformation = \"quasi-static\") to follow the bar into its buckled "
             "state", t, rate, coord >= 0 ? s->model->coordinate_names[coord] : "the deformation amplitudes");
    return SYMGEN_SOLVER_FAILED;
}


/* quasi-static start (start.quasi_static_start): under angle drivers the deformation rates and
   accelerations are the quasi-static ones too, by central first and second differences, and the
   deformation is solved again with both held (their loads in it: the Coriolis load 2 theta' w' on
   a turning bar, the deformation's own inertia, the foreshortening's acceleration) */
/* the quasi-static state at t0 + dt from (q, v) at t0, in s->qs (start._shifted): the driven angles
   moved, under hold 2 the `moving` amplitudes on their held motion q + dt v + dt^2/2 qs_ah (their
   rate v + dt qs_ah, their accelerations the unknowns), the closure assembled and its velocities
   made consistent (in s->vs), the deformation solved (symgen_quasi_static_ with hold 0 or 2) */
static int symgen_shifted_(symgen_solver *s, double t0, double dt, const double *q, const double *v, int hold)
{
    double m3[3];
    int k;
    memcpy(s->qs, q, sizeof(double) * SYMGEN_NQ(s));
    memcpy(s->vs, v, sizeof(double) * SYMGEN_NQ(s));
    for (k = 0; k < s->model->n_angle; ++k) {
        symgen_driver_motion_(s, k, t0 + dt, m3);
        s->qs[s->model->angle_coords[k]] = m3[0];
    }
    for (k = 0; hold == 2 && k < s->model->nmoving; ++k) {
        const int i = s->model->moving[k];
        s->qs[i] = q[i] + dt * v[i] + 0.5 * dt * dt * s->qs_ah[i];
        s->vs[i] = v[i] + dt * s->qs_ah[i];
    }
    if (symgen_assemble_(s, t0 + dt, s->qs, s->model->dependent)) return 1;
    if (symgen_velocities_(s, t0 + dt, s->qs, s->vs)) return 1;
    return symgen_quasi_static_(s, t0 + dt, s->qs, s->vs, hold);
}

/* quasi-static start (start.quasi_static_start): under angle drivers the deformation rates and
   accelerations are the quasi-static ones too, by central first and second differences, and the
   deformation is solved again with both held (their loads in it: the Coriolis load 2 theta' w' on
   a turning bar, the deformation's own inertia, the foreshortening's acceleration) */
static int symgen_quasi_static_start_(symgen_solver *s, double t0, double *q, double *v)
{
    double m3[3], h;
    int k, side, pass;
    if (symgen_quasi_static_(s, t0, q, v, 0)) return 1;
    /* the quasi-static state within the range of the bar models (Mechanism.quasi_static_start) */
    memcpy(s->q, q, sizeof(double) * SYMGEN_NQ(s));
    if (symgen_beyond_range_(s, t0)) return 1;
    /* and stable: not beyond a buckling load (Mechanism.quasi_static_start) */
    if (symgen_divergence_(s, t0, q, v)) return 1;
    {   /* the fastest angle driver at t0 (Mechanism.driver_step); all at rest: quasi-static rates are zero */
        double rate = 0.0;
        int moving = 0;
        for (k = 0; k < s->model->n_angle; ++k) {
            symgen_driver_motion_(s, k, t0, m3);
            if (m3[1] != 0.0 || m3[2] != 0.0) moving = 1;
            if (fabs(m3[1]) > rate) rate = fabs(m3[1]);
        }
        if (!moving) return 0;
        h = rate > 0.0 ? s->model->policy.driver_step / rate : s->model->policy.driver_step;
    }
    for (side = 0; side < 2; ++side) {
        if (symgen_shifted_(s, t0, side == 0 ? -h : h, q, v, 0)) return 1;
        for (k = 0; k < SYMGEN_NE(s); ++k) {
            int i = s->model->elastic[k];
            if (side == 0) s->qe[i] = s->qs[i];
            else {
                v[i] = (s->qs[i] - s->qe[i]) / (2 * h);
                s->qs_ah[i] = (s->qs[i] - 2.0 * q[i] + s->qe[i]) / (h * h);
            }
        }
    }
    for (k = 0; k < s->model->nh; ++k) {   /* no rate nor acceleration in the run */
        v[s->model->quasi[k]] = 0.0;
        s->qs_ah[s->model->quasi[k]] = 0.0;
    }
    if (symgen_quasi_static_(s, t0, q, v, 1)) return 1;
    /* the axial amplitudes' rates and accelerations along the bending's held motion through the
       state just solved: axial-only quasi-static solves at t0 - h, t0, t0 + h (hold 2), their
       central differences held, the state solved again; policy.start_axial_passes times
       (start.quasi_static_start) */
    for (pass = 0; s->model->nfollow > 0 && pass < s->model->policy.start_axial_passes; ++pass) {
        for (side = -1; side <= 1; ++side) {
            if (symgen_shifted_(s, t0, side * h, q, v, 2)) return 1;
            for (k = 0; k < s->model->nfollow; ++k) {
                const int i = s->model->follow[k];
                if (side == -1) s->qe[i] = s->qs[i];
                else if (side == 0) s->qf[i] = s->qs[i];
                else {
                    v[i] = (s->qs[i] - s->qe[i]) / (2 * h);
                    s->qs_ah[i] = (s->qs[i] - 2.0 * s->qf[i] + s->qe[i]) / (h * h);
                }
            }
        }
        if (symgen_quasi_static_(s, t0, q, v, 1)) return 1;
    }
    return 0;
}

/* ------------------------------------------------------------------ Radau IIA */
/* The Newton matrices E = c M - dF/dy (M = diag(I, 0); c = GAMMA / h real, (ALPHA + i BETA) / h
   complex) are solved by block elimination on y = [x; z]: with g_z the algebraic block of dF/dy
   (regular: the DAE has index 1), K = g_z^-1 g_x and jred = f_x - f_z K (the Jacobian of the
   reduced ODE x' = f(x, z(x))),
       (c I - jred) dx = r_x - f_z g_z^-1 r_z,    dz = -g_z^-1 r_z - K dx.
   x = [q_I, v_I] is of second order: jred = [[0, I], [A_q, A_v]], so that (as RADAU5 does for
   second-order systems) dq = (c^2 I - c A_v - A_q)^-1 (r_v + (c I - A_v) r_q), dv = c dq - r_q.
   g_z is factored once per Jacobian and is real for both matrices; a new step size costs only
   the NI x NI LU of c^2 I - c A_v - A_q (real and complex). */
/* b := g_z^-1 b with the factors of g_z (lu_solve visiting their nonzeros only) */
static void symgen_zsolve_(const symgen_solver *s, double *b)
{
    const int nz = SYMGEN_NZ(s);
    const double *A = s->gzz;
    int i, k;
    for (i = 0; i < nz; ++i) {
        const int pi = s->pivz[i];
        if (pi != i) { double tmp = b[i]; b[i] = b[pi]; b[pi] = tmp; }
    }
    for (i = 1; i < nz; ++i) {
        double sum = b[i];
        for (k = s->zrow[i]; k < s->zmid[i]; ++k) sum -= A[i * nz + s->zcol[k]] * b[s->zcol[k]];
        b[i] = sum;
    }
    for (i = nz - 1; i >= 0; --i) {
        double sum = b[i];
        for (k = s->zmid[i]; k < s->zrow[i + 1]; ++k) sum -= A[i * nz + s->zcol[k]] * b[s->zcol[k]];
        b[i] = sum / A[i * nz + i];
    }
}

/* g_z factored (the polish's chord steps and the dense path use it) */
static void symgen_reduce_z_(symgen_solver *s)
{
    const int ny = SYMGEN_NY(s), nx = SYMGEN_NX(s), nz = SYMGEN_NZ(s);
    int i, j, k;
    s->reduced_x = 0;
    for (i = 0; i < nz; ++i) {
        for (j = 0; j < nz; ++j) s->gzz[i * nz + j] = s->jac[(nx + i) * ny + nx + j];
    }
    s->gzz_singular = symgen_lu(s->gzz, nz, s->pivz) != 0;
    if (s->gzz_singular) return;
    /* g_z is sparse (block lower triangular in [q_D, v_D, (a, lam)]) and so are its factors:
       the solves visit their nonzeros only (in the dense order: the same sums) */
    k = 0;
    for (i = 0; i < nz; ++i) {
        s->zrow[i] = k;
        for (j = 0; j < i; ++j) {
            if (s->gzz[i * nz + j] != 0.0) s->zcol[k++] = j;
        }
        s->zmid[i] = k;
        for (j = i + 1; j < nz; ++j) {
            if (s->gzz[i * nz + j] != 0.0) s->zcol[k++] = j;
        }
    }
    s->zrow[nz] = k;
}

/* K = g_z^-1 g_x and jred = f_x - f_z K of the dense path */
static void symgen_reduce_x_(symgen_solver *s)
{
    const int ny = SYMGEN_NY(s), nx = SYMGEN_NX(s), nz = SYMGEN_NZ(s);
    int i, j, k;
    s->reduced_x = 1;
    for (j = 0; j < nx; ++j) {
        for (i = 0; i < nz; ++i) s->uz[i] = s->jac[(nx + i) * ny + j];
        symgen_zsolve_(s, s->uz);
        for (i = 0; i < nz; ++i) s->kzx[i * nx + j] = s->uz[i];
    }
    for (i = 0; i < nx; ++i) {
        for (j = 0; j < nx; ++j) s->jred[i * nx + j] = s->jac[i * ny + j];
        for (k = 0; k < nz; ++k) {
            const double fz = s->jac[i * ny + nx + k];
            if (fz != 0.0) {
                for (j = 0; j < nx; ++j) s->jred[i * nx + j] -= fz * s->kzx[k * nx + j];
            }
        }
    }
}

static void symgen_reduce_(symgen_solver *s)
{
    symgen_reduce_z_(s);
    if (!s->gzz_singular) symgen_reduce_x_(s);
}

/* The Newton matrices factored whole, sparse: E1 = c M - J (real, c = GAMMA / h), E2 (complex,
   c = (ALPHA + i BETA) / h), with M = diag(I, 0) and J = dF/dy of the last Jacobian: its pattern
   is fixed, and so are the pivots Markowitz's criterion chose on the first E1 (the fewest
   fill-in among entries of at least SYMGEN_SPLU_PIVOT of their column), kept for each new step
   size and each new Jacobian (whose nonzeros lie on their pattern: symgen_splu_covers) while
   every pivot stays at least SYMGEN_SPLU_KEEP of its column (else chosen again). A
   chain's Jacobian is block-sparse: the factors keep it so, and a step costs about linearly in
   the number of bars, where the dense path's reduced matrices are full (cubic). 0, or 1: the
   dense path factors this step size (also when the pivots of E2 do not hold). */
#define SYMGEN_SPLU_PIVOT 0.1
#define SYMGEN_SPLU_KEEP 0.01
static int symgen_sparse_factor_(symgen_solver *s, double h)
{
    const int ny = SYMGEN_NY(s), nx = SYMGEN_NX(s);
    const double fac1 = s->model->radau.gamma / h, alphn = s->model->radau.alpha / h, betan = s->model->radau.beta / h;
    int j, fresh = 0;
    if (s->analyzed < 0 || s->dense_newton) return 1;
    if (s->analyzed) {
        symgen_splu_gather(&s->lu, s->jac, -1.0, s->spa);
        for (j = 0; j < nx; ++j) s->spa[j * ny + j] += fac1;
        fresh = symgen_splu_refactor(&s->lu, s->spa, SYMGEN_SPLU_KEEP) != 0;
    }
    if (!s->analyzed || fresh) {
        for (j = 0; j < ny * ny; ++j) s->spa[j] = -s->jac[j];
        for (j = 0; j < nx; ++j) s->spa[j * ny + j] += fac1;
        s->analyzed = symgen_splu_analyze(&s->lu, s->spa, SYMGEN_SPLU_PIVOT) ? -1 : 1;
        if (s->analyzed < 0) return 1;
    }
    symgen_splu_gather(&s->lu, s->jac, -1.0, s->spr);
    symgen_splu_gather(&s->lu, s->jac, 0.0, s->spi);
    for (j = 0; j < nx; ++j) {
        s->spr[j * ny + j] += alphn;
        s->spi[j * ny + j] += betan;
    }
    if (symgen_splu_crefactor(&s->lu, s->spr, s->spi, SYMGEN_SPLU_KEEP)) return 1;
    symgen_splu_pack(&s->lu, s->spa, s->spv);
    symgen_splu_pack(&s->lu, s->spr, s->spvr);
    symgen_splu_pack(&s->lu, s->spi, s->spvi);
    return 0;
}

static int symgen_factor_(symgen_solver *s, double h)
{
    const int ni = SYMGEN_NI(s), nx = SYMGEN_NX(s);
    const double fac1 = s->model->radau.gamma / h, alphn = s->model->radau.alpha / h, betan = s->model->radau.beta / h;
    int i, j;
    if (s->gzz_singular) return 1;
    s->sparse = symgen_sparse_factor_(s, h) == 0;
    if (s->sparse) {
        s->n_factorizations++;
        s->h_lu = h;
        return 0;
    }
    if (!s->reduced_x) symgen_reduce_x_(s);
    for (i = 0; i < ni; ++i) {
        for (j = 0; j < ni; ++j) {
            const double aq = s->jred[(ni + i) * nx + j], av = s->jred[(ni + i) * nx + ni + j];
            s->e1[i * ni + j] = -aq - fac1 * av;
            s->e2r[i * ni + j] = -aq - alphn * av;
            s->e2i[i * ni + j] = -betan * av;
        }
        s->e1[i * ni + i] += fac1 * fac1;
        s->e2r[i * ni + i] += alphn * alphn - betan * betan;
        s->e2i[i * ni + i] += 2.0 * alphn * betan;
    }
    s->n_factorizations++;
    s->h_lu = h;
    if (symgen_lu(s->e1, ni, s->piv1)) return 1;
    if (symgen_clu(s->e2r, s->e2i, ni, s->piv2)) return 1;
    return 0;
}

/* d := E1^-1 d (real Newton matrix; c = GAMMA / h) */
static void symgen_solve1_(symgen_solver *s, double *d)
{
    const int ny = SYMGEN_NY(s), ni = SYMGEN_NI(s), nx = SYMGEN_NX(s), nz = SYMGEN_NZ(s);
    const double fac1 = s->model->radau.gamma / s->h_lu;
    double *x = d, *z = d + nx, *u = s->uz;
    int i, k;
    if (s->sparse) {
        symgen_splu_solve(&s->lu, s->spv, d, s->spx);
        memcpy(d, s->spx, sizeof(double) * ny);
        return;
    }
    memcpy(u, z, sizeof(double) * nz);
    symgen_zsolve_(s, u);
    for (i = ni; i < nx; ++i) {          /* the rows of q_I do not depend on z */
        double sum = x[i];
        for (k = 0; k < nz; ++k) sum -= s->jac[i * ny + nx + k] * u[k];
        x[i] = sum;
    }
    for (i = 0; i < ni; ++i) {           /* r_v + (c I - A_v) r_q */
        double sum = x[ni + i] + fac1 * x[i];
        for (k = 0; k < ni; ++k) sum -= s->jred[(ni + i) * nx + ni + k] * x[k];
        x[ni + i] = sum;
    }
    symgen_lu_solve(s->e1, ni, s->piv1, x + ni);
    for (i = 0; i < ni; ++i) {
        const double dq = x[ni + i];
        x[ni + i] = fac1 * dq - x[i];
        x[i] = dq;
    }
    for (k = 0; k < nz; ++k) {
        double sum = -u[k];
        for (i = 0; i < nx; ++i) sum -= s->kzx[k * nx + i] * x[i];
        z[k] = sum;
    }
}

/* (dr + i di) := E2^-1 (dr + i di) (complex Newton matrix; c = (ALPHA + i BETA) / h) */
static void symgen_solve2_(symgen_solver *s, double *dr, double *di)
{
    const int ny = SYMGEN_NY(s), ni = SYMGEN_NI(s), nx = SYMGEN_NX(s), nz = SYMGEN_NZ(s);
    const double alphn = s->model->radau.alpha / s->h_lu, betan = s->model->radau.beta / s->h_lu;
    double *ur = s->uz, *ui = s->uzi;
    int i, k;
    if (s->sparse) {
        symgen_splu_csolve(&s->lu, s->spvr, s->spvi, dr, di, s->spx, s->spxi);
        memcpy(dr, s->spx, sizeof(double) * ny);
        memcpy(di, s->spxi, sizeof(double) * ny);
        return;
    }
    memcpy(ur, dr + nx, sizeof(double) * nz);
    memcpy(ui, di + nx, sizeof(double) * nz);
    symgen_zsolve_(s, ur);
    symgen_zsolve_(s, ui);
    for (i = ni; i < nx; ++i) {
        double sr = dr[i], si = di[i];
        for (k = 0; k < nz; ++k) {
            const double fz = s->jac[i * ny + nx + k];
            sr -= fz * ur[k];
            si -= fz * ui[k];
        }
        dr[i] = sr;
        di[i] = si;
    }
    for (i = 0; i < ni; ++i) {
        double sr = dr[ni + i] + alphn * dr[i] - betan * di[i];
        double si = di[ni + i] + alphn * di[i] + betan * dr[i];
        for (k = 0; k < ni; ++k) {
            const double av = s->jred[(ni + i) * nx + ni + k];
            sr -= av * dr[k];
            si -= av * di[k];
        }
        dr[ni + i] = sr;
        di[ni + i] = si;
    }
    symgen_clu_solve(s->e2r, s->e2i, ni, s->piv2, dr + ni, di + ni);
    for (i = 0; i < ni; ++i) {
        const double qr = dr[ni + i], qi = di[ni + i];
        dr[ni + i] = alphn * qr - betan * qi - dr[i];
        di[ni + i] = alphn * qi + betan * qr - di[i];
        dr[i] = qr;
        di[i] = qi;
    }
    for (k = 0; k < nz; ++k) {
        double sr = -ur[k], si = -ui[k];
        for (i = 0; i < nx; ++i) {
            sr -= s->kzx[k * nx + i] * dr[i];
            si -= s->kzx[k * nx + i] * di[i];
        }
        dr[nx + k] = sr;
        di[nx + k] = si;
    }
}

static double symgen_rms_(const double *x, const double *scal, int n, int reps)
{
    double sum = 0.0;
    int i, r;
    for (r = 0; r < reps; ++r) {
        for (i = 0; i < n; ++i) { double e = x[r * n + i] / scal[i]; sum += e * e; }
    }
    return sqrt(sum / (n * reps));
}

/* integrate from s->t with Radau IIA (after Hairer & Wanner's RADAU5) until s->t >= t_out; the
   steps are the error control's, but none passes t_stop >= t_out: the one that would lands on
   it (t_stop = t_out: land exactly on t_out). 0, _FAILED, or _PAUSED at s->step_limit steps */
static int symgen_integrate_(symgen_solver *s, double t_out, double t_stop)
{
    const int ny = SYMGEN_NY(s);
    const double uround = DBL_EPSILON;
    const symgen_radau *rk = &s->model->radau;
    const double safe = rk->safe, facl = rk->facl, facr = rk->facr, thet = rk->thet;
    const double quot1 = rk->quot1, quot2 = rk->quot2;
    const int nit = rk->nit, nx = SYMGEN_NX(s);
    const double C[3] = { rk->c[0], rk->c[1], rk->c[2] }, DD[3] = { rk->dd[0], rk->dd[1], rk->dd[2] };
    const double T[3][3] = { { rk->T[0][0], rk->T[0][1], rk->T[0][2] }, { rk->T[1][0], rk->T[1][1], rk->T[1][2] },
                             { rk->T[2][0], rk->T[2][1], rk->T[2][2] } };
    const double TI[3][3] = { { rk->TI[0][0], rk->TI[0][1], rk->TI[0][2] }, { rk->TI[1][0], rk->TI[1][1], rk->TI[1][2] },
                              { rk->TI[2][0], rk->TI[2][1], rk->TI[2][2] } };
    const double c1 = C[0], c2 = C[1], c1m1 = c1 - 1.0, c2m1 = c2 - 1.0, c1mc2 = c1 - c2;
    const double cfac = safe * (1 + 2 * nit);
    /* the error estimate is of order 3: rtol transformed as in RADAU5, 0.1 rtol^(2/3) (looser than
       asked below rtol = 1e-3); atol with it (RADAU5 keeps atol / rtol) but never looser than
       asked: RADAU5's atol grows as rtol^(-1/3), so that a tighter rtol took fewer steps and
       components at the scale of atol (axial amplitudes of 1e-6 under atol 1e-10) lost accuracy:
       the inverted slider-crank at rtol 1e-10, atol 1e-10 took 70 steps, 8e-5 off its axial peak */
    const double rtol = 0.1 * pow(s->rtol, 2.0 / 3.0), atol = fmin(rtol * (s->atol / s->rtol), s->atol);
    const double fnewt = fmax(10 * uround / rtol, fmin(0.03, sqrt(rtol)));
    long budget = 50000000L;
    int i, j;
    while (s->t < t_out) {
        double h = s->h, h_unclipped = s->h, rem = t_stop - s->t, hhfac = 0.5;
        double fac1, alphn, betan, theta, thqold = 1.0, dynold = 1.0, err, fac, quot, hnew;
        int newt = 0, outcome = 0, clipped = 0, landing = 0;
        if (rem <= 4 * uround * fmax(fabs(t_stop), 1.0)) { s->t = t_stop; break; }
        if (s->step_limit > 0 && s->n_steps >= s->step_limit) return SYMGEN_SOLVER_PAUSED;
        if (--budget <= 0) return symgen_fail_(s, s->t, "too many steps", 0.0, "loosen the tolerances");
        if (h >= rem * (1.0 - 1e-4)) { h = rem; clipped = 1; landing = 1; }
        else if (h > 0.5 * rem) { h = 0.5 * rem; clipped = 1; }
        if (!(h > 1e-14 * fmax(fabs(s->t), 1.0))) {
            return symgen_fail_(s, s->t, "the step size became too small", h,
                               "the mechanism may have reached a singular position, or the tolerances are too tight");
        }
        if (s->need_jac) {
            symgen_rhs_jac_(s, s->t, s->y);
            symgen_reduce_z_(s);
            /* the pivots are kept across Jacobians too: chosen again only when an entry lies
               off their pattern (or none qualified before); symgen_sparse_factor_ chooses them
               again when one no longer holds. Choosing them (Markowitz) costs more than the
               rest of a step: it was half the run's CPU when done at every Jacobian */
            if (s->analyzed < 0 || (s->analyzed > 0 && !symgen_splu_covers(&s->lu, s->jac, SYMGEN_NX(s)))) {
                s->analyzed = 0;
            }
            s->have_jac = 1;
            s->need_jac = 0;
            s->jac_current = 1;
            s->h_lu = -1.0;
        }
        if (h != s->h_lu && symgen_factor_(s, h)) {
            s->n_rejected++;
            s->reject = 1;
            s->h = 0.5 * h;
            continue;
        }
        fac1 = rk->gamma / h; alphn = rk->alpha / h; betan = rk->beta / h;
        /* weights of the Newton test: differential components by their value; algebraic ones
           (they pass through zero with round-off of the size of their peaks) by the largest
           magnitude they have had in this run, and accelerations and multipliers, which move
           x only through h * a, relaxed by 1/h (as RADAU5 does for index-2 variables) */
        for (j = 0; j < ny; ++j) {
            if (j >= nx && fabs(s->y[j]) > s->ymax[j]) s->ymax[j] = fabs(s->y[j]);
            s->scal[j] = atol + rtol * (j < nx ? fabs(s->y[j]) : s->ymax[j]);
            if (j >= SYMGEN_A0(s) && h < 1.0) s->scal[j] /= h;
        }
        for (j = 0; j < s->model->nh; ++j) {       /* a quasi-static amplitude is a coordinate: not relaxed */
            const int at = SYMGEN_A0(s) + s->model->quasi[j];
            s->scal[at] = atol + rtol * s->ymax[at];
        }
        memcpy(s->y0, s->y, sizeof(double) * ny);
        /* starting values: the previous step's collocation polynomial, or zero */
        if (s->first || !s->have_cont) {
            memset(s->z, 0, sizeof(double) * 3 * ny);
        } else {
            const double c3q = h / s->h_old, c1q = c1 * c3q, c2q = c2 * c3q;
            for (j = 0; j < ny; ++j) {
                const double ak1 = s->cont[j], ak2 = s->cont[ny + j], ak3 = s->cont[2 * ny + j];
                s->z[j] = c1q * (ak1 + (c1q - c2m1) * (ak2 + (c1q - c1m1) * ak3));
                s->z[ny + j] = c2q * (ak1 + (c2q - c2m1) * (ak2 + (c2q - c1m1) * ak3));
                s->z[2 * ny + j] = c3q * (ak1 + (c3q - c2m1) * (ak2 + (c3q - c1m1) * ak3));
            }
        }
        for (j = 0; j < ny; ++j) {
            const double z1 = s->z[j], z2 = s->z[ny + j], z3 = s->z[2 * ny + j];
            s->w[j] = TI[0][0] * z1 + TI[0][1] * z2 + TI[0][2] * z3;
            s->w[ny + j] = TI[1][0] * z1 + TI[1][1] * z2 + TI[1][2] * z3;
            s->w[2 * ny + j] = TI[2][0] * z1 + TI[2][1] * z2 + TI[2][2] * z3;
        }
        /* simplified Newton iterations on the stage equations */
        s->faccon = pow(fmax(s->faccon, uround), 0.8);
        theta = thet;
        for (;;) {
            double dyno;
            int finite = 1;
            if (newt >= nit) { outcome = 2; break; }
            for (i = 0; i < 3; ++i) {
                for (j = 0; j < ny; ++j) s->tmp[j] = s->y0[j] + s->z[i * ny + j];
                symgen_rhs_(s, s->t + C[i] * h, s->tmp, s->f + i * ny);
            }
            for (j = 0; j < 3 * ny; ++j) {
                if (!(fabs(s->f[j]) <= DBL_MAX)) { finite = 0; break; }
            }
            if (!finite) { outcome = 2; break; }
            for (j = 0; j < ny; ++j) {
                const double f0 = s->f[j], f1 = s->f[ny + j], f2 = s->f[2 * ny + j];
                const double g1 = TI[0][0] * f0 + TI[0][1] * f1 + TI[0][2] * f2;
                const double g2 = TI[1][0] * f0 + TI[1][1] * f1 + TI[1][2] * f2;
                const double g3 = TI[2][0] * f0 + TI[2][1] * f1 + TI[2][2] * f2;
                if (j < nx) {
                    const double w1 = s->w[j], w2 = s->w[ny + j], w3 = s->w[2 * ny + j];
                    s->dw[j] = g1 - fac1 * w1;
                    s->dw[ny + j] = g2 - (alphn * w2 - betan * w3);
                    s->dw[2 * ny + j] = g3 - (betan * w2 + alphn * w3);
                } else {
                    s->dw[j] = g1;
                    s->dw[ny + j] = g2;
                    s->dw[2 * ny + j] = g3;
                }
            }
            symgen_solve1_(s, s->dw);
            symgen_solve2_(s, s->dw + ny, s->dw + 2 * ny);
            newt++;
            dyno = symgen_rms_(s->dw, s->scal, ny, 3);
            if (!(dyno <= DBL_MAX)) { outcome = 2; break; }
            if (newt > 1 && newt < nit) {
                const double thq = dyno / dynold;
                theta = newt == 2 ? thq : sqrt(thq * thqold);
                thqold = thq;
                if (theta < 0.99) {
                    double dyth;
                    s->faccon = theta / (1.0 - theta);
                    dyth = s->faccon * dyno * pow(theta, nit - 1 - newt) / fnewt;
                    if (dyth >= 1.0) {
                        const double qnewt = fmax(1e-4, fmin(20.0, dyth));
                        hhfac = 0.8 * pow(qnewt, -1.0 / (4.0 + nit - 1 - newt));
                        outcome = 1;
                        break;
                    }
                } else {
                    outcome = 2;
                    break;
                }
            }
            dynold = fmax(dyno, uround);
            for (j = 0; j < 3 * ny; ++j) s->w[j] += s->dw[j];
            for (j = 0; j < ny; ++j) {
                const double w1 = s->w[j], w2 = s->w[ny + j], w3 = s->w[2 * ny + j];
                s->z[j] = T[0][0] * w1 + T[0][1] * w2 + T[0][2] * w3;
                s->z[ny + j] = T[1][0] * w1 + T[1][1] * w2 + T[1][2] * w3;
                s->z[2 * ny + j] = T[2][0] * w1 + T[2][1] * w2 + T[2][2] * w3;
            }
            if (s->faccon * dyno <= fnewt) break;
        }
        s->n_steps++;
        if (outcome) {
            /* Newton too slow (1) or diverging (2): smaller step, fresh Jacobian if it is old */
            s->n_rejected++;
            s->reject = 1;
            s->h = h * (outcome == 1 ? hhfac : 0.5);
            if (!s->jac_current) s->need_jac = 1;
            continue;
        }
        /* error estimate (Hairer & Wanner IV.8) */
        for (j = 0; j < ny; ++j) {
            const double e = (DD[0] * s->z[j] + DD[1] * s->z[ny + j] + DD[2] * s->z[2 * ny + j]) / h;
            s->tmp2[j] = j < nx ? e : 0.0;
            s->tmp[j] = s->tmp2[j] + s->f0[j];
        }
        /* the local error test covers the differential components only (like the Python
           path's IDAS with suppress_algebraic): z follows x through the algebraic equations */
        symgen_solve1_(s, s->tmp);
        err = fmax(symgen_rms_(s->tmp, s->scal, nx > 0 ? nx : ny, 1), 1e-10);
        if (err >= 1.0 && (s->first || s->reject)) {
            for (j = 0; j < ny; ++j) s->tmp[j] += s->y0[j];
            symgen_rhs_(s, s->t, s->tmp, s->tmp3);
            for (j = 0; j < ny; ++j) s->tmp[j] = s->tmp3[j] + s->tmp2[j];
            symgen_solve1_(s, s->tmp);
            err = fmax(symgen_rms_(s->tmp, s->scal, nx > 0 ? nx : ny, 1), 1e-10);
        }
        if (!(err <= DBL_MAX)) err = 1e6;
        fac = fmin(safe, cfac / (newt + 2 * nit));
        quot = fmax(facr, fmin(facl, pow(err, 0.25) / fac));
        hnew = h / quot;
        if (err < 1.0) {
            double qt;
            s->n_accepted++;
            if (s->n_accepted > 1) {
                double facgus = (s->h_acc / h) * pow(err * err / s->err_acc, 0.25) / safe;
                facgus = fmax(facr, fmin(facl, facgus));
                quot = fmax(quot, facgus);
                hnew = h / quot;
            }
            s->h_acc = h;
            s->err_acc = fmax(1e-2, err);
            s->first = 0;
            for (j = 0; j < ny; ++j) {
                const double z1 = s->z[j], z2 = s->z[ny + j], z3 = s->z[2 * ny + j];
                const double ak = (z1 - z2) / c1mc2;
                double acont3 = z1 / c1;
                s->y[j] = s->y0[j] + z3;
                s->cont[j] = (z2 - z3) / c2m1;
                acont3 = (ak - acont3) / c2;
                s->cont[ny + j] = (ak - s->cont[j]) / c1m1;
                s->cont[2 * ny + j] = s->cont[ny + j] - acont3;
            }
            s->have_cont = 1;
            s->h_old = h;
            s->t = landing ? t_stop : s->t + h;
            symgen_rhs_(s, s->t, s->y, s->f0);
            if (s->reject) hnew = fmin(hnew, h);
            s->reject = 0;
            s->jac_current = 0;
            qt = hnew / h;
            if (theta <= thet && qt >= quot1 && qt <= quot2) hnew = h;
            if (clipped) hnew = hnew < h ? hnew : fmax(hnew, h_unclipped);
            s->h = hnew;
            s->need_jac = theta > thet;
        } else {
            s->n_rejected++;
            s->reject = 1;
            s->h = s->first ? 0.1 * h : hnew;
            if (!s->jac_current) s->need_jac = 1;
        }
    }
    return 0;
}

/* g_z, the Jacobian of the algebraic equations in z, from s->galg (symgen_alg_jac_) into s->sq */
static void symgen_gz_(symgen_solver *s)
{
    const int nz = SYMGEN_NZ(s);
    int r, c;
    for (r = 0; r < nz; ++r) {
        for (c = 0; c < SYMGEN_NW(s); ++c) {
            const int col = s->model->ycol[c];
            if (col >= SYMGEN_NX(s)) s->sq[r * nz + col - SYMGEN_NX(s)] = s->galg[r * SYMGEN_NW(s) + c];
        }
    }
}

/* Newton on the algebraic equations in z at fixed x (DaeRunner.polish). The first iterations
   use the factored g_z of the integrator's last Jacobian (a chord step costs one solve, no
   Jacobian and no LU), kept while each contracts the residual at least tenfold; then Newton with
   a fresh g_z. Both stop at the same residual. */
static void symgen_polish_(symgen_solver *s, double t, double *y)
{
    const int nz = SYMGEN_NZ(s);
    int it, r, chord = s->have_jac && !s->gzz_singular;
    double rn, rn_old = HUGE_VAL;
    for (it = 0; it < s->model->policy.polish_maxit; ++it) {
        symgen_unpack_(s, y, s->q, s->v);
        symgen_alg_(s, t, s->q, s->v, symgen_accel_(s, y), y + SYMGEN_A0(s) + SYMGEN_NQ(s), s->sr);
        rn = symgen_max_abs(s->sr, nz);
        if (rn < s->model->policy.polish_tol) break;
        if (chord && !(rn <= 0.1 * rn_old)) {
            chord = 0;
            if (rn_old < rn) {       /* the last chord step made it worse: undo it */
                for (r = 0; r < nz; ++r) y[SYMGEN_NX(s) + r] += s->uz[r];
                it--;
                continue;
            }
        }
        rn_old = rn;
        if (chord) {
            memcpy(s->uz, s->sr, sizeof(double) * nz);
            symgen_zsolve_(s, s->uz);
            for (r = 0; r < nz; ++r) y[SYMGEN_NX(s) + r] -= s->uz[r];
            it--;                    /* chord steps are not counted against the Newton iterations */
            continue;
        }
        symgen_alg_jac_(s, t, s->q, s->v, symgen_accel_(s, y), y + SYMGEN_A0(s) + SYMGEN_NQ(s));
        symgen_gz_(s);
        if (symgen_lu(s->sq, nz, s->sp)) break;
        symgen_lu_solve(s->sq, nz, s->sp, s->sr);
        for (r = 0; r < nz; ++r) y[SYMGEN_NX(s) + r] -= s->sr[r];
    }
}

/* The quasi-static amplitudes at the start (DaeRunner.quasi_start): z solved from the algebraic
   equations by Newton at fixed x from the full model's consistent start in s->y, converged when
   the step is below policy.quasi_start_tol of max(1, max |z|), or below quasi_start_floor of it
   and no longer halving (round-off of an ill-conditioned Jacobian); refused when it does not
   converge (a quasi-static function near buckling: keep it dynamic). 0, or fail. */
static int symgen_quasi_start_(symgen_solver *s, double t)
{
    const int nz = SYMGEN_NZ(s);
    double *y = s->y, *z = s->y + SYMGEN_NX(s);
    int it, r;
    double last = DBL_MAX;
    for (it = 0; it < s->model->policy.quasi_start_maxit; ++it) {
        double step, size;
        symgen_unpack_(s, y, s->q, s->v);
        symgen_alg_(s, t, s->q, s->v, symgen_accel_(s, y), y + SYMGEN_A0(s) + SYMGEN_NQ(s), s->sr);
        symgen_alg_jac_(s, t, s->q, s->v, symgen_accel_(s, y), y + SYMGEN_A0(s) + SYMGEN_NQ(s));
        symgen_gz_(s);
        if (symgen_lu(s->sq, nz, s->sp)) break;
        symgen_lu_solve(s->sq, nz, s->sp, s->sr);
        for (r = 0; r < nz; ++r) z[r] -= s->sr[r];
        size = symgen_max_abs(z, nz);
        if (!(size <= DBL_MAX)) break;
        step = symgen_max_abs(s->sr, nz);
        if (step <= s->model->policy.quasi_start_tol * fmax(1.0, size)) return 0;
        if (step <= s->model->policy.quasi_start_floor * fmax(1.0, size) && step > 0.5 * last) return 0;
        last = step;
    }
    return symgen_fail_(s, t, "the quasi-static transverse amplitudes have no solution at the start (Newton does not converge)",
                        0.0, "lower bodies.<name>.quasi_static_transverse (keep those functions dynamic)");
}

/* the largest |eta'| and the largest ||r'| - 1| over the points of amplitude check c in q
   (symgen.numerics.checks.bar_ranges): a NaN at a point makes its value NaN; no axial
   amplitudes: *stretch = 0 (not checked) */
static void symgen_bar_range_(const symgen_model *M, const symgen_amplitude_check *c, const double *q,
                              double *slope, double *stretch)
{
    int j, k;
    *slope = 0.0;
    *stretch = 0.0;
    for (j = 0; j < c->points; ++j) {
        double eta = 0.0, zeta = 0.0, e, a;
        if (c->guide) {
            /* a slot guide: its functions scaled by the contact (checks.guide_slopes) */
            const double beta = q[c->beta];
            const int *pw = c->powers + (j < c->span_points ? 0 : 2);
            for (k = 0; k < c->count; ++k) {
                eta += c->slopes[j * c->count + k] * pow(beta, pw[4 * k]) * pow(1.0 - beta, pw[4 * k + 1]) *
                       q[M->amplitude_index[c->start + k]];
            }
        } else {
            for (k = 0; k < c->count; ++k) eta += c->slopes[j * c->count + k] * q[M->amplitude_index[c->start + k]];
        }
        a = fabs(eta);
        if (*slope == *slope && !(a <= *slope)) *slope = a;      /* a NaN stays */
        if (c->axial_count == 0) continue;
        for (k = 0; k < c->axial_count; ++k) {
            zeta += c->stretches[j * c->axial_count + k] * q[M->amplitude_index[c->axial_start + k]];
        }
        /* |r'| - 1 of r' = (1 + zeta', eta'), without cancellation (checks.stretch) */
        if (c->linear) eta = 0.0;
        e = fabs((2.0 * zeta + zeta * zeta + eta * eta) / (1.0 + sqrt((1.0 + zeta) * (1.0 + zeta) + eta * eta)));
        if (*stretch == *stretch && !(e <= *stretch)) *stretch = e;
    }
}

/* bars deformed beyond the range of the model (Mechanism.beyond_range) in s->q at t: 0, or fail */
static int symgen_beyond_range_(symgen_solver *s, double t)
{
    const symgen_model *M = s->model;
    int g;
    for (g = 0; g < M->n_amplitude_checks; ++g) {
        const symgen_amplitude_check *c = &M->amplitude_checks[g];
        double slope, stretch;
        symgen_bar_range_(M, c, s->q, &slope, &stretch);
        if (c->count > 0 && !(slope <= M->policy.slope_limit)) {
            return symgen_fail_(s, t, c->slope_message, slope,
                                "check the loads, lumped masses and stiffness (lambda, mu) of that bar");
        }
        if (c->axial_count > 0 && !(stretch <= M->policy.stretch_limit)) {
            return symgen_fail_(s, t, c->stretch_message, stretch,
                                "check the loads, lumped masses and stiffness (lambda, mu) of that bar");
        }
    }
    return 0;
}

/* a NaN's rank below every value (numpy's argmax of where(isfinite(s), s, -1)) */
static double symgen_rank_(double x)
{
    return fabs(x) <= DBL_MAX ? x : -1.0;
}

/* the range record (symgen_solver_range) after a row at t with coordinates q */
static void symgen_record_range_(symgen_solver *s, double t, const double *q)
{
    const symgen_model *M = s->model;
    int g;
    for (g = 0; g < M->n_amplitude_checks; ++g) {
        double *r = s->range_rec + SYMGEN_RANGE_FIELDS * g;
        double slope, stretch;
        symgen_bar_range_(M, &M->amplitude_checks[g], q, &slope, &stretch);
        if (r[1] != r[1] || symgen_rank_(slope) > symgen_rank_(r[0])) r[0] = slope, r[1] = t;
        if (r[2] != r[2] && !(slope <= s->range_warning)) r[2] = t, r[3] = slope;
        if (r[5] != r[5] || symgen_rank_(stretch) > symgen_rank_(r[4])) r[4] = stretch, r[5] = t;
    }
}

SYMGEN_API int symgen_solver_range(const symgen_solver *s, double *out)
{
    if (!s || !s->model || !out) return 0;
    memcpy(out, s->range_rec, sizeof(double) * SYMGEN_RANGE_FIELDS * (size_t)s->model->n_amplitude_checks);
    return s->model->n_amplitude_checks;
}

SYMGEN_API void symgen_solver_range_warning(symgen_solver *s, double slope)
{
    if (s) s->range_warning = slope;
}

/* at a good output (the start, each advance, each dense output) at t with state y: the largest
   closure residual seen, and the coordinates there (a failing step's diagnosis looks back at them) */
static void symgen_record_closure_(symgen_solver *s, double t, const double *y)
{
    double *clo = s->clo;
    double m;
    symgen_unpack_(s, y, s->q, s->v);
    memcpy(s->q_last, s->q, sizeof(double) * SYMGEN_NQ(s));
    s->t_last = t;
    if (SYMGEN_NCLO(s) == 0) return;
    s->model->closure(t, s->q, s->zeros, s->zeros, s->zeros, s->p, clo);
    m = symgen_max_abs(clo, SYMGEN_NCLO(s));
    if (m > s->closure_max) s->closure_max = m;
}

/* ------------------------------------------------------------------ public */
/* a call with an invalid argument: the message, nothing else changed */
static int symgen_bad_argument_(symgen_solver *s, const char *what, double value, const char *rule)
{
    snprintf(s->message, SYMGEN_MESSAGE_SIZE, "%s = %.17g is not valid: it must be %s", what, value, rule);
    return SYMGEN_SOLVER_BAD_ARGUMENT;
}

SYMGEN_API int symgen_solver_init(symgen_solver *s, const double *p, double t0, double rtol, double atol)
{
    double *q, *v;
    int k;
    if (!s || !s->model) return SYMGEN_SOLVER_BAD_ARGUMENT;
    {   /* a fresh state (every array zero) in the storage s is bound to */
        const symgen_model *model = s->model;
        double *pp = s->p, *y = s->y, *work = s->work;
        int *iwork = s->iwork;
        long used;
        memset(s, 0, sizeof(*s));
        used = symgen_bind(s, model, pp, y, work, iwork);
        if (s->sizes_differ) {
            s->status = SYMGEN_SOLVER_FAILED;
            snprintf(s->message, SYMGEN_MESSAGE_SIZE, "the solver was compiled for other sizes than its model's "
                     "(files of different emissions mixed?): emit the model's C again");
            return SYMGEN_SOLVER_FAILED;
        }
        memset(work, 0, sizeof(double) * (size_t)used);
        memset(iwork, 0, sizeof(int) * (size_t)SYMGEN_WORK_INTS(s->nq, s->nl, s->ni, s->nd, s->ne));
        memset(pp, 0, sizeof(double) * (size_t)s->np);
        memset(y, 0, sizeof(double) * (size_t)s->ny);
    }
    s->range_warning = s->model->policy.slope_limit;
    for (k = 0; k < SYMGEN_RANGE_FIELDS * s->model->n_amplitude_checks; ++k) s->range_rec[k] = NAN;
    if (!(fabs(t0) <= DBL_MAX)) return s->status = symgen_bad_argument_(s, "t0", t0, "finite");
    if (!(fabs(rtol) <= DBL_MAX) || (rtol > 0 && !(rtol < s->model->rtol_max))) {
        return s->status = symgen_bad_argument_(s, "rtol", rtol, s->model->rtol_rule);
    }
    if (!(fabs(atol) <= DBL_MAX)) {
        return s->status = symgen_bad_argument_(s, "atol", atol, "finite and > 0, or <= 0 for the scene's");
    }
    memcpy(s->p, p ? p : s->model->parameter_defaults, sizeof(double) * SYMGEN_NP(s));
    for (k = 0; k < SYMGEN_NP(s); ++k) {
        if (!s->model->parameter_valid(k, s->p[k])) {
            return s->status = symgen_bad_argument_(s, s->model->parameter_names[k], s->p[k], s->model->parameter_range[k]);
        }
    }
    s->t = t0;
    s->rtol = rtol > 0 ? rtol : s->model->rtol;
    s->atol = atol > 0 ? atol : s->model->atol;
    q = s->qs;   /* scratch for the start */
    v = s->vs;
    memcpy(q, s->model->q_guess, sizeof(double) * SYMGEN_NQ(s));
    memcpy(v, s->model->v_guess, sizeof(double) * SYMGEN_NQ(s));
    for (k = 0; k < s->model->n_angle; ++k) {   /* every angle driver's angle and rate at t0 */
        double m3[3];
        symgen_driver_motion_(s, k, t0, m3);
        q[s->model->angle_coords[k]] = m3[0];
        v[s->model->angle_coords[k]] = m3[1];
    }
    if (symgen_assemble_(s, t0, q, s->model->assembly_dependent)) return s->status;
    if (symgen_closure_ratio_(s, t0, q) < s->model->policy.singular_ratio) {
        return symgen_fail_(s, t0, "the rigid mechanism starts at a singular position: the closure Jacobian loses rank", 0.0,
                           "start the driver at another angle or change initial.guess");
    }
    {
        double *q0 = s->start_q, *v0 = s->start_v, *a = s->start_a, *lam = s->start_lam;
        memcpy(q0, q, sizeof(double) * SYMGEN_NQ(s));
        memcpy(v0, v, sizeof(double) * SYMGEN_NQ(s));
        if (s->model->quasi_static && symgen_quasi_static_start_(s, t0, q0, v0)) return s->status;
        if (symgen_velocities_(s, t0, q0, v0)) return s->status;
        if (symgen_accelerations_(s, t0, q0, v0, a, lam)) return s->status;
        symgen_continuum_start_(s, t0, q0, v0);
        symgen_pack_(s, q0, v0, a, lam, s->y);
        /* the quasi-static amplitudes: the solution of their rows at the start */
        if (s->model->nh > 0 && symgen_quasi_start_(s, t0)) return s->status;
    }
    s->first = 1;
    s->need_jac = 1;
    s->h = 1e-6;
    s->h_lu = -1.0;
    s->faccon = 1.0;
    symgen_rhs_(s, t0, s->y, s->f0);
    s->t_dense = -HUGE_VAL;
    symgen_record_closure_(s, t0, s->y);
    return 0;
}

/* a failed integration: a step that failed where the closure was already near rank loss at the
   last good output met a singular position (as simulate._lost reports it in Python) */
static int symgen_integration_failed_(symgen_solver *s)
{
    const double t_fail = s->t;
    const double ratio = symgen_closure_ratio_(s, s->t_last, s->q_last);
    if (ratio < s->model->policy.near_singular_ratio) {
        return symgen_fail_(s, t_fail, "the rigid mechanism reached a singular position (change point / toggle): "
                           "the closure Jacobian loses rank (singular value ratio at the last output)", ratio,
                           "the mechanism cannot be driven through this position; shorten the run or change "
                           "the geometry or the driver");
    }
    return s->status;
}

/* the checks of an output at t with the polished state y (Mechanism.beyond_range, the singular
   position), then its closure recorded: 0, or fail */
static int symgen_output_checks_(symgen_solver *s, double t, const double *y)
{
    double ratio;
    symgen_unpack_(s, y, s->q, s->v);
    if (symgen_beyond_range_(s, t)) return s->status;
    ratio = symgen_closure_ratio_(s, t, s->q);
    if (ratio < s->model->policy.singular_ratio) {
        return symgen_fail_(s, t, "the rigid mechanism reached a singular position: the closure Jacobian loses rank (singular value ratio)",
                           ratio, "the mechanism cannot pass this position as driven; shorten t_end or change the geometry");
    }
    symgen_record_closure_(s, t, y);
    return 0;
}

SYMGEN_API int symgen_solver_advance(symgen_solver *s, double t_out)
{
    if (!s) return SYMGEN_SOLVER_BAD_ARGUMENT;
    if (s->status) return s->status;
    if (!(fabs(t_out) <= DBL_MAX)) return symgen_bad_argument_(s, "t_out", t_out, "finite");
    if (!(t_out > s->t)) return 0;
    s->step_limit = 0;
    if (symgen_integrate_(s, t_out, t_out)) return symgen_integration_failed_(s);
    symgen_polish_(s, s->t, s->y);
    symgen_rhs_(s, s->t, s->y, s->f0);
    return symgen_output_checks_(s, s->t, s->y);
}

/* y := the collocation polynomial of the last accepted step at t (RADAU5's CONTR5) */
static void symgen_interpolate_(const symgen_solver *s, double t, double *y)
{
    const int ny = SYMGEN_NY(s);
    const double c1m1 = s->model->radau.c[0] - 1.0, c2m1 = s->model->radau.c[1] - 1.0;
    const double u = (t - s->t) / s->h_old;
    int j;
    for (j = 0; j < ny; ++j) {
        y[j] = s->y[j] + u * (s->cont[j] + (u - c2m1) * (s->cont[ny + j] + (u - c1m1) * s->cont[2 * ny + j]));
    }
}

SYMGEN_API int symgen_solver_dense(symgen_solver *s, double t_out, double t_stop, double *y_out)
{
    int rc;
    if (!s) return SYMGEN_SOLVER_BAD_ARGUMENT;
    if (s->status) return s->status;
    if (!(fabs(t_out) <= DBL_MAX)) return symgen_bad_argument_(s, "t_out", t_out, "finite");
    if (!(fabs(t_stop) <= DBL_MAX) || !(t_stop >= t_out)) {
        return symgen_bad_argument_(s, "t_stop", t_stop, "finite and at or after t_out");
    }
    if (t_out > s->t) {
        rc = symgen_integrate_(s, t_out, t_stop);
        if (rc == SYMGEN_SOLVER_PAUSED) return rc;
        if (rc) return symgen_integration_failed_(s);
    }
    if (t_out == s->t) {
        memcpy(y_out, s->y, sizeof(double) * SYMGEN_NY(s));
    } else if (s->have_cont && t_out >= s->t - s->h_old * (1.0 + 1e-12)) {
        symgen_interpolate_(s, t_out, y_out);
    } else {
        return symgen_bad_argument_(s, "t_out", t_out, "at or after the start of the last step");
    }
    symgen_polish_(s, t_out, y_out);
    s->t_dense = t_out;
    return symgen_output_checks_(s, t_out, y_out);
}

/* at the start of a run from an unstressed state, the joint forces of the outputs `out` at t
   := the continuum's (symgen_continuum_start_) */
static void symgen_start_forces_(const symgen_solver *s, double t, double *out)
{
    int k;
    if (!s->continuum_start || t != s->t_start) return;
    for (k = 0; k < s->model->n_start_forces; ++k) out[s->model->start_forces[k]] = s->start_out[s->model->start_forces[k]];
}

SYMGEN_API int symgen_solver_rows(symgen_solver *s, double t0, double step, long n_rows, long *done, long max_rows,
                                  long max_steps, double *rec)
{
    const symgen_model *M;
    const long first = *done;
    const double t_stop = t0 + (double)(n_rows - 1) * step;
    long stride, i;
    int rc = 0, k;
    if (!s || !done || !rec) return SYMGEN_SOLVER_BAD_ARGUMENT;
    M = s->model;
    stride = 1 + M->nout + 2 * M->n + M->m;
    s->step_limit = max_steps > 0 ? s->n_steps + max_steps : 0;
    for (i = first; i < n_rows && (max_rows <= 0 || i - first < max_rows); ++i) {
        const double t = t0 + (double)i * step;
        double *row = rec + (i - first) * stride;
        rc = symgen_solver_dense(s, t, t_stop, s->yd);
        if (rc && !(rc == SYMGEN_SOLVER_FAILED && s->t_dense == t)) break;
        row[0] = t;
        symgen_model_outputs(M, t, s->yd, s->p, row + 1 + M->nout, row + 1 + M->nout + M->n, s->ya, row + 1);
        symgen_start_forces_(s, t, row + 1);
        for (k = 0; k < M->m; ++k) row[1 + M->nout + 2 * M->n + k] = s->yd[SYMGEN_A0(s) + M->n + k];
        symgen_record_range_(s, t, row + 1 + M->nout);
        *done = i + 1;
        if (rc) break;
    }
    s->step_limit = 0;
    return rc;
}

SYMGEN_API void symgen_model_state(const symgen_model *model, const double *y, double *q, double *v, double *a,
                                   double *lam)
{
    const int a0 = SYMGEN_NX_(model->ni) + 2 * model->nd;
    int k;
    for (k = 0; k < model->n; ++k) {
        const int quasi = model->ypos_q[k] == a0 + k;      /* a quasi-static amplitude: no v, no a */
        if (q) q[k] = y[model->ypos_q[k]];
        if (v) v[k] = quasi ? 0.0 : y[model->ypos_v[k]];
        if (a) a[k] = quasi ? 0.0 : y[a0 + k];
    }
    for (k = 0; k < model->m; ++k) {
        if (lam) lam[k] = y[a0 + model->n + k];
    }
}

SYMGEN_API void symgen_model_outputs(const symgen_model *model, double t, const double *y, const double *p, double *q,
                                     double *v, double *a, double *out)
{
    const int a0 = SYMGEN_NX_(model->ni) + 2 * model->nd;
    symgen_model_state(model, y, q, v, a, NULL);
    model->out(t, q, v, a, y + a0 + model->n, p, out);
}

SYMGEN_API void symgen_solver_outputs(symgen_solver *s, double t, const double *y, double *out)
{
    symgen_model_outputs(s->model, t, y, s->p, s->q, s->v, s->ya, out);
    symgen_start_forces_(s, t, out);
}
