/*
 * symgen C runtime: the numerics of the emitted DAE solver (plain C99 + libm).
 *
 * An emitted model (PREFIX.c: its functions; PREFIX_solver.c: its tables, gathered into one
 * `symgen_model` descriptor) is integrated by this runtime: dense and sparse LU, real and complex,
 * eigenvalues, the consistent and quasi-static start, Radau IIA (order 5) with its step
 * control, the closure polish, and the run checks (singular position, range of the bar models,
 * divergence of a quasi-static start) with their messages. The runtime holds no data of a
 * scene: every size, index set, limit and policy value comes in through the descriptor.
 *
 * Linkage. Every function of the runtime is declared with SYMGEN_API, `extern` unless defined
 * before this header is included. The emitted PREFIX_solver.c defines it as `static` and
 * includes the runtime's .c files: each model then carries a private copy, so that any number
 * of emitted models (of any symgen version) link into one program without duplicate symbols,
 * and `cc PREFIX.c PREFIX_solver.c main.c` builds a model with nothing else to list. Compiled on
 * its own (the runtime's unit tests), the runtime is an ordinary library with `symgen_` symbols.
 *
 * Storage. The runtime allocates nothing: a solver's work arrays live in storage of the caller
 * (the emitted struct PREFIX_solver), of SYMGEN_WORK_DOUBLES / SYMGEN_WORK_INTS elements, and
 * are bound to the solver's pointers on every call (the struct may be moved between calls).
 */
#ifndef SYMGEN_RUNTIME_H
#define SYMGEN_RUNTIME_H

#include <string.h>      /* memcpy of SYMGEN_PUBLISH */

