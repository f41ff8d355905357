/*
 * symgen C runtime: dense linear algebra (plain C99 + libm; see symgen_runtime.h).
 * LU with partial pivoting, real and complex; sparse LU (Markowitz pivots kept for matrices of
 * one pattern), real and complex; the eigenvalues of a general real matrix; the
 * ratio of the extreme singular values of a square matrix.
 */
#include <float.h>
#include <math.h>

#include "symgen_runtime.h"

/* ------------------------------------------------------------------ LU */
/* LU with partial pivoting of the row-major n x n matrix A; 0, or k + 1 at a zero pivot k */
SYMGEN_API int symgen_lu(double *A, int n, int *piv)
{
    int i, j, k;
    for (k = 0; k < n; ++k) {
        int pr = k;
        double best = fabs(A[k * n + k]);
        for (i = k + 1; i < n; ++i) {
            if (fabs(A[i * n + k]) > best) { best = fabs(A[i * n + k]); pr = i; }
        }
        piv[k] = pr;
        if (!(best > 0.0)) return k + 1;
        if (pr != k) {
            for (j = 0; j < n; ++j) { double tmp = A[k * n + j]; A[k * n + j] = A[pr * n + j]; A[pr * n + j] = tmp; }
        }
        for (i = k + 1; i < n; ++i) {
            double l = A[i * n + k] / A[k * n + k];
            A[i * n + k] = l;
            if (l != 0.0) {
                for (j = k + 1; j < n; ++j) A[i * n + j] -= l * A[k * n + j];
            }
        }
    }
    return 0;
}

SYMGEN_API void symgen_lu_solve(const double *A, int n, const int *piv, double *b)
{
    int i, j;
    for (i = 0; i < n; ++i) {
        if (piv[i] != i) { double tmp = b[i]; b[i] = b[piv[i]]; b[piv[i]] = tmp; }
    }
    for (i = 1; i < n; ++i) {
        double sum = b[i];
        for (j = 0; j < i; ++j) sum -= A[i * n + j] * b[j];
        b[i] = sum;
    }
    for (i = n - 1; i >= 0; --i) {
        double sum = b[i];
        for (j = i + 1; j < n; ++j) sum -= A[i * n + j] * b[j];
        b[i] = sum / A[i * n + i];
    }
}

/* the same for a complex matrix held as real and imaginary parts */
SYMGEN_API int symgen_clu(double *ar, double *ai, int n, int *piv)
{
    int i, j, k;
    for (k = 0; k < n; ++k) {
        int pr = k;
        double best = fabs(ar[k * n + k]) + fabs(ai[k * n + k]);
        double dr, di, den;
        for (i = k + 1; i < n; ++i) {
            double mag = fabs(ar[i * n + k]) + fabs(ai[i * n + k]);
            if (mag > best) { best = mag; pr = i; }
        }
        piv[k] = pr;
        if (!(best > 0.0)) return k + 1;
        if (pr != k) {
            for (j = 0; j < n; ++j) {
                double tr = ar[k * n + j], ti = ai[k * n + j];
                ar[k * n + j] = ar[pr * n + j]; ai[k * n + j] = ai[pr * n + j];
                ar[pr * n + j] = tr; ai[pr * n + j] = ti;
            }
        }
        den = ar[k * n + k] * ar[k * n + k] + ai[k * n + k] * ai[k * n + k];
        dr = ar[k * n + k] / den;        /* 1 / pivot */
        di = -ai[k * n + k] / den;
        for (i = k + 1; i < n; ++i) {
            double xr = ar[i * n + k], xi = ai[i * n + k];
            double lr = xr * dr - xi * di, li = xr * di + xi * dr;
            ar[i * n + k] = lr; ai[i * n + k] = li;
            if (lr != 0.0 || li != 0.0) {
                for (j = k + 1; j < n; ++j) {
                    double ur = ar[k * n + j], ui = ai[k * n + j];
                    ar[i * n + j] -= lr * ur - li * ui;
                    ai[i * n + j] -= lr * ui + li * ur;
                }
            }
        }
    }
    return 0;
}

