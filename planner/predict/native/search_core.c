/*
 * Native core of the exact pruned search (planner/predict/search.py, docs/scaling.md).
 *
 * The depth-first branch-and-bound over partial mode assignments and the pruning LP of every
 * node, in C: the same tree rules as planner.predict.search._expand (FREE -> B | CONTACT,
 * CONTACT -> S+ | S- | R, the branching rule of search_tree.branch_contact, subtree sizes of
 * eq. (49), leaves at <= batch_size candidates) and the same LP relaxation, built by
 * planner.predict.prune_lp.Pruner (row/column bounds per contact state).  The LP is solved by a
 * small dense dual simplex that restarts every node from its parent's basis; a node is pruned
 * only when the dual simplex ends with a Farkas certificate that this file re-checks against
 * the constraint data (residual and bound gap, below), never on an iteration limit or a
 * numerical failure -- those keep the node, as an LP without a verdict does in the Python
 * search.  Leaves are handed back to Python, which tests their candidates with the unchanged
 * batched stages (planner.predict.stages), so the modes are those of exhaustive enumeration.
 *
 * LP form.  Variables x (n); row activities r = A x (m); every row and column has bounds
 * [lo, hi] (either may be infinite).  An "item" is a row (0..m-1) or a column (m..m+n-1).  A
 * basis is a set T of n tight items whose constraint rows M (A rows or unit rows) are
 * independent; x = M^{-1} bT with bT the tight values.  Column t of Minv = M^{-1} is the change
 * of x when item T[t]'s value changes by one.  A tight item sits at its lower bound (LO), its
 * upper bound (HI), both (FIX), or -- a column without bounds, or an item whose bound became
 * infinite -- at any value (FREE: it may move either way).
 *
 * Dual simplex for a zero objective (every basis is dual feasible): while some basic (not
 * tight) item p violates its bounds by more than the feasibility tolerance, p must become
 * tight at the violated bound b_p; alpha = a_p Minv says how item p moves when tight item t
 * moves; t may be released if it can move in a direction that brings p towards b_p.  The
 * eligible t with the largest |alpha_t| is released (after 4 n iterations: the lowest index,
 * Bland's rule, which cannot cycle), Minv is updated by the pivot formula and refactorised by
 * Gauss-Jordan with partial pivoting every REFACTOR pivots.  No eligible t: p cannot reach
 * b_p while every tight constraint stays feasible, i.e.
 *     sigma val_p = sum_t sigma alpha_t val_t + sigma res . x <= S := sum_t max(sigma alpha_t v)
 * over each tight item's range, and S < sigma b_p: infeasible (Farkas).  The certificate is
 * accepted only if the residual res = a_p - sum_t alpha_t m_t is at rounding level and the
 * gap sigma b_p - S clears the rounding of its terms (verify_farkas).
 *
 * Trinkle & Zeng (1994), eqs. (5), (9)-(11), (16)-(17), (21)-(26), (29), (49).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define KEYS 6     /* contact states with sliding direction: B, S-, S+, R, FREE, CONTACT */
#define MAXR 8     /* rows a contact state sets */
#define REFACTOR 100
#define MAX2(a, b) ((a) > (b) ? (a) : (b))

enum { ST_BREAK = 0, ST_SLIDE = 1, ST_ROLL = 2, ST_FREE = 3, ST_CONTACT = 4 };
enum { SIDE_FREE = 0, SIDE_LO = 1, SIDE_HI = 2, SIDE_FIX = 3 };
enum { LP_FEASIBLE = 0, LP_INFEASIBLE = 1, LP_UNKNOWN = 2 };

typedef struct {
  int *T, *side;
  double *bT, *Minv, *x, *r;
  int since, valid;
} Basis;

typedef struct {
  signed char *states, *xi;
  int depth, must_solve;
} Node;

typedef struct {
  /* problem data (copies) */
  int m, n, n_c, nz, k;
  double *A, *base_lo, *base_hi;
  int *rp, *ci;             /* A in compressed rows: row i's nonzeros are ci/cv[rp[i]..rp[i+1]) */
  double *cv;
  int *tab_nrows, *tab_rows;
  double *tab_lo, *tab_hi, *tab_col;
  int *cn, *ct;
  double *mu, *sizes;
  int batch_size, lp_min_size;
  double zero_force;
  /* current bounds (items) and applied contact keys */
  double *lo, *hi;
  int *cur_key;
  /* working basis */
  Basis w;
  int *pos;                 /* item -> position in T, or -1 */
  double *alpha, *res, *Mtmp;
  /* snapshots per depth */
  Basis *snap;
  int max_depth;
  /* DFS stack */
  Node *stack;
  int n_stack, cap_stack;
  signed char *pool;        /* states/xi storage for stack nodes */
  int *cw_und, *cw_left, *cw_choice, *cw_rows;   /* completions' scratch (n_c + 1 each) */
  signed char *cw_cur;
  /* statistics */
  long long lp_solves, pivots, inherited, unknown, refactors, cold, nodes, leaves;
  double leaf_candidates;
} Ctx;

/* ---------------------------------------------------------------------------------------- */
static void *xmalloc(size_t n) { void *p = calloc(n ? n : 1, 1); return p; }