#ifdef __cplusplus
extern "C" {
#endif

#ifndef SYMGEN_API
#define SYMGEN_API extern
#endif

/* Return values (and status): 0 ok, _FAILED the run failed (status stays set, every later call
   returns it), _BAD_ARGUMENT a call with an invalid argument (message says which; nothing done). */
#define SYMGEN_SOLVER_FAILED 1
#define SYMGEN_SOLVER_BAD_ARGUMENT 2
/* symgen_solver_dense / _rows only: the step limit s->step_limit was reached before the output
   time (not a failure: status stays 0; call again to go on) */
#define SYMGEN_SOLVER_PAUSED 3
#define SYMGEN_MESSAGE_SIZE 640

/* F(t, q, v, a, lam, p) -> out: the signature of every model function (symgen's C codegen) */
typedef void (*symgen_function)(double t, const double *q, const double *v, const double *a, const double *lam,
                                const double *p, double *out);

/* The solver policy (symgen/policy.py, rendered by the emitter): tolerances and limits of the
   start, the polish and the checks; the same values the Python runners use. */
typedef struct symgen_policy {
    double assembly_tol, assembly_accept;
    int assembly_maxit;
    double assembly_min_step, armijo;
    double singular_ratio, near_singular_ratio, partition_ratio;
    double quasi_static_tol, quasi_static_accept, quasi_static_near;
    int quasi_static_maxit;
    double polish_tol;
    int polish_maxit;
    double driver_step, slope_limit, stretch_limit, divergence_rtol;
    double free_inertia_factor;
    double quasi_start_tol, quasi_start_floor;
    int quasi_start_maxit;
    int start_axial_passes;
} symgen_policy;

/* The 3-stage Radau IIA method and its step control (symgen/backends/c/radau.py) */
typedef struct symgen_radau {
    double c[3], T[3][3], TI[3][3], dd[3], gamma, alpha, beta;
    int nit;
    double thet, safe, facl, facr, quot1, quot2;
} symgen_radau;

/* The range of a bar model, at its sample points j < points: its transverse amplitudes
   g_k = q[index[start + k]], k < count, give its slopes eta'_j = sum_k slopes[j * count + k] g_k
   (slopes: psi_k'(xi_j)); its axial amplitudes f_k = q[index[axial_start + k]], k < axial_count,
   its zeta'_j = sum_k stretches[j * axial_count + k] f_k (phi_k'(xi_j)); its tangent
   r' = (1 + zeta', eta'). The largest |eta'| within policy.slope_limit (else slope_message), the
   largest ||r'| - 1| within policy.stretch_limit (else stretch_message; no axial amplitudes: not
   checked). linear: the seed's linear strain, whose axis does not shorten as it bends: its
   strain zeta' alone, r' = (1 + zeta', 0) */
typedef struct symgen_amplitude_check {
    int start, count, axial_start, axial_count, points, linear;
    const double *slopes, *stretches;
    const char *slope_message, *stretch_message;
    /* a slot guide (guide = 1): its functions move with the contact q[beta], so the slope of
       function k at point j is slopes[j * count + k] * beta^a (1 - beta)^b, (a, b) =
       powers[4 k], powers[4 k + 1] at the span's first span_points points and powers[4 k + 2],
       powers[4 k + 3] at the overhang's (symgen.ir.shape_samples.GuideSlopes) */
    int guide, beta, span_points;
    const int *powers;
} symgen_amplitude_check;

/*
 * An emitted model: its functions and tables. Sizes: n coordinates q, m multipliers (closure
 * rows: loops, then the angle drivers), np parameters, nclosure loop rows of phi; the solver's
 * partition into ni independent and nd dependent coordinates (y = [q_I, v_I, q_D, v_D, a, lam]);
 * ne deformation amplitudes the quasi-static start solves for, nr accelerations it solves for,
 * ns dependent rigid coordinates that decide a singular position.
 *
 * Quasi-static amplitudes h (nh of them, `quasi`; docs/quasi-static-modes.md, the Python path's
 * symgen.numerics.index1): neither independent nor dependent, algebraic: their rates and
 * accelerations are zero in every equation and the slot of a_h in y holds q_h (ypos_q[h] =
 * a0 + h, ypos_v[h] = -1; in ycol the columns of v_h and a_h are -1, dropped), so y keeps its
 * size and the rows res_h (which no longer read a_h) determine q_h.
 */
typedef struct symgen_model {
    int n, m, np, nclosure, ni, nd, ne, nr, ns;
    const int *independent, *dependent;      /* [ni], [nd]: indices into q */
    const int *assembly_dependent;           /* [nd]: the partition of the assembly at the guess */
    const int *ypos_q, *ypos_v;              /* [n]: position in y of q_i, of v_i */
    const int *ycol;                         /* [3n + m]: position in y of each Jacobian column w = [q; v; a; lam] */
    const int *elastic, *accel;              /* [ne], [nr]: the unknowns of the quasi-static start */
    const int *sing_rows, *sing_cols;        /* [ns]: the closure Jacobian's block that decides a singular position */
    const double *q_guess, *v_guess;         /* [n]: the assembly's initial guess */
    int n_angle;                             /* angle drivers (0: none) */
    const int *angle_coords, *angle_rows;    /* [n_angle]: each angle driver's coordinate and row of phi */
    int quasi_static;                        /* 1: start on the quasi-static deformation */
    double rtol, atol;                       /* the scene's default tolerances */
    double rtol_max;                         /* rtol must be below it */
    const char *rtol_rule;                   /* that rule in words, for the message */
    const char *const *coordinate_names;     /* [n] */
    const char *const *parameter_names;      /* [np] */
    const char *const *parameter_range;      /* [np]: the valid values in words */
    const double *parameter_defaults;        /* [np] */
    int (*parameter_valid)(int k, double value);
    int n_amplitude_checks;
    const symgen_amplitude_check *amplitude_checks;
    const int *amplitude_index;              /* the coordinates the checks sum over */
    symgen_function phi, phid, phidd, res, out, closure;           /* values */
    symgen_function phi_jac, phid_jac, phidd_jac, res_jac;         /* dF/dw, row-major [rows x (3n + m)] */
    symgen_policy policy;
    symgen_radau radau;
    int nout;                                /* values of `out` (a row of symgen_solver_rows) */
    /* the joint forces of an unstressed start as a continuum gives them (the first output of a
       run; symgen.numerics.start.continuum_start_outputs): the parameters scaled towards 0 (the
       elastic bars' masses) and the outputs that take their limit (driver torques, reactions);
       0 and NULL: every output is the model's own */
    int n_free;
    const int *free_params;                  /* [n_free] */
    int n_start_forces;
    const int *start_forces;                 /* [n_start_forces]: indices into out */
    /* the quasi-static amplitudes (0 and NULL: every amplitude dynamic) */
    int nh;
    const int *quasi;                        /* [nh]: indices into q */
    /* the quasi-static start's axial amplitudes whose rates and accelerations it takes along the
       held motion of the bending amplitudes `moving` (StartPlan.follow, .moving; 0 and NULL: none) */
    int nfollow, nmoving;
    const int *follow, *moving;              /* [nfollow], [nmoving]: indices into q */
} symgen_model;

/* The sparse LU of an n x n matrix held in dense row-major storage (symgen_linalg.c): the
   pivot sequence and the factors' pattern, bound to caller storage: prow, pcol, rcount, ccount
   [n], lptr [n + 1], uptr [n], idx and mark [n * n]. */
typedef struct symgen_splu {
    int n, nnz;                  /* size; entries of L + U (fill-in included), after analyze */
    long flops;                  /* multiply-adds of one factorization */
    int *prow, *pcol;            /* step k pivots on (prow[k], pcol[k]) */
    int *lptr, *uptr, *idx;      /* idx[lptr[k]..uptr[k]): rows of L, idx[uptr[k]..lptr[k+1]): columns of U */
    int *mark, *rcount, *ccount; /* the analysis' pattern and active counts */
} symgen_splu;

/*
 * The work arrays of a model, in doubles and in ints: the storage a solver needs beside its
 * struct (p and y are the caller's own arrays). The sizes in terms of the model's: n, m, ni, nd,
 * ne (nclosure <= m), np, nout. symgen_bind carves the storage in this order.
 */
#define SYMGEN_NX_(ni) (2 * (ni))
#define SYMGEN_NZ_(n, m, nd) (2 * (nd) + (n) + (m))
#define SYMGEN_NY_(n, m, ni, nd) (SYMGEN_NX_(ni) + SYMGEN_NZ_(n, m, nd))
#define SYMGEN_NALG_(n, m) (3 * (m) + (n))
#define SYMGEN_NW_(n, m) (3 * (n) + (m))
#define SYMGEN_WORK_DOUBLES(n, m, ni, nd, ne, np, nout) \
    (28 * SYMGEN_NY_(n, m, ni, nd) + 7 * SYMGEN_NY_(n, m, ni, nd) * SYMGEN_NY_(n, m, ni, nd) \
     + SYMGEN_NZ_(n, m, nd) * (SYMGEN_NZ_(n, m, nd) + SYMGEN_NX_(ni) + 2) + SYMGEN_NX_(ni) * SYMGEN_NX_(ni) \
     + 3 * (ni) * (ni) + SYMGEN_NALG_(n, m) * (SYMGEN_NW_(n, m) + SYMGEN_NALG_(n, m) + 3) \
     + 23 * (n) + 11 * (m) + 8 * (ne) * (ne) + 8 * (ne) + (np) + 2 * (nout) + 1)
#define SYMGEN_WORK_INTS(n, m, ni, nd, ne) \
    (SYMGEN_NZ_(n, m, nd) * (SYMGEN_NZ_(n, m, nd) + 3) + 1 + 2 * (ni) + 2 * SYMGEN_NALG_(n, m) + 3 * (ne) + 1 \
     + 2 * SYMGEN_NY_(n, m, ni, nd) * SYMGEN_NY_(n, m, ni, nd) + 6 * SYMGEN_NY_(n, m, ni, nd) + 1)

/*
 * A solver's state. The first block is what a caller reads between calls (the emitted driver
 * and FMU copy it into PREFIX_solver); the rest is the integrator's state and the work arrays.
 */
typedef struct symgen_solver {
    double t;                   /* current tau */
    double rtol, atol;          /* tolerances asked for */
    long n_steps, n_accepted, n_rejected, n_jacobians, n_factorizations, n_residuals;
    double closure_max;         /* max |loop closure| seen at the output times */
    double divergence_rate;     /* growth rate (per unit tau) of a quasi-static start beyond a
                                   buckling load (the start is refused), else 0 */
    int status;                 /* 0 ok, else an error (see message) */
    char message[SYMGEN_MESSAGE_SIZE];
    int continuum_start;        /* 1: the outputs at t_start of the model's start_forces are the
                                   continuum's (start_out), the start being unstressed */
    double t_start;             /* the run's start time */
    /* the integrator: the model, its sizes (nx = 2 ni, nz = 2 nd + n + m, ny = nx + nz,
       nalg = 3 m + n rows and nw = 3 n + m columns of the algebraic Jacobian, y[a0..]: a, lam) */
    const symgen_model *model;
    int nq, nl, np, ni, nd, ne, nr, ns, nclo, nx, nz, ny, nalg, nw, a0;
    double h, h_lu, h_old, h_acc, err_acc, faccon, t_last;
    int first, reject, jac_current, need_jac, have_cont, have_jac, gzz_singular;
    int sizes_differ;           /* the solver's compiled sizes are not the model's: init fails */
    long step_limit;            /* > 0: symgen_solver_dense / _rows pause once n_steps reaches it */
    double t_dense;             /* the time of the last state symgen_solver_dense wrote (checked or not) */
    /* the caller's arrays: p [np], y [ny]; the work arrays (symgen_bind) */
    double *p, *y, *work;
    int *iwork;
    double *yd;                 /* [ny]: the state at an output time of symgen_solver_rows */
    double *y0, *f0, *scal, *ymax, *z, *w, *f, *dw, *cont, *tmp, *tmp2, *tmp3;
    double *jac, *gzz, *kzx, *jred, *e1, *e2r, *e2i, *uz, *uzi;
    double *galg, *sq, *sv, *sr;
    double *q, *v, *qs, *vs, *qe, *qf, *q_last, *zeros;
    double *start_q, *start_v, *start_a, *start_lam, *qs_u, *qs_a, *qs_ah, *qs_lam, *dv_a, *dv_lam;
    double *as_r, *as_rt, *as_dq, *as_trial, *vel_r, *drv_r, *clo;
    double *dva, *dvh, *dvwr, *dvwi, *dvx, *dvu;
    double *ct_p, *ct_a, *ct_lam, *start_out, *ct_out;   /* the continuum start: [np], [n], [m], [nout], [nout] */
    double *ya;                 /* [n]: the accelerations of a state y, a_h = 0 (symgen_accel_) */
    /* the range record over the rows of symgen_solver_rows (symgen_solver_range): per amplitude
       check, SYMGEN_RANGE_FIELDS doubles; range_warning: the slope whose first passing it keeps */
    double *range_rec;          /* [SYMGEN_RANGE_FIELDS * n] */
    double range_warning;
    int *pivz, *zrow, *zmid, *zcol, *piv1, *piv2, *sp, *qs_col, *dvpiv;
    int *dvidx;                 /* [ne]: the dynamic amplitudes of the divergence check */
    /* the Newton matrices factored whole and sparse (the default; else by block elimination,
       dense): the pivots chosen once (analyzed 1; -1: none qualified, dense until the next
       Jacobian), kept across step sizes and Jacobians while they hold and the Jacobian's
       nonzeros lie on their pattern; sparse: the last factorization was; reduced_x:
       K and jred of the dense path are up to date; dense_newton: always the dense path (set
       after symgen_solver_init: the runtime's tests compare both) */
    symgen_splu lu;
    double *spa, *spr, *spi, *spx, *spxi, *spv, *spvr, *spvi;   /* spv*: the packed factors */
    int analyzed, sparse, reduced_x, dense_newton;
} symgen_solver;

/* The public block of symgen_solver, copied into a struct with the same members (the emitted
   PREFIX_solver): t, rtol, atol, the counters, closure_max, divergence_rate, status, message. */
#define SYMGEN_PUBLISH(dst, src) do { \
        (dst)->t = (src)->t; (dst)->rtol = (src)->rtol; (dst)->atol = (src)->atol; \
        (dst)->n_steps = (src)->n_steps; (dst)->n_accepted = (src)->n_accepted; \
        (dst)->n_rejected = (src)->n_rejected; (dst)->n_jacobians = (src)->n_jacobians; \
        (dst)->n_factorizations = (src)->n_factorizations; (dst)->n_residuals = (src)->n_residuals; \
        (dst)->closure_max = (src)->closure_max; (dst)->divergence_rate = (src)->divergence_rate; \
        (dst)->status = (src)->status; \
        memcpy((dst)->message, (src)->message, SYMGEN_MESSAGE_SIZE); \
    } while (0)