SYMGEN_API void symgen_clu_solve(const double *ar, const double *ai, int n, const int *piv, double *br, double *bi)
{
    int i, j;
    for (i = 0; i < n; ++i) {
        if (piv[i] != i) {
            double tr = br[i], ti = bi[i];
            br[i] = br[piv[i]]; bi[i] = bi[piv[i]]; br[piv[i]] = tr; bi[piv[i]] = ti;
        }
    }
    for (i = 1; i < n; ++i) {
        double sr = br[i], si = bi[i];
        for (j = 0; j < i; ++j) {
            sr -= ar[i * n + j] * br[j] - ai[i * n + j] * bi[j];
            si -= ar[i * n + j] * bi[j] + ai[i * n + j] * br[j];
        }
        br[i] = sr; bi[i] = si;
    }
    for (i = n - 1; i >= 0; --i) {
        double sr = br[i], si = bi[i], dr, di, den;
        for (j = i + 1; j < n; ++j) {
            sr -= ar[i * n + j] * br[j] - ai[i * n + j] * bi[j];
            si -= ar[i * n + j] * bi[j] + ai[i * n + j] * br[j];
        }
        dr = ar[i * n + i]; di = ai[i * n + i];
        den = dr * dr + di * di;
        br[i] = (sr * dr + si * di) / den;
        bi[i] = (si * dr - sr * di) / den;
    }
}

/* ------------------------------------------------------------------ sparse LU */
/* Sparse LU of an n x n matrix held in dense row-major storage (symgen_splu in symgen_runtime.h).
   The pivots are chosen once (symgen_splu_analyze: Markowitz's criterion, the fewest fill-in,
   among the entries of at least `u` times the largest of their column) and their sequence and
   the factors' pattern kept: a matrix of the same pattern is factored again (symgen_splu_refactor)
   visiting the pattern only, as long as each kept pivot stays at least `tol` times the largest
   entry below it. Step k pivots on (prow[k], pcol[k]); its column's other rows (L) and its row's
   other columns (U) are idx[lptr[k] .. uptr[k]) and idx[uptr[k] .. lptr[k + 1]). */

/* the columns Markowitz's search examines at each step (those with the fewest entries): on a
   12-bar chain's Newton matrix (253 x 253, 5396 entries) 4 give 7054 entries of L + U, 16 give
   6374, all 5969 (SuperLU with COLAMD: 10440) */
#define SYMGEN_SPLU_CANDIDATES 16

/* the elimination of step k (multipliers stored in the pivot's column) */
static void symgen_splu_eliminate_(const symgen_splu *f, double *A, int k)
{
    const int n = f->n, pr = f->prow[k], pc = f->pcol[k];
    const double piv = A[pr * n + pc];
    int a, b;
    for (a = f->lptr[k]; a < f->uptr[k]; ++a) {
        const int i = f->idx[a];
        const double l = A[i * n + pc] / piv;
        A[i * n + pc] = l;
        if (l != 0.0) {
            for (b = f->uptr[k]; b < f->lptr[k + 1]; ++b) A[i * n + f->idx[b]] -= l * A[pr * n + f->idx[b]];
        }
    }
}