static int key_of(int state, int xi) {
  switch (state) {
    case ST_BREAK: return 0;
    case ST_SLIDE: return xi < 0 ? 1 : 2;
    case ST_ROLL: return 3;
    case ST_FREE: return 4;
    default: return 5;
  }
}

static void basis_free(Basis *b) {
  free(b->T); free(b->side); free(b->bT); free(b->Minv); free(b->x); free(b->r);
  b->T = NULL; b->side = NULL; b->bT = b->Minv = b->x = b->r = NULL;
}

static int basis_alloc(Basis *b, int m, int n) {
  b->T = xmalloc(sizeof(int) * n);
  b->side = xmalloc(sizeof(int) * n);
  b->bT = xmalloc(sizeof(double) * n);
  b->Minv = xmalloc(sizeof(double) * (size_t)n * n);
  b->x = xmalloc(sizeof(double) * n);
  b->r = xmalloc(sizeof(double) * (m ? m : 1));
  b->since = 0;
  b->valid = 0;
  if (b->T && b->side && b->bT && b->Minv && b->x && b->r) return 1;
  basis_free(b);   /* all or nothing: a half-allocated basis is never used */
  return 0;
}

static int basis_copy(Basis *dst, const Basis *src, int m, int n) {
  if (!dst->T && !basis_alloc(dst, m, n)) return 0;   /* snapshots are allocated on first use */
  memcpy(dst->T, src->T, sizeof(int) * n);
  memcpy(dst->side, src->side, sizeof(int) * n);
  memcpy(dst->bT, src->bT, sizeof(double) * n);
  memcpy(dst->Minv, src->Minv, sizeof(double) * (size_t)n * n);
  memcpy(dst->x, src->x, sizeof(double) * n);
  memcpy(dst->r, src->r, sizeof(double) * m);
  dst->since = src->since;
  dst->valid = src->valid;
  return 1;
}

/* ---------------------------------------------------------------------------------------- */
/* LP helpers */

static double item_value(const Ctx *c, int it) {
  return it < c->m ? c->w.r[it] : c->w.x[it - c->m];
}

static void activities(Ctx *c) {
  const double *x = c->w.x;
  const int *ci = c->ci;
  const double *cv = c->cv;
  for (int i = 0; i < c->m; i++) {
    /* four partial sums: the long rows (equilibrium, power) are not one dependency chain */
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int q = c->rp[i], end = c->rp[i + 1];
    for (; q + 3 < end; q += 4) {
      s0 += cv[q] * x[ci[q]];
      s1 += cv[q + 1] * x[ci[q + 1]];
      s2 += cv[q + 2] * x[ci[q + 2]];
      s3 += cv[q + 3] * x[ci[q + 3]];
    }
    for (; q < end; q++) s0 += cv[q] * x[ci[q]];
    c->w.r[i] = (s0 + s1) + (s2 + s3);
  }
}

static void solve_x(Ctx *c) {
  int n = c->n;
  double *x = c->w.x;
  for (int i = 0; i < n; i++) {
    const double *mi = c->w.Minv + (size_t)i * n;
    double s = 0.0;
    for (int t = 0; t < n; t++) s += mi[t] * c->w.bT[t];
    x[i] = s;
  }
  activities(c);
}

static void set_positions(Ctx *c) {
  for (int i = 0; i < c->m + c->n; i++) c->pos[i] = -1;
  for (int t = 0; t < c->n; t++) c->pos[c->w.T[t]] = t;
}

/* Minv = M^{-1}, M row t = constraint row of item T[t]; Gauss-Jordan, partial pivoting. */
static int refactor(Ctx *c) {
  int n = c->n, m = c->m;
  double *M = c->Mtmp, *Inv = c->w.Minv;
  for (int t = 0; t < n; t++) {
    int it = c->w.T[t];
    double *row = M + (size_t)t * n;
    if (it < m) memcpy(row, c->A + (size_t)it * n, sizeof(double) * n);
    else { memset(row, 0, sizeof(double) * n); row[it - m] = 1.0; }
  }
  memset(Inv, 0, sizeof(double) * (size_t)n * n);
  for (int i = 0; i < n; i++) Inv[(size_t)i * n + i] = 1.0;
  /* Solve M X = I by elimination on rows of [M | I]: X = M^{-1}. */
  for (int col = 0; col < n; col++) {
    int piv = -1;
    double best = 0.0;
    for (int i = col; i < n; i++) {
      double v = fabs(M[(size_t)i * n + col]);
      if (v > best) { best = v; piv = i; }
    }
    if (piv < 0 || best < 1e-13) {
      c->w.valid = 0;   /* a singular basis: nobody warm-starts from it */
      return 0;
    }
    if (piv != col) {
      for (int j = 0; j < n; j++) {
        double tmp = M[(size_t)piv * n + j]; M[(size_t)piv * n + j] = M[(size_t)col * n + j];
        M[(size_t)col * n + j] = tmp;
        tmp = Inv[(size_t)piv * n + j]; Inv[(size_t)piv * n + j] = Inv[(size_t)col * n + j];
        Inv[(size_t)col * n + j] = tmp;
      }
    }
    double d = 1.0 / M[(size_t)col * n + col];
    double *mc = M + (size_t)col * n, *ic = Inv + (size_t)col * n;
    for (int j = 0; j < n; j++) { mc[j] *= d; ic[j] *= d; }
    for (int i = 0; i < n; i++) {
      if (i == col) continue;
      double f = M[(size_t)i * n + col];
      if (f == 0.0) continue;
      double *mi = M + (size_t)i * n, *ii = Inv + (size_t)i * n;
      for (int j = 0; j < n; j++) { mi[j] -= f * mc[j]; ii[j] -= f * ic[j]; }
    }
  }
  /* the row operations E took [M | I] to [I | E]: E = M^{-1} */
  c->w.since = 0;
  c->refactors++;
  solve_x(c);
  return 1;
}

