/*
 * The DAQP side of the replay: DAQP 0.11.0's dense QP interface on the condensed MPC QP of an
 * `mpcc dump-qp` file (format mpcc-qp/1, peers/README.md), with the parametric part computed here,
 * in c_float, as a DAQP user's controller computes it:
 *
 *   f = (F_x x0 - F_r r + F_u u_last, w_slack),    o = W_x x0 + W_u u_last,
 *   z_min <= z <= z_max,   lower - o <= A z <= upper - o.
 *
 * The matrices are the caller's (const, in flash on a board); the workspace is set up once (daqp's setup_daqp: the Cholesky factor of H, M = A R^-1) and kept:
 * each solve updates v and d (daqp_update_ldp with DAQP_UPDATE_v | DAQP_UPDATE_d) and calls
 * daqp_solve, which starts from the previous solve's working set (DAQP's hot start).
 * Infinite bounds become +-DAQP_INF (1e30).
 */
#include <stdlib.h>
#include "api.h"

typedef struct {
    int nx, nu, nr, np, ns, n, rows;
    const c_float *Fx, *Fr, *Fu, *w, *lower, *upper, *Wx, *Wu;
    c_float *f, *bu, *bl, *lam;
    int *sense;
    DAQPProblem qp;
    DAQPWorkspace work;
    DAQPSettings settings;
    DAQPResult res;
} peer_daqp;

/* The size of the workspace struct (without the buffers it points to). */
size_t peer_daqp_size(void) { return sizeof(peer_daqp); }

/*
 * Sets up the workspace on the dump's data in c_float, which it keeps pointers to (the caller keeps
 * it alive; DAQP does not write to it): H (n x n), A (rows x n, row-major), z_min/z_max (n),
 * lower/upper (rows), W_x (rows x nx), W_u (rows x nu), F_x (np x nx), F_r (np x nr), F_u (np x nu),
 * w (n - np); infinite bounds as +-DAQP_INF. Returns NULL if memory runs out, else the workspace;
 * *flag is DAQP's setup flag (negative: failed).
 */
peer_daqp *peer_daqp_setup(int nx, int nu, int nr, int np, int n, int rows, const c_float *H,
                           const c_float *A, const c_float *z_min, const c_float *z_max,
                           const c_float *lower, const c_float *upper, const c_float *Wx,
                           const c_float *Wu, const c_float *Fx, const c_float *Fr,
                           const c_float *Fu, const c_float *w, int *flag) {
    int i;
    peer_daqp *p = calloc(1, sizeof(peer_daqp));
    if (p == NULL) return NULL;
    p->nx = nx; p->nu = nu; p->nr = nr; p->np = np; p->ns = n - np; p->n = n; p->rows = rows;
    p->Fx = Fx; p->Fr = Fr; p->Fu = Fu; p->w = w;
    p->lower = lower; p->upper = upper; p->Wx = Wx; p->Wu = Wu;
    /* DAQPProblem's pointers are not const; DAQP only reads H and A (presolve, which writes the
     * bounds, is for mixed-integer problems only). */
    p->qp.H = (c_float *)H;
    p->qp.A = (c_float *)A;
    p->f = calloc(n, sizeof(c_float));
    p->bu = calloc(n + rows, sizeof(c_float));
    p->bl = calloc(n + rows, sizeof(c_float));
    p->lam = calloc(n + rows, sizeof(c_float));
    p->sense = calloc(n + rows, sizeof(int));
    if (!p->f || !p->bu || !p->bl || !p->lam || !p->sense) return NULL;
    for (i = 0; i < n; i++) { p->bu[i] = z_max[i]; p->bl[i] = z_min[i]; }
    for (i = 0; i < rows; i++) { p->bu[n + i] = p->upper[i]; p->bl[n + i] = p->lower[i]; }
    for (i = 0; i < p->ns; i++) p->f[np + i] = p->w[i];
    p->qp.n = n;
    p->qp.m = n + rows;
    p->qp.ms = n;
    p->qp.f = p->f;
    p->qp.bupper = p->bu;
    p->qp.blower = p->bl;
    p->qp.sense = p->sense;
    p->qp.break_points = NULL;
    p->qp.nh = 0;
    p->qp.problem_type = 0;
    daqp_default_settings(&p->settings);
    p->work.settings = &p->settings;
    *flag = setup_daqp(&p->qp, &p->work, NULL);
    p->res.x = NULL;
    p->res.lam = p->lam;
    return p;
}

/*
 * Forms one control step's data from the state x0 (nx), the reference window r (nr) and the last
 * input u_last (nu): f and the rows' bounds.
 */
void peer_daqp_form(peer_daqp *p, const c_float *x0, const c_float *r, const c_float *u_last) {
    int i, j;
    const int nx = p->nx, nu = p->nu, nr = p->nr, n = p->n;
    for (i = 0; i < p->np; i++) {
        c_float s = 0;
        const c_float *fx = p->Fx + i * nx, *fr = p->Fr + i * nr, *fu = p->Fu + i * nu;
        for (j = 0; j < nx; j++) s += fx[j] * x0[j];
        for (j = 0; j < nr; j++) s -= fr[j] * r[j];
        for (j = 0; j < nu; j++) s += fu[j] * u_last[j];
        p->f[i] = s;
    }
    for (i = 0; i < p->rows; i++) {
        c_float o = 0;
        const c_float *wx = p->Wx + i * nx, *wu = p->Wu + i * nu;
        for (j = 0; j < nx; j++) o += wx[j] * x0[j];
        for (j = 0; j < nu; j++) o += wu[j] * u_last[j];
        p->bu[n + i] = p->upper[i] >= DAQP_INF ? DAQP_INF : p->upper[i] - o;
        p->bl[n + i] = p->lower[i] <= -DAQP_INF ? -DAQP_INF : p->lower[i] - o;
    }
}

/*
 * Solves the formed step: updates the LDP (v and d), solves from the previous working set and
 * writes z (n). Returns DAQP's exit flag (1 optimal, 2 soft optimal; negative failed); *iter is
 * the number of active-set iterations.
 */
int peer_daqp_solve(peer_daqp *p, c_float *z, int *iter) {
    p->res.x = z;
    p->res.exitflag = daqp_update_ldp(DAQP_UPDATE_v | DAQP_UPDATE_d, &p->work, &p->qp);
    if (p->res.exitflag < 0) { *iter = 0; return p->res.exitflag; }
    daqp_solve(&p->res, &p->work);
    *iter = p->res.iter;
    return p->res.exitflag;
}