SYMGEN_API int symgen_splu_analyze(symgen_splu *f, double *A, double u)
{
    const int n = f->n;
    int i, j, k, c, top = 0;
    f->flops = 0;
    for (i = 0; i < n; ++i) { f->rcount[i] = 0; f->ccount[i] = 0; }
    for (i = 0; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            f->mark[i * n + j] = A[i * n + j] != 0.0;
            if (f->mark[i * n + j]) { f->rcount[i]++; f->ccount[j]++; }
        }
    }
    for (k = 0; k < n; ++k) {
        int cand[SYMGEN_SPLU_CANDIDATES], pr = -1, pc = -1;
        long best = -1;
        double best_ratio = 0.0;
        /* the (up to) SYMGEN_SPLU_CANDIDATES active columns with the fewest entries */
        for (c = 0; c < SYMGEN_SPLU_CANDIDATES; ++c) cand[c] = -1;
        for (j = 0; j < n; ++j) {
            if (f->ccount[j] < 0) continue;                   /* pivoted */
            for (c = 0; c < SYMGEN_SPLU_CANDIDATES; ++c) {
                if (cand[c] < 0 || f->ccount[j] < f->ccount[cand[c]]) {
                    int m;
                    for (m = SYMGEN_SPLU_CANDIDATES - 1; m > c; --m) cand[m] = cand[m - 1];
                    cand[c] = j;
                    break;
                }
            }
        }
        for (c = 0; c < SYMGEN_SPLU_CANDIDATES && cand[c] >= 0; ++c) {
            double colmax = 0.0;
            j = cand[c];
            for (i = 0; i < n; ++i) {
                if (f->rcount[i] >= 0 && f->mark[i * n + j] && fabs(A[i * n + j]) > colmax) colmax = fabs(A[i * n + j]);
            }
            if (!(colmax > 0.0)) continue;
            for (i = 0; i < n; ++i) {
                if (f->rcount[i] >= 0 && f->mark[i * n + j] && fabs(A[i * n + j]) >= u * colmax) {
                    const long cost = (long)(f->rcount[i] - 1) * (long)(f->ccount[j] - 1);
                    const double ratio = fabs(A[i * n + j]) / colmax;
                    if (best < 0 || cost < best || (cost == best && ratio > best_ratio)) {
                        best = cost; best_ratio = ratio; pr = i; pc = j;
                    }
                }
            }
        }
        if (pr < 0) return k + 1;                              /* no acceptable pivot: singular */
        f->prow[k] = pr;
        f->pcol[k] = pc;
        f->lptr[k] = top;
        for (i = 0; i < n; ++i) {
            if (i != pr && f->rcount[i] >= 0 && f->mark[i * n + pc]) f->idx[top++] = i;
        }
        f->uptr[k] = top;
        for (j = 0; j < n; ++j) {
            if (j != pc && f->ccount[j] >= 0 && f->mark[pr * n + j]) f->idx[top++] = j;
        }
        f->lptr[k + 1] = top;
        f->flops += (long)(f->uptr[k] - f->lptr[k]) * (long)(f->lptr[k + 1] - f->uptr[k]);
        /* the fill-in, the active counts without the pivot's row and column */
        for (c = f->lptr[k]; c < f->uptr[k]; ++c) {
            const int r = f->idx[c];
            int b;
            for (b = f->uptr[k]; b < f->lptr[k + 1]; ++b) {
                const int col = f->idx[b];
                if (!f->mark[r * n + col]) { f->mark[r * n + col] = 1; f->rcount[r]++; f->ccount[col]++; }
            }
            f->rcount[r]--;
        }
        for (c = f->uptr[k]; c < f->lptr[k + 1]; ++c) f->ccount[f->idx[c]]--;
        f->rcount[pr] = -1;
        f->ccount[pc] = -1;
        symgen_splu_eliminate_(f, A, k);
    }
    f->nnz = top + n;
    return 0;
}

SYMGEN_API int symgen_splu_covers(const symgen_splu *f, const double *A, int nd)
{
    const int n = f->n;
    int i, j;
    for (i = 0; i < n; ++i) {
        if (i < nd && !f->mark[i * n + i]) return 0;
        for (j = 0; j < n; ++j) {
            if (A[i * n + j] != 0.0 && !f->mark[i * n + j]) return 0;
        }
    }
    return 1;
}

SYMGEN_API void symgen_splu_gather(const symgen_splu *f, const double *src, double alpha, double *A)
{
    const int n = f->n;
    int k, a;
    for (k = 0; k < n; ++k) {
        const int pr = f->prow[k], pc = f->pcol[k];
        A[pr * n + pc] = alpha * src[pr * n + pc];
        for (a = f->lptr[k]; a < f->uptr[k]; ++a) A[f->idx[a] * n + pc] = alpha * src[f->idx[a] * n + pc];
        for (a = f->uptr[k]; a < f->lptr[k + 1]; ++a) A[pr * n + f->idx[a]] = alpha * src[pr * n + f->idx[a]];
    }
}

SYMGEN_API int symgen_splu_refactor(const symgen_splu *f, double *A, double tol)
{
    const int n = f->n;
    int k, a;
    for (k = 0; k < n; ++k) {
        const int pc = f->pcol[k];
        const double piv = fabs(A[f->prow[k] * n + pc]);
        double colmax = 0.0;
        for (a = f->lptr[k]; a < f->uptr[k]; ++a) {
            if (fabs(A[f->idx[a] * n + pc]) > colmax) colmax = fabs(A[f->idx[a] * n + pc]);
        }
        if (!(piv > 0.0 && piv >= tol * colmax && piv <= DBL_MAX)) return k + 1;
        symgen_splu_eliminate_(f, A, k);
    }
    return 0;
}