/* Cold start: every column tight (at its bound, or FREE at 0), Minv = I. */
static void cold_start(Ctx *c) {
  int n = c->n, m = c->m;
  for (int t = 0; t < n; t++) {
    int it = m + t;
    double lo = c->lo[it], hi = c->hi[it];
    c->w.T[t] = it;
    if (lo == hi) { c->w.side[t] = SIDE_FIX; c->w.bT[t] = lo; }
    else if (isfinite(lo) && lo > 0.0) { c->w.side[t] = SIDE_LO; c->w.bT[t] = lo; }
    else if (isfinite(hi) && hi < 0.0) { c->w.side[t] = SIDE_HI; c->w.bT[t] = hi; }
    else { c->w.side[t] = SIDE_FREE; c->w.bT[t] = 0.0; }
  }
  memset(c->w.Minv, 0, sizeof(double) * (size_t)n * n);
  for (int i = 0; i < n; i++) c->w.Minv[(size_t)i * n + i] = 1.0;
  c->w.since = 0;
  c->w.valid = 1;
  set_positions(c);
  solve_x(c);
  c->cold++;
}

/* Bounds of contact i in key: its table rows and its two force columns. */
static void apply_key(Ctx *c, int i, int key) {
  int base = i * KEYS + key;
  int nr = c->tab_nrows[base];
  for (int q = 0; q < nr; q++) {
    int row = c->tab_rows[base * MAXR + q];
    c->lo[row] = c->tab_lo[base * MAXR + q];
    c->hi[row] = c->tab_hi[base * MAXR + q];
  }
  int m = c->m;
  c->lo[m + c->cn[i]] = c->tab_col[base * 2];
  c->hi[m + c->cn[i]] = c->tab_col[base * 2 + 1];
  c->lo[m + c->ct[i]] = c->tab_col[base * 2];
  c->hi[m + c->ct[i]] = c->tab_col[base * 2 + 1];
  c->cur_key[i] = key;
}

static void apply_node(Ctx *c, const signed char *states, const signed char *xi) {
  for (int i = 0; i < c->n_c; i++) {
    int key = key_of(states[i], xi[i]);
    if (c->cur_key[i] != key) apply_key(c, i, key);
  }
}

/* Tight items put back on a valid bound after the bounds changed; x, r recomputed if moved. */
static void sanitize(Ctx *c) {
  int moved = 0;
  for (int t = 0; t < c->n; t++) {
    int it = c->w.T[t];
    double lo = c->lo[it], hi = c->hi[it], v = c->w.bT[t];
    int s = c->w.side[t];
    if (lo == hi) { s = SIDE_FIX; if (v != lo) { v = lo; moved = 1; } }
    else if (s == SIDE_LO) {
      if (!isfinite(lo)) s = SIDE_FREE; else if (v != lo) { v = lo; moved = 1; }
    } else if (s == SIDE_HI) {
      if (!isfinite(hi)) s = SIDE_FREE; else if (v != hi) { v = hi; moved = 1; }
    } else if (s == SIDE_FIX) {
      if (v >= lo && v <= hi) s = (v == lo) ? SIDE_LO : (v == hi) ? SIDE_HI : SIDE_FREE;
      else if (v < lo) { s = SIDE_LO; v = lo; moved = 1; }
      else { s = SIDE_HI; v = hi; moved = 1; }
    }
    if (s == SIDE_FREE) {
      if (v < lo) { s = SIDE_LO; v = lo; moved = 1; }
      else if (v > hi) { s = SIDE_HI; v = hi; moved = 1; }
    }
    c->w.side[t] = s;
    c->w.bT[t] = v;
  }
  if (moved) solve_x(c);
}

/* Largest bound violation among basic items (or the lowest-index violated one when bland);
   rows and columns in two branch-light loops (this scan runs once per pivot). */
static int leaving_item(const Ctx *c, double tol, int bland, double *viol_out) {
  int best = -1, m = c->m;
  double bv = 0.0;
  const double *lo = c->lo, *hi = c->hi, *r = c->w.r, *x = c->w.x;
  const int *pos = c->pos;
  for (int it = 0; it < m + c->n; it++) {
    double v = it < m ? r[it] : x[it - m];
    double e = MAX2(lo[it] - v, v - hi[it]);
    if (e > tol && e > bv && pos[it] < 0) {
      bv = e; best = it;
      if (bland) break;
    }
  }
  *viol_out = bv;
  return best;
}