/* ------------------------------------------------------------------ solver */
/* Point s's work arrays into `work` (SYMGEN_WORK_DOUBLES) and `iwork` (SYMGEN_WORK_INTS) and its
   p, y at the caller's arrays; returns the number of doubles used (= SYMGEN_WORK_DOUBLES). */
SYMGEN_API long symgen_bind(symgen_solver *s, const symgen_model *model, double *p, double *y, double *work,
                            int *iwork);

/* Start a run at tau = t0 with parameters p (NULL: the model's defaults) and tolerances rtol,
   atol (<= 0: the model's): assembly, singular-position check, quasi-static start (range and
   divergence checks), consistent velocities, accelerations and multipliers; then, with
   quasi-static amplitudes (model->nh > 0), z by Newton at fixed x (their values, and a and lam
   with them; refused when it does not converge). s is bound. */
SYMGEN_API int symgen_solver_init(symgen_solver *s, const double *p, double t0, double rtol, double atol);

/* Integrate to tau = t_out (> s->t), landing exactly on it, polish z and run the checks. */
SYMGEN_API int symgen_solver_advance(symgen_solver *s, double t_out);

/*
 * Dense output. Integrate with the steps the error control sets (never shortened to meet t_out;
 * only the step that would pass t_stop >= t_out lands on it) until the last step covers tau =
 * t_out (t_out at or after the previous output time), and write the state at t_out into y_out
 * (ny doubles): the last step's collocation polynomial (order 3 in x, z alike), then z polished
 * by Newton on the algebraic equations at fixed x (position closure to round-off), then the run
 * checks of an output (range of the bar models, singular position; closure_max). The steps and
 * so the results do not depend on the output times. Returns 0; _FAILED (a failed step: y_out
 * untouched; a failed check: y_out holds the state that failed it and s->t_dense = t_out);
 * _BAD_ARGUMENT (t_out before the last step or after t_stop); _PAUSED (s->step_limit reached:
 * call again with the same arguments).
 */