SYMGEN_API void symgen_splu_pack(const symgen_splu *f, const double *A, double *val)
{
    const int n = f->n;
    int k, a;
    for (k = 0; k < n; ++k) {
        const int pr = f->prow[k], pc = f->pcol[k];
        for (a = f->lptr[k]; a < f->uptr[k]; ++a) val[a] = A[f->idx[a] * n + pc];
        for (a = f->uptr[k]; a < f->lptr[k + 1]; ++a) val[a] = A[pr * n + f->idx[a]];
        val[n * n + k] = A[pr * n + pc];
    }
}

SYMGEN_API void symgen_splu_solve(const symgen_splu *f, const double *val, double *b, double *x)
{
    const int n = f->n;
    const double *diag = val + n * n;
    int k, a;
    for (k = 0; k < n; ++k) {
        const double bk = b[f->prow[k]];
        if (bk != 0.0) {
            for (a = f->lptr[k]; a < f->uptr[k]; ++a) b[f->idx[a]] -= val[a] * bk;
        }
    }
    for (k = n - 1; k >= 0; --k) {
        double sum = b[f->prow[k]];
        for (a = f->uptr[k]; a < f->lptr[k + 1]; ++a) sum -= val[a] * x[f->idx[a]];
        x[f->pcol[k]] = sum / diag[k];
    }
}

SYMGEN_API int symgen_splu_crefactor(const symgen_splu *f, double *ar, double *ai, double tol)
{
    const int n = f->n;
    int k, a, b;
    for (k = 0; k < n; ++k) {
        const int pr = f->prow[k], pc = f->pcol[k];
        /* magnitudes compared squared (no hypot: a sixth of a factorization's time); the
           Newton matrices' entries are far below the 1e154 where a square overflows */
        const double pvr = ar[pr * n + pc], pvi = ai[pr * n + pc], den = pvr * pvr + pvi * pvi;
        double colmax2 = 0.0, dr, di;
        for (a = f->lptr[k]; a < f->uptr[k]; ++a) {
            const double xr = ar[f->idx[a] * n + pc], xi = ai[f->idx[a] * n + pc], m2 = xr * xr + xi * xi;
            if (m2 > colmax2) colmax2 = m2;
        }
        if (!(den > 0.0 && den >= tol * tol * colmax2 && den <= DBL_MAX)) return k + 1;
        dr = pvr / den;                  /* 1 / pivot */
        di = -pvi / den;
        for (a = f->lptr[k]; a < f->uptr[k]; ++a) {
            const int i = f->idx[a];
            const double xr = ar[i * n + pc], xi = ai[i * n + pc];
            const double lr = xr * dr - xi * di, li = xr * di + xi * dr;
            ar[i * n + pc] = lr;
            ai[i * n + pc] = li;
            if (lr != 0.0 || li != 0.0) {
                for (b = f->uptr[k]; b < f->lptr[k + 1]; ++b) {
                    const int j = f->idx[b];
                    const double ur = ar[pr * n + j], ui = ai[pr * n + j];
                    ar[i * n + j] -= lr * ur - li * ui;
                    ai[i * n + j] -= lr * ui + li * ur;
                }
            }
        }
    }
    return 0;
}

SYMGEN_API void symgen_splu_csolve(const symgen_splu *f, const double *vr, const double *vi, double *br, double *bi,
                                   double *xr, double *xi)
{
    const int n = f->n;
    const double *dgr = vr + n * n, *dgi = vi + n * n;
    int k, a;
    for (k = 0; k < n; ++k) {
        const double tr = br[f->prow[k]], ti = bi[f->prow[k]];
        if (tr != 0.0 || ti != 0.0) {
            for (a = f->lptr[k]; a < f->uptr[k]; ++a) {
                const int i = f->idx[a];
                br[i] -= vr[a] * tr - vi[a] * ti;
                bi[i] -= vr[a] * ti + vi[a] * tr;
            }
        }
    }
    for (k = n - 1; k >= 0; --k) {
        double sr = br[f->prow[k]], si = bi[f->prow[k]], dr, di, den;
        for (a = f->uptr[k]; a < f->lptr[k + 1]; ++a) {
            const int j = f->idx[a];
            sr -= vr[a] * xr[j] - vi[a] * xi[j];
            si -= vr[a] * xi[j] + vi[a] * xr[j];
        }
        dr = dgr[k]; di = dgi[k];
        den = dr * dr + di * di;
        xr[f->pcol[k]] = (sr * dr + si * di) / den;
        xi[f->pcol[k]] = (si * dr - sr * di) / den;
    }
}