static void compute_alpha(Ctx *c, int p) {
  int n = c->n, m = c->m;
  double *alpha = c->alpha;
  if (p >= m) {
    memcpy(alpha, c->w.Minv + (size_t)(p - m) * n, sizeof(double) * n);
    return;
  }
  memset(alpha, 0, sizeof(double) * n);
  for (int q = c->rp[p]; q < c->rp[p + 1]; q++) {
    double ai = c->cv[q];
    const double *mi = c->w.Minv + (size_t)c->ci[q] * n;
    for (int t = 0; t < n; t++) alpha[t] += ai * mi[t];
  }
}

/* Allowed moving directions of a tight item: bit 1 up, bit 2 down. */
static int directions(const Ctx *c, int t) {
  int it = c->w.T[t], s = c->w.side[t];
  double lo = c->lo[it], hi = c->hi[it], v = c->w.bT[t];
  if (s == SIDE_FIX) return 0;
  if (s == SIDE_LO) return hi > lo ? 1 : 0;
  if (s == SIDE_HI) return hi > lo ? 2 : 0;
  return (v < hi ? 1 : 0) | (v > lo ? 2 : 0);
}

/* The Farkas certificate of item p (direction sigma, target bound bp) re-checked. */
static int verify_farkas(Ctx *c, int p, double sigma, double bp, double piv_tol) {
  int n = c->n, m = c->m;
  double *res = c->res;
  if (p < m) memcpy(res, c->A + (size_t)p * n, sizeof(double) * n);
  else { memset(res, 0, sizeof(double) * n); res[p - m] = 1.0; }
  double S = 0.0, mag = fabs(bp), err = 0.0, asum = 1.0;
  for (int t = 0; t < n; t++) {
    double a = c->alpha[t];
    if (a == 0.0) continue;
    int it = c->w.T[t];
    if (it < m) {
      const double *row = c->A + (size_t)it * n;
      for (int j = 0; j < n; j++) res[j] -= a * row[j];
    } else {
      res[it - m] -= a;
    }
    asum += fabs(a);
    double sa = sigma * a, v;
    if (fabs(a) <= piv_tol) {
      /* not eligible only because tiny: count its whole range as error */
      double lo = c->lo[it], hi = c->hi[it];
      double range = fabs(c->w.bT[t]) + 1.0;
      if (isfinite(lo) && isfinite(hi)) range = MAX2(fabs(lo), fabs(hi)) + 1.0;
      err += 10.0 * fabs(a) * range;
      v = c->w.bT[t];
    } else {
      /* it cannot move the helpful way (else it was eligible): its value is its supremum */
      int d = directions(c, t);
      if ((sa > 0 && (d & 1)) || (sa < 0 && (d & 2))) return 0;
      v = c->w.bT[t];
      if (!isfinite(v)) return 0;
    }
    S += sa * v;
    mag += fabs(a * v);
  }
  double rmax = 0.0, r1 = 0.0, xmax = 1.0;
  for (int j = 0; j < n; j++) {
    rmax = MAX2(rmax, fabs(res[j]));
    r1 += fabs(res[j]);
    xmax = MAX2(xmax, fabs(c->w.x[j]));
  }
  if (rmax > 1e-9 * asum) return 0;
  double gap = sigma * bp - S;
  return gap > 1e-9 * (1.0 + mag) + err + 100.0 * r1 * xmax;
}

/* Dual simplex from the working basis. */
static int dual_simplex(Ctx *c) {
  int n = c->n;
  int limit = 20 * n + 100, bland_after = 4 * n;
  for (int iter = 0; iter < limit; iter++) {
    double xmax = 1.0;
    for (int j = 0; j < n; j++) xmax = MAX2(xmax, fabs(c->w.x[j]));
    double tol = 1e-9 * xmax, viol;
    int bland = iter >= bland_after;
    int p = leaving_item(c, tol, bland, &viol);
    if (p < 0) return LP_FEASIBLE;
    double v = item_value(c, p);
    double bp = v < c->lo[p] ? c->lo[p] : c->hi[p];
    double sigma = v < c->lo[p] ? 1.0 : -1.0;
    compute_alpha(c, p);
    double amax = 0.0;
    for (int t = 0; t < n; t++) amax = MAX2(amax, fabs(c->alpha[t]));
    double piv_tol = MAX2(1e-9 * amax, 1e-12);
    int q = -1;
    double qa = 0.0;
    for (int t = 0; t < n; t++) {
      double a = c->alpha[t];
      if (fabs(a) <= piv_tol) continue;
      int d = directions(c, t);
      if (!((sigma * a > 0 && (d & 1)) || (sigma * a < 0 && (d & 2)))) continue;
      if (bland) {
        if (q < 0 || c->w.T[t] < c->w.T[q]) q = t;
        continue;
      }
      if (fabs(a) > qa) { qa = fabs(a); q = t; }
    }
    if (q < 0) {
      if (verify_farkas(c, p, sigma, bp, piv_tol)) return LP_INFEASIBLE;
      if (c->w.since > 0) {  /* rounding in Minv? refactorise once and continue */
        if (!refactor(c)) return LP_UNKNOWN;
        continue;
      }
      return LP_UNKNOWN;
    }
    /* pivot: item T[q] released, p tight at bp */
    double aq = c->alpha[q];
    double delta = (bp - v) / aq;
    double *Minv = c->w.Minv;
    for (int i = 0; i < n; i++) c->w.x[i] += delta * Minv[(size_t)i * n + q];
    for (int i = 0; i < n; i++) {
      double *mi = Minv + (size_t)i * n;
      double f = mi[q] / aq;
      if (f != 0.0) {
        for (int t = 0; t < n; t++) mi[t] -= f * c->alpha[t];
      }
      mi[q] = f;
    }
    c->pos[c->w.T[q]] = -1;
    c->w.T[q] = p;
    c->pos[p] = q;
    c->w.bT[q] = bp;
    c->w.side[q] = (c->lo[p] == c->hi[p]) ? SIDE_FIX : (sigma > 0 ? SIDE_LO : SIDE_HI);
    c->pivots++;
    if (++c->w.since >= REFACTOR) {
      if (!refactor(c)) return LP_UNKNOWN;
    } else {
      activities(c);
    }
  }
  return LP_UNKNOWN;
}