SYMGEN_API int symgen_solver_dense(symgen_solver *s, double t_out, double t_stop, double *y_out);

/*
 * The rows of a run on the grid tau_i = t0 + i step, i = *done .. n_rows - 1 (t0 = the start
 * time, the last row the stop time), by symgen_solver_dense, at most max_rows of them (<= 0:
 * all): row i at rec + (i - first) * stride, first = *done at the call, stride = 1 + nout + 2 n
 * + m: tau, the outputs, q, v, lam. *done counts the rows written (a row whose check failed is
 * written, as symgen simulate keeps it). max_steps > 0: pause (_PAUSED) after that many more
 * steps; call again to go on. Returns 0 when max_rows or all rows are written, or
 * symgen_solver_dense's code.
 */
SYMGEN_API int symgen_solver_rows(symgen_solver *s, double t0, double step, long n_rows, long *done, long max_rows,
                                  long max_steps, double *rec);

/*
 * The range record of the rows written so far by symgen_solver_rows (the sidecar's `range`, as
 * symgen.numerics.checks.range_record makes it from the rows' q): per amplitude check g (one per
 * bar, the model's order), SYMGEN_RANGE_FIELDS doubles at out + g * SYMGEN_RANGE_FIELDS: the
 * largest slope |eta'| and its tau (the first row of the largest, a NaN slope counting as none),
 * the first tau and slope where the slope passed s->range_warning (!(slope <= warning)), the
 * largest stretch ||r'| - 1| and its tau; NaN taus: no such row. Returns the number of checks.
 * symgen_solver_init sets range_warning to the policy's slope_limit; symgen_solver_range_warning
 * sets it (after symgen_solver_init, before the first row).
 */