SYMGEN_API double symgen_max_abs(const double *x, int n)
{
    double m = 0.0;
    int i;
    for (i = 0; i < n; ++i) {
        if (!(fabs(x[i]) <= m)) m = fabs(x[i]);     /* NaN propagates */
    }
    return m;
}

/* ------------------------------------------------------------------ eigenvalues of a real matrix */
/* The eigenvalues of a general real n x n matrix, for the divergence check of the quasi-static
   start: balancing, Householder reduction to upper Hessenberg form and Francis double-shift QR
   iterations; the algorithm of EISPACK's balanc, orthes and hqr (Wilkinson & Reinsch, Handbook
   for Automatic Computation II, 1971; Golub & Van Loan, Matrix Computations, 7.4-7.5), eigenvalues
   only: no Schur vectors are accumulated. Row-major, the matrix is overwritten. */

/* a := D^-1 a D, D diagonal with powers of 2 (exact): the row and column of an index are scaled
   while that cuts the sum of their off-diagonal norms by 5 %, until no index changes. The
   eigenvalues do not change; their round-off then scales with the balanced norm, not with the
   raw one (stiff axial rows of size lambda next to unit rows) */
static void symgen_balance_(double *a, int n)
{
    int i, j, done = 0;
    while (!done) {
        done = 1;
        for (i = 0; i < n; ++i) {
            double c = 0.0, r = 0.0, f = 1.0, sum;
            for (j = 0; j < n; ++j) {
                if (j == i) continue;
                c += fabs(a[j * n + i]);
                r += fabs(a[i * n + j]);
            }
            if (c == 0.0 || r == 0.0) continue;
            sum = c + r;
            /* f = 2^k with c f^2 within [r / 2, 2 r); c tracks c f^2 */
            while (c < 0.5 * r) { f *= 2.0; c *= 4.0; }
            while (c >= 2.0 * r) { f *= 0.5; c *= 0.25; }
            if ((c + r) / f < 0.95 * sum) {     /* the sums shrink enough: scale row i by 1/f, column i by f */
                done = 0;
                for (j = 0; j < n; ++j) a[i * n + j] /= f;
                for (j = 0; j < n; ++j) a[j * n + i] *= f;
            }
        }
    }
}

/* a := P^T a P upper Hessenberg, P a product of n - 2 Householder reflections (u: n doubles of
   work): step k reflects rows and columns k+1.. so that column k is zero below its subdiagonal */
static void symgen_hessenberg_(double *a, int n, double *u)
{
    int i, j, k;
    for (k = 0; k + 2 < n; ++k) {
        double scale = 0.0, h = 0.0, g, f;
        for (i = k + 1; i < n; ++i) scale += fabs(a[i * n + k]);
        if (scale == 0.0) continue;                 /* already zero below the subdiagonal */
        for (i = k + 1; i < n; ++i) {
            u[i] = a[i * n + k] / scale;
            h += u[i] * u[i];
        }
        g = u[k + 1] > 0.0 ? -sqrt(h) : sqrt(h);    /* the new subdiagonal (/ scale), sign against cancellation */
        h -= u[k + 1] * g;                          /* |u|^2 / 2 once u[k+1] -= g: P = I - u u^T / h */
        u[k + 1] -= g;
        for (j = k + 1; j < n; ++j) {               /* a := P a (columns k+1..) */
            f = 0.0;
            for (i = k + 1; i < n; ++i) f += u[i] * a[i * n + j];
            f /= h;
            for (i = k + 1; i < n; ++i) a[i * n + j] -= f * u[i];
        }
        for (i = 0; i < n; ++i) {                   /* a := a P */
            f = 0.0;
            for (j = k + 1; j < n; ++j) f += a[i * n + j] * u[j];
            f /= h;
            for (j = k + 1; j < n; ++j) a[i * n + j] -= f * u[j];
        }
        a[(k + 1) * n + k] = scale * g;             /* column k: P maps it to (.., scale g, 0, ..) */
        for (i = k + 2; i < n; ++i) a[i * n + k] = 0.0;
    }
}

/* eigenvalues wr + i wi of the upper Hessenberg a (destroyed) by Francis double-shift QR: the
   active block is rows / columns l..nn; a negligible subdiagonal entry splits it; a converged
   1 x 1 or 2 x 2 block at its bottom gives one real eigenvalue or a pair and is deflated.
   Each step applies (H - s1 I)(H - s2 I), s1 and s2 the eigenvalues of the trailing 2 x 2 block
   (real arithmetic: only their sum x + y and product x y - w enter), implicitly: a 3 x 3
   reflection from its first column starts a bulge that 3 x 3 reflections chase down the
   subdiagonal. 0, or 1 if 30 n steps did not find every eigenvalue. */