/* Whether the working point meets every bound of contact i (rows and force columns). */
static int contact_satisfied(const Ctx *c, int i) {
  int base = i * KEYS + c->cur_key[i];
  double xmax = 1.0;
  for (int j = 0; j < c->n; j++) xmax = MAX2(xmax, fabs(c->w.x[j]));
  double tol = 1e-9 * xmax;
  for (int q = 0; q < c->tab_nrows[base]; q++) {
    int row = c->tab_rows[base * MAXR + q];
    double v = c->w.r[row];
    if (v < c->lo[row] - tol || v > c->hi[row] + tol) return 0;
  }
  int cols[2] = {c->m + c->cn[i], c->m + c->ct[i]};
  for (int q = 0; q < 2; q++) {
    double v = c->w.x[cols[q] - c->m];
    if (v < c->lo[cols[q]] - tol || v > c->hi[cols[q]] + tol) return 0;
  }
  return 1;
}

/* ---------------------------------------------------------------------------------------- */
/* tree */

static double subtree_size(const Ctx *c, const signed char *st) {
  int nf = 0, ncon = 0, used = 0;
  for (int i = 0; i < c->n_c; i++) {
    if (st[i] == ST_FREE) nf++;
    else if (st[i] == ST_CONTACT) ncon++;
    else if (st[i] == ST_ROLL) used += 2;
    else if (st[i] == ST_SLIDE) used += 1;
  }
  int left = c->k - used;
  if (left < 0) return 0.0;
  return c->sizes[((size_t)nf * (c->n_c + 1) + ncon) * (c->k + 1) + left];
}

static int branch_contact(const Ctx *c, const signed char *st, const double *x) {
  int n_c = c->n_c, first_free = -1, first_con = -1;
  for (int i = 0; i < n_c; i++) {
    if (st[i] == ST_FREE && first_free < 0) first_free = i;
    if (st[i] == ST_CONTACT && first_con < 0) first_con = i;
  }
  if (!x) return first_free >= 0 ? first_free : first_con;
  const double *cf = x + c->nz;
  double cmax = 0.0;
  for (int j = 0; j < 2 * n_c; j++) cmax = MAX2(cmax, fabs(cf[j]));
  int bf = -1;
  double fbest = 0.0;
  for (int i = 0; i < n_c; i++) {
    if (st[i] != ST_FREE) continue;
    if (bf < 0 || cf[2 * i] > fbest) { bf = i; fbest = cf[2 * i]; }
  }
  if (bf >= 0 && (first_con < 0 || fbest > c->zero_force * MAX2(cmax, 1e-300))) return bf;
  int bc = -1;
  double cbest = 0.0;
  for (int i = 0; i < n_c; i++) {
    if (st[i] != ST_CONTACT) continue;
    double v = c->mu[i] * cf[2 * i] - fabs(cf[2 * i + 1]);
    if (bc < 0 || v > cbest) { bc = i; cbest = v; }
  }
  return bc;
}

/* Every completion of the leaf st (its FREE contacts B / S / R, its CONTACT ones S / R) with
   exactly k rows (eq. 49), appended to codes (ST_BREAK / ST_SLIDE / ST_ROLL per contact) with
   the leaf's number; returns how many. */