#define SYMGEN_RANGE_FIELDS 6
SYMGEN_API int symgen_solver_range(const symgen_solver *s, double *out);
SYMGEN_API void symgen_solver_range_warning(symgen_solver *s, double slope);

/* The q, v, a, lam of the solver vector y of a model (any pointer may be NULL); a quasi-static
   amplitude's v and a are 0. */
SYMGEN_API void symgen_model_state(const symgen_model *model, const double *y, double *q, double *v, double *a,
                                   double *lam);

/* The model's outputs at tau = t, y, parameters p; q, v, a: n doubles of scratch. */
SYMGEN_API void symgen_model_outputs(const symgen_model *model, double t, const double *y, const double *p, double *q,
                                     double *v, double *a, double *out);

/* The run's outputs at tau = t, y (those of symgen_solver_rows): the model's, but at the start
   of a run from an unstressed state (t = s->t_start, s->continuum_start), where the model's
   start_forces (driver torques, reactions) are the continuum's (s->start_out). */
SYMGEN_API void symgen_solver_outputs(symgen_solver *s, double t, const double *y, double *out);

/* ------------------------------------------------------------------ dense linear algebra */
/* LU with partial pivoting of the row-major n x n matrix A; 0, or k + 1 at a zero pivot k */
SYMGEN_API int symgen_lu(double *A, int n, int *piv);
SYMGEN_API void symgen_lu_solve(const double *A, int n, const int *piv, double *b);
/* the same for a complex matrix held as real and imaginary parts */
SYMGEN_API int symgen_clu(double *ar, double *ai, int n, int *piv);
SYMGEN_API void symgen_clu_solve(const double *ar, const double *ai, int n, const int *piv, double *br, double *bi);
/* ------------------------------------------------------------------ sparse LU */
/* The sparse LU of an n x n matrix held in dense row-major storage (symgen_splu): see
   symgen_splu above the solver. */