#define SYMGEN_H_(i, j) a[(i) * n + (j)]
static int symgen_hqr_(double *a, int n, double *wr, double *wi)
{
    int nn = n - 1, its = 0, steps = 0, i, j, k, l, m;
    double norm = 0.0, shift = 0.0, p = 0.0, q = 0.0, r = 0.0, s, w, x, y, z;
    for (i = 0; i < n; ++i) {
        for (j = i > 0 ? i - 1 : 0; j < n; ++j) norm += fabs(SYMGEN_H_(i, j));
    }
    while (nn >= 0) {
        /* l: the top of the active block (the lowest negligible subdiagonal entry is set to 0) */
        for (l = nn; l > 0; --l) {
            s = fabs(SYMGEN_H_(l - 1, l - 1)) + fabs(SYMGEN_H_(l, l));
            if (s == 0.0) s = norm;
            if (fabs(SYMGEN_H_(l, l - 1)) <= DBL_EPSILON * s) { SYMGEN_H_(l, l - 1) = 0.0; break; }
        }
        x = SYMGEN_H_(nn, nn);
        if (l == nn) {                              /* 1 x 1: a real eigenvalue */
            wr[nn] = x + shift;
            wi[nn] = 0.0;
            nn -= 1;
            its = 0;
            continue;
        }
        y = SYMGEN_H_(nn - 1, nn - 1);
        w = SYMGEN_H_(nn, nn - 1) * SYMGEN_H_(nn - 1, nn);
        if (l == nn - 1) {                          /* 2 x 2 [[y, .], [., x]]: x + p +- sqrt(p^2 + w) */
            p = 0.5 * (y - x);
            q = p * p + w;
            z = sqrt(fabs(q));
            x += shift;
            if (q >= 0.0) {                         /* a real pair; the smaller from the product (no cancellation) */
                z = p + (p >= 0.0 ? z : -z);
                wr[nn - 1] = wr[nn] = x + z;
                if (z != 0.0) wr[nn] = x - w / z;
                wi[nn - 1] = wi[nn] = 0.0;
            } else {                                /* a complex pair */
                wr[nn - 1] = wr[nn] = x + p;
                wi[nn - 1] = z;
                wi[nn] = -z;
            }
            nn -= 2;
            its = 0;
            continue;
        }
        if (steps >= 30 * n) return 1;
        if (its == 10 || its == 20) {               /* exceptional shift: a stalled block is shaken loose */
            shift += x;
            for (i = 0; i <= nn; ++i) SYMGEN_H_(i, i) -= x;
            s = fabs(SYMGEN_H_(nn, nn - 1)) + fabs(SYMGEN_H_(nn - 1, nn - 2));
            x = y = 0.75 * s;
            w = -0.4375 * s * s;
        }
        ++its;
        ++steps;
        /* m: where the step starts, the largest m >= l at which H(m, m-1) is negligible against
           (p, q, r), the first column of (H - s1 I)(H - s2 I) on rows m.. (else l) */
        for (m = nn - 2; m >= l; --m) {
            z = SYMGEN_H_(m, m);
            r = x - z;
            s = y - z;
            p = (r * s - w) / SYMGEN_H_(m + 1, m) + SYMGEN_H_(m, m + 1);
            q = SYMGEN_H_(m + 1, m + 1) - z - r - s;
            r = SYMGEN_H_(m + 2, m + 1);
            s = fabs(p) + fabs(q) + fabs(r);
            p /= s;
            q /= s;
            r /= s;
            if (m == l) break;
            if (fabs(SYMGEN_H_(m, m - 1)) * (fabs(q) + fabs(r))
                <= DBL_EPSILON * fabs(p) * (fabs(SYMGEN_H_(m - 1, m - 1)) + fabs(z) + fabs(SYMGEN_H_(m + 1, m + 1)))) break;
        }
        for (i = m + 2; i <= nn; ++i) {             /* clear what the bulge will fill */
            SYMGEN_H_(i, i - 2) = 0.0;
            if (i != m + 2) SYMGEN_H_(i, i - 3) = 0.0;
        }
        /* the double step: reflections I - v v^T / v1 on rows / columns k, k+1, k+2 (k+1 at the
           bottom), v = (1, y, z) / x scaled, chase the bulge from row m to nn */
        for (k = m; k < nn; ++k) {
            const int last = k == nn - 1;
            if (k != m) {
                p = SYMGEN_H_(k, k - 1);
                q = SYMGEN_H_(k + 1, k - 1);
                r = last ? 0.0 : SYMGEN_H_(k + 2, k - 1);
                x = fabs(p) + fabs(q) + fabs(r);
                if (x == 0.0) continue;             /* nothing to chase here */
                p /= x;
                q /= x;
                r /= x;
            }
            s = sqrt(p * p + q * q + r * r);
            if (p < 0.0) s = -s;
            if (k == m) {
                if (l != m) SYMGEN_H_(k, k - 1) = -SYMGEN_H_(k, k - 1);
            } else {
                SYMGEN_H_(k, k - 1) = -s * x;
            }
            p += s;
            x = p / s;
            y = q / s;
            z = r / s;
            q /= p;
            r /= p;
            for (j = k; j <= nn; ++j) {             /* rows k, k+1, k+2 of the active block */
                p = SYMGEN_H_(k, j) + q * SYMGEN_H_(k + 1, j);
                if (!last) {
                    p += r * SYMGEN_H_(k + 2, j);
                    SYMGEN_H_(k + 2, j) -= p * z;
                }
                SYMGEN_H_(k + 1, j) -= p * y;
                SYMGEN_H_(k, j) -= p * x;
            }
            for (i = l; i <= (nn < k + 3 ? nn : k + 3); ++i) {   /* columns k, k+1, k+2 */
                p = x * SYMGEN_H_(i, k) + y * SYMGEN_H_(i, k + 1);
                if (!last) {
                    p += z * SYMGEN_H_(i, k + 2);
                    SYMGEN_H_(i, k + 2) -= p * r;
                }
                SYMGEN_H_(i, k + 1) -= p * q;
                SYMGEN_H_(i, k) -= p;
            }
        }
    }
    return 0;
}
#undef SYMGEN_H_