static int completions(const Ctx *c, const signed char *st, signed char *codes, int *leaf_of,
                       int leaf) {
  int n_c = c->n_c, *und = c->cw_und, nu = 0, used = 0, *ncon_left = c->cw_left;
  for (int i = 0; i < n_c; i++) {
    if (st[i] == ST_FREE || st[i] == ST_CONTACT) und[nu++] = i;
    else if (st[i] == ST_ROLL) used += 2;
    else if (st[i] == ST_SLIDE) used += 1;
  }
  ncon_left[nu] = 0;
  for (int q = nu - 1; q >= 0; q--) ncon_left[q] = ncon_left[q + 1] + (st[und[q]] == ST_CONTACT);
  int need = c->k - used;
  signed char *cur = c->cw_cur;
  for (int i = 0; i < n_c; i++) cur[i] = st[i] == ST_FREE || st[i] == ST_CONTACT ? 0 : st[i];
  int *choice = c->cw_choice, *rows = c->cw_rows, count = 0, q = 0;
  /* odometer over the undecided contacts: choice 0 B, 1 S, 2 R (CONTACT: S or R only) */
  rows[0] = 0;
  choice[0] = -1;
  while (q >= 0) {
    if (q == nu) {
      if (rows[q] == need) {
        memcpy(codes + (size_t)count * n_c, cur, n_c);
        leaf_of[count++] = leaf;
      }
      q--;
      continue;
    }
    int i = und[q];
    int lo_choice = st[i] == ST_CONTACT ? 1 : 0;
    int ch = choice[q] < lo_choice ? lo_choice : choice[q] + 1;
    int done = 1;
    for (; ch <= 2; ch++) {
      int r = rows[q] + ch;                 /* B 0 rows, S 1, R 2 */
      int left = need - r, rest = nu - q - 1;
      if (left < ncon_left[q + 1] || left > 2 * rest) continue;
      choice[q] = ch;
      cur[i] = (signed char)(ch == 0 ? ST_BREAK : ch == 1 ? ST_SLIDE : ST_ROLL);
      rows[q + 1] = r;
      choice[q + 1] = -1;
      q++;
      done = 0;
      break;
    }
    if (done) { choice[q] = -1; q--; }
  }
  return count;
}

static int push(Ctx *c, const signed char *st, const signed char *xi, int depth, int must) {
  if (c->n_stack == c->cap_stack) {
    int cap = c->cap_stack * 2;
    Node *s = realloc(c->stack, sizeof(Node) * cap);
    if (!s) return 0;
    signed char *pool = realloc(c->pool, (size_t)cap * 2 * c->n_c);
    if (!pool) { c->stack = s; return 0; }
    c->stack = s;
    c->pool = pool;
    c->cap_stack = cap;
    for (int q = 0; q < c->n_stack; q++) {
      c->stack[q].states = c->pool + (size_t)q * 2 * c->n_c;
      c->stack[q].xi = c->stack[q].states + c->n_c;
    }
  }
  Node *nd = &c->stack[c->n_stack];
  nd->states = c->pool + (size_t)c->n_stack * 2 * c->n_c;
  nd->xi = nd->states + c->n_c;
  memcpy(nd->states, st, c->n_c);
  memcpy(nd->xi, xi, c->n_c);
  nd->depth = depth;
  nd->must_solve = must;
  c->n_stack++;
  return 1;
}

/* ---------------------------------------------------------------------------------------- */
/* API */

void qs_free(Ctx *c);