/* Factor A in place choosing the pivots (Markowitz, threshold u in (0, 1]; the pattern: A's
   nonzeros) and record them in f: 0, or k + 1 when no entry of the active columns qualifies */
SYMGEN_API int symgen_splu_analyze(symgen_splu *f, double *A, double u);
/* 1 when every nonzero of A (n x n, row-major) and its first nd diagonal entries lie on the
   pattern f's analysis recorded (A's nonzeros and the fill-in of its pivot sequence), else 0:
   a matrix it covers is factored exactly by f's pivots (symgen_splu_refactor): the pattern
   holds every entry the elimination reads or writes; an entry outside it would be dropped */
SYMGEN_API int symgen_splu_covers(const symgen_splu *f, const double *A, int nd);
/* A := alpha src on the pattern of f (fill-in positions included: src is 0 there) */
SYMGEN_API void symgen_splu_gather(const symgen_splu *f, const double *src, double alpha, double *A);
/* Factor A (values on f's pattern) in place with f's pivots: 0, or k + 1 when pivot k is zero,
   not finite or below tol times the largest entry of its column of L */
SYMGEN_API int symgen_splu_refactor(const symgen_splu *f, double *A, double tol);
/* The factors of the factored A packed in the order the solves read them: val [n * n + n]
   (L and U along idx, the pivots after n * n): contiguous, where A's columns are strided */
SYMGEN_API void symgen_splu_pack(const symgen_splu *f, const double *A, double *val);
/* x := A^-1 b from the packed factors (b by rows, overwritten; x by columns) */
SYMGEN_API void symgen_splu_solve(const symgen_splu *f, const double *val, double *b, double *x);
/* the same for a complex matrix held as real and imaginary parts (packed: both parts) */
SYMGEN_API int symgen_splu_crefactor(const symgen_splu *f, double *ar, double *ai, double tol);
SYMGEN_API void symgen_splu_csolve(const symgen_splu *f, const double *vr, const double *vi, double *br, double *bi,
                                   double *xr, double *xi);
/* max |x_i| (a NaN propagates) */
SYMGEN_API double symgen_max_abs(const double *x, int n);
/* the eigenvalues wr + i wi of the general real n x n matrix a (row-major, overwritten; u: n
   doubles of work) by balancing, Hessenberg reduction and Francis double-shift QR: 0, or 1 if
   they did not converge */
SYMGEN_API int symgen_eigenvalues(double *a, int n, double *u, double *wr, double *wi);
/* smallest / largest singular value of the n x n matrix a (row-major, overwritten) by one-sided
   Jacobi rotations; 1 for n = 0 */
SYMGEN_API double symgen_singular_ratio(double *a, int n);

#ifdef __cplusplus
}
#endif

#endif /* SYMGEN_RUNTIME_H */