SYMGEN_API int symgen_eigenvalues(double *a, int n, double *u, double *wr, double *wi)
{
    symgen_balance_(a, n);
    symgen_hessenberg_(a, n, u);
    return symgen_hqr_(a, n, wr, wi);
}

/* ------------------------------------------------------------------ singular values */
/* smallest / largest singular value of a (the distance of the closure Jacobian to a singular
   position: Mechanism.singular_ratio, the same measure), by one-sided Jacobi rotations of the
   columns (Hestenes; n is small): the columns become orthogonal, their norms the singular values */
SYMGEN_API double symgen_singular_ratio(double *a, int n)
{
    double lo = HUGE_VAL, hi = 0.0;
    int r, j, k, sweep;
    if (n == 0) return 1.0;
    for (sweep = 0; sweep < 60; ++sweep) {
        int rotated = 0;
        for (j = 0; j < n - 1; ++j) {
            for (k = j + 1; k < n; ++k) {
                double alpha = 0.0, beta = 0.0, gamma = 0.0, zeta, tn, c, sn;
                for (r = 0; r < n; ++r) {
                    const double x = a[r * n + j], y = a[r * n + k];
                    alpha += x * x;
                    beta += y * y;
                    gamma += x * y;
                }
                if (!(fabs(gamma) > DBL_EPSILON * sqrt(alpha * beta))) continue;
                rotated = 1;
                zeta = (beta - alpha) / (2.0 * gamma);
                tn = fabs(zeta) > 1e150 ? 0.5 / zeta
                     : (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                c = 1.0 / sqrt(1.0 + tn * tn);
                sn = c * tn;
                for (r = 0; r < n; ++r) {
                    const double x = a[r * n + j], y = a[r * n + k];
                    a[r * n + j] = c * x - sn * y;
                    a[r * n + k] = sn * x + c * y;
                }
            }
        }
        if (!rotated) break;
    }
    for (k = 0; k < n; ++k) {
        double d = 0.0;
        for (r = 0; r < n; ++r) d += a[r * n + k] * a[r * n + k];
        d = sqrt(d);
        if (d < lo) lo = d;
        if (d > hi) hi = d;
    }
    return hi > 0.0 ? lo / hi : 0.0;
}