Ctx *qs_new(int m, int n, const double *A, const double *row_lo, const double *row_hi,
            const double *col_lo, const double *col_hi, int n_c, int nz, int k,
            const int *tab_nrows, const int *tab_rows, const double *tab_lo,
            const double *tab_hi, const double *tab_col, const int *cn, const int *ct,
            const double *mu, const double *sizes, int batch_size, int lp_min_size,
            double zero_force) {
  Ctx *c = xmalloc(sizeof(Ctx));
  if (!c) return NULL;
  c->m = m; c->n = n; c->n_c = n_c; c->nz = nz; c->k = k;
  c->batch_size = batch_size; c->lp_min_size = lp_min_size; c->zero_force = zero_force;
  size_t mn = (size_t)m * n, tab = (size_t)n_c * KEYS;
  size_t nsizes = (size_t)(n_c + 1) * (n_c + 1) * (k + 1);
  c->A = xmalloc(sizeof(double) * mn);
  c->base_lo = xmalloc(sizeof(double) * (m + n));
  c->base_hi = xmalloc(sizeof(double) * (m + n));
  c->lo = xmalloc(sizeof(double) * (m + n));
  c->hi = xmalloc(sizeof(double) * (m + n));
  c->tab_nrows = xmalloc(sizeof(int) * tab);
  c->tab_rows = xmalloc(sizeof(int) * tab * MAXR);
  c->tab_lo = xmalloc(sizeof(double) * tab * MAXR);
  c->tab_hi = xmalloc(sizeof(double) * tab * MAXR);
  c->tab_col = xmalloc(sizeof(double) * tab * 2);
  c->cn = xmalloc(sizeof(int) * n_c);
  c->ct = xmalloc(sizeof(int) * n_c);
  c->mu = xmalloc(sizeof(double) * n_c);
  c->sizes = xmalloc(sizeof(double) * nsizes);
  c->cur_key = xmalloc(sizeof(int) * n_c);
  c->pos = xmalloc(sizeof(int) * (m + n));
  c->alpha = xmalloc(sizeof(double) * n);
  c->res = xmalloc(sizeof(double) * n);
  c->Mtmp = xmalloc(sizeof(double) * (size_t)n * n);
  c->cw_und = xmalloc(sizeof(int) * (n_c + 1));
  c->cw_left = xmalloc(sizeof(int) * (n_c + 1));
  c->cw_choice = xmalloc(sizeof(int) * (n_c + 1));
  c->cw_rows = xmalloc(sizeof(int) * (n_c + 1));
  c->cw_cur = xmalloc(n_c + 1);
  c->max_depth = 2 * n_c + 2;
  c->snap = xmalloc(sizeof(Basis) * (c->max_depth + 1));
  c->cap_stack = 64;
  c->stack = xmalloc(sizeof(Node) * c->cap_stack);
  c->pool = xmalloc((size_t)c->cap_stack * 2 * n_c);
  if (!c->A || !c->base_lo || !c->base_hi || !c->lo || !c->hi || !c->tab_nrows ||
      !c->tab_rows || !c->tab_lo || !c->tab_hi || !c->tab_col || !c->cn || !c->ct || !c->mu ||
      !c->sizes || !c->cur_key || !c->pos || !c->alpha || !c->res || !c->Mtmp ||
      !c->snap || !c->stack || !c->pool || !c->cw_und || !c->cw_left || !c->cw_choice ||
      !c->cw_rows || !c->cw_cur || !basis_alloc(&c->w, m, n)) {
    qs_free(c);
    return NULL;
  }
  memcpy(c->A, A, sizeof(double) * mn);
  size_t nnz = 0;
  for (size_t q = 0; q < mn; q++) nnz += A[q] != 0.0;
  c->rp = xmalloc(sizeof(int) * (m + 1));
  c->ci = xmalloc(sizeof(int) * nnz);
  c->cv = xmalloc(sizeof(double) * nnz);
  if (!c->rp || !c->ci || !c->cv) { qs_free(c); return NULL; }
  nnz = 0;
  for (int i = 0; i < m; i++) {
    c->rp[i] = (int)nnz;
    for (int j = 0; j < n; j++) {
      double v = A[(size_t)i * n + j];
      if (v != 0.0) { c->ci[nnz] = j; c->cv[nnz] = v; nnz++; }
    }
  }
  c->rp[m] = (int)nnz;
  memcpy(c->base_lo, row_lo, sizeof(double) * m);
  memcpy(c->base_hi, row_hi, sizeof(double) * m);
  memcpy(c->base_lo + m, col_lo, sizeof(double) * n);
  memcpy(c->base_hi + m, col_hi, sizeof(double) * n);
  memcpy(c->tab_nrows, tab_nrows, sizeof(int) * tab);
  memcpy(c->tab_rows, tab_rows, sizeof(int) * tab * MAXR);
  memcpy(c->tab_lo, tab_lo, sizeof(double) * tab * MAXR);
  memcpy(c->tab_hi, tab_hi, sizeof(double) * tab * MAXR);
  memcpy(c->tab_col, tab_col, sizeof(double) * tab * 2);
  memcpy(c->cn, cn, sizeof(int) * n_c);
  memcpy(c->ct, ct, sizeof(int) * n_c);
  memcpy(c->mu, mu, sizeof(double) * n_c);
  memcpy(c->sizes, sizes, sizeof(double) * nsizes);
  return c;
}

void qs_free(Ctx *c) {
  if (!c) return;
  if (c->snap) {
    for (int d = 0; d <= c->max_depth; d++) basis_free(&c->snap[d]);
    free(c->snap);
  }
  basis_free(&c->w);
  free(c->A); free(c->rp); free(c->ci); free(c->cv); free(c->base_lo); free(c->base_hi); free(c->lo); free(c->hi);
  free(c->tab_nrows); free(c->tab_rows); free(c->tab_lo); free(c->tab_hi); free(c->tab_col);
  free(c->cn); free(c->ct); free(c->mu); free(c->sizes); free(c->cur_key); free(c->pos);
  free(c->alpha); free(c->res); free(c->Mtmp); free(c->stack); free(c->pool);
  free(c->cw_und); free(c->cw_left); free(c->cw_choice); free(c->cw_rows); free(c->cw_cur);
  free(c);
}

/* Start a search at the node (states, xi): bounds reset, no basis (the first LP starts cold),
   statistics zeroed.  Returns 0 when out of memory. */
int qs_start(Ctx *c, const signed char *states, const signed char *xi) {
  memcpy(c->lo, c->base_lo, sizeof(double) * (c->m + c->n));
  memcpy(c->hi, c->base_hi, sizeof(double) * (c->m + c->n));
  for (int i = 0; i < c->n_c; i++) c->cur_key[i] = -1;
  for (int d = 0; d <= c->max_depth; d++) c->snap[d].valid = 0;
  c->w.valid = 0;
  c->n_stack = 0;
  c->lp_solves = c->pivots = c->inherited = c->unknown = c->refactors = c->cold = 0;
  c->nodes = c->leaves = 0;
  c->leaf_candidates = 0.0;
  return push(c, states, xi, 0, 1);
}

/* Run the search until it ends (returns 0) or until max_leaves leaves or max_candidates leaf
   candidates are in the output (returns 1: call again).  -1: out of memory.
   Leaves are written to out_states / out_xi (n_leaves x n_c). */
int qs_run(Ctx *c, signed char *out_states, signed char *out_xi, int max_leaves,
           signed char *out_codes, int *out_leaf, int max_codes, int *n_out, int *n_codes) {
  int n_c = c->n_c, m = c->m, n = c->n;
  int nl = 0, nc = 0, biggest = c->batch_size > 1 ? c->batch_size : 1;
  signed char *st = malloc(2 * n_c);
  double *zeros = calloc(n, sizeof(double));
  if (!st || !zeros) { free(st); free(zeros); return -1; }
  signed char *xi = st + n_c;
  while (c->n_stack > 0) {
    if (nl >= max_leaves || nc + biggest > max_codes) {
      free(st); free(zeros); *n_out = nl; *n_codes = nc; return 1;
    }
    Node *nd = &c->stack[--c->n_stack];
    memcpy(st, nd->states, n_c);
    memcpy(xi, nd->xi, n_c);
    int depth = nd->depth, must = nd->must_solve;
    c->nodes++;
    double size = subtree_size(c, st);
    if (size == 0.0) continue;
    const double *point = NULL;
    int known = 1;   /* the point is an LP point (not the zeros of an LP without a verdict) */
    if (size > c->lp_min_size) {
      Basis *parent = depth > 0 ? &c->snap[depth - 1] : NULL;
      int have_parent = parent && parent->valid;
      if (have_parent && !basis_copy(&c->w, parent, m, n)) { free(st); free(zeros); return -1; }
      apply_node(c, st, xi);
      if (!c->w.valid) {
        cold_start(c);
      } else {
        set_positions(c);
        sanitize(c);
      }
      if (must || !have_parent) {
        c->lp_solves++;
        int status = dual_simplex(c);
        if (status == LP_INFEASIBLE) continue;
        if (status == LP_UNKNOWN) { c->unknown++; known = 0; }
      } else {
        c->inherited++;
      }
      /* no verdict: branch on zero forces and solve every child, as the Python search does
         with its all-zero point; the basis stays as the children's warm start */
      point = known ? c->w.x : zeros;
    }
    int undecided = 0;
    for (int i = 0; i < n_c; i++) undecided |= (st[i] == ST_FREE || st[i] == ST_CONTACT);
    if (size <= c->batch_size || !undecided) {
      memcpy(out_states + (size_t)nl * n_c, st, n_c);
      memcpy(out_xi + (size_t)nl * n_c, xi, n_c);
      nc += completions(c, st, out_codes + (size_t)nc * n_c, out_leaf + nc, nl);
      nl++;
      c->leaves++;
      c->leaf_candidates += size;
      continue;
    }
    int i = branch_contact(c, st, point);
    if (depth >= c->max_depth) { free(st); free(zeros); return -1; }
    /* this node's basis for its children (none solved: its parent's, if any) */
    int okc = 1;
    if (point) okc = basis_copy(&c->snap[depth], &c->w, m, n);
    else if (depth > 0 && c->snap[depth - 1].valid)
      okc = basis_copy(&c->snap[depth], &c->snap[depth - 1], m, n);
    else c->snap[depth].valid = 0;
    if (!okc) { free(st); free(zeros); return -1; }
    signed char old = st[i], oldxi = xi[i];
    static const int free_children[2][2] = {{ST_BREAK, 0}, {ST_CONTACT, 0}};
    static const int con_children[3][2] = {{ST_SLIDE, 1}, {ST_SLIDE, -1}, {ST_ROLL, 0}};
    int nch = old == ST_FREE ? 2 : 3;
    for (int q = 0; q < nch; q++) {
      int code = old == ST_FREE ? free_children[q][0] : con_children[q][0];
      int x = old == ST_FREE ? free_children[q][1] : con_children[q][1];
      st[i] = (signed char)code;
      xi[i] = (signed char)x;
      int inherit = 0;
      if (point && known && (code == ST_CONTACT || code == ST_ROLL)) {
        /* the parent's point meets the child's bounds for contact i? */
        int key_before = c->cur_key[i];
        apply_key(c, i, key_of(code, x));
        inherit = contact_satisfied(c, i);
        if (key_before >= 0) apply_key(c, i, key_before);
      }
      if (!push(c, st, xi, depth + 1, !inherit)) { free(st); free(zeros); return -1; }
    }
    st[i] = old;
    xi[i] = oldxi;
  }
  free(st);
  free(zeros);
  *n_out = nl;
  *n_codes = nc;
  return 0;
}

void qs_stats(const Ctx *c, long long *out, double *cands) {
  out[0] = c->lp_solves; out[1] = c->pivots; out[2] = c->inherited; out[3] = c->unknown;
  out[4] = c->refactors; out[5] = c->cold; out[6] = c->nodes; out[7] = c->leaves;
  *cands = c->leaf_candidates;
}

/* One LP at a node, for tests: 0 feasible (x written), 1 infeasible, 2 no verdict. */
int qs_solve_node(Ctx *c, const signed char *states, const signed char *xi, double *x_out) {
  memcpy(c->lo, c->base_lo, sizeof(double) * (c->m + c->n));
  memcpy(c->hi, c->base_hi, sizeof(double) * (c->m + c->n));
  for (int i = 0; i < c->n_c; i++) c->cur_key[i] = -1;
  apply_node(c, states, xi);
  cold_start(c);
  int s = dual_simplex(c);
  memcpy(x_out, c->w.x, sizeof(double) * c->n);
  return s;
}
