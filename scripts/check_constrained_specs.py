#!/usr/bin/env python3
"""Checks of the constrained specs of issue 17, in plain Python (no numpy needed).

    python3 scripts/check_constrained_specs.py [SPEC ...]

Without arguments it checks `specs/quadcopter.toml`, `specs/hover.toml`, `specs/paper-limits.toml` and
`specs/paper-geofence.toml`.
For every spec it

1. checks the dimensions of every key against the model (nx, nu, nz = nx: these specs track the whole
   state): `q`, `r`, `qf`, `u_min`/`u_max`, `x_min`/`x_max`, `du_min`/`du_max`, each `[[mpc.constraint]]`
   and `[mpc.region]`, and that the region lies inside the hard state bounds;
2. forms the condensed QP exactly as `codegen::lower` does (eqs. 9-13 of the paper):
   H = 2(Suᵀ Q̄ Su + R̄), Q̄ = blkdiag(Q, …, Q, Qf), and prints λmin, λmax and κ(H) (all eigenvalues
   by cyclic Jacobi rotations; the issue quotes κ(H) = 2.3e4 for the quadcopter and 2.8e4 for the
   hover, which checks the transcription of the matrices and weights);
3. solves the constrained QP with a small dense Mehrotra interior-point method (f64, here in Python) on
   the source's closed loop and on the corners of `[mpc.region]`, and reports
   - whether the hard constraints are feasible there (the region must not hold states from which the
     hard QP has no solution), and the largest state excursion along the source's closed loop (the
     region must cover it);
   - for soft state bounds (`x_soft`), the exact-penalty threshold: the largest sum over the horizon of
     the hard problem's multipliers of one state component, Σ_k (λ⁺_{k,i} + λ⁻_{k,i}), which `x_soft`
     must exceed for the soft problem to have the hard problem's solution whenever that is feasible. The same
     per row of the `[[mpc.constraint]]` groups, which a group's `soft` must exceed.

The cost is the project's: J = Σ_{k=1}^{N−1} (x_k − r_k)ᵀQ(x_k − r_k) + (x_N − r_N)ᵀQf(x_N − r_N)
+ Σ_{k=0}^{N−1} u_kᵀRu_k = ½UᵀHU + fᵀU + const, f = 2Suᵀ Q̄ (Sx x0 − R_ref). A soft state bound adds one
slack s_i ≥ 0 per constrained component i, shared by x_1 … x_N and both sides, with the cost
w·s_i + 1e-3·w·s_i²/2 (the design stated in docs/methods.md, "Constraints and the interior-point method").
"""

import math
import random
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SPECS = ["specs/quadcopter.toml", "specs/hover.toml", "specs/paper-limits.toml",
                 "specs/paper-geofence.toml"]
QUAD_SOFT = 1e-3  # the quadratic term of a soft constraint, relative to its weight


# ---------------------------------------------------------------------------------------------- algebra

def zeros(r, c):
    return [[0.0] * c for _ in range(r)]


def eye(n):
    m = zeros(n, n)
    for i in range(n):
        m[i][i] = 1.0
    return m


def matmul(a, b):
    bt = list(zip(*b))
    return [[sum(x * y for x, y in zip(row, col)) for col in bt] for row in a]


def matvec(a, v):
    return [sum(x * y for x, y in zip(row, v)) for row in a]


def transpose(a):
    return [list(r) for r in zip(*a)]


def diag_or_matrix(value, n, name):
    """A spec weight: a number k·I, a list (diagonal) or a list of lists (full matrix)."""
    if isinstance(value, (int, float)):
        return [[float(value) if i == j else 0.0 for j in range(n)] for i in range(n)]
    if all(isinstance(v, (int, float)) for v in value):
        assert len(value) == n, f"{name}: {len(value)} entries, expected {n}"
        return [[float(value[i]) if i == j else 0.0 for j in range(n)] for i in range(n)]
    assert len(value) == n and all(len(r) == n for r in value), f"{name}: not {n} × {n}"
    return [[float(x) for x in r] for r in value]


def cholesky(a):
    n = len(a)
    l = zeros(n, n)
    for i in range(n):
        for j in range(i + 1):
            s = a[i][j] - sum(l[i][k] * l[j][k] for k in range(j))
            if i == j:
                if s <= 0.0:
                    raise ValueError("matrix not positive definite")
                l[i][i] = math.sqrt(s)
            else:
                l[i][j] = s / l[j][j]
    return l


def cho_solve(l, b):
    n = len(l)
    y = [0.0] * n
    for i in range(n):
        y[i] = (b[i] - sum(l[i][k] * y[k] for k in range(i))) / l[i][i]
    x = [0.0] * n
    for i in reversed(range(n)):
        x[i] = (y[i] - sum(l[k][i] * x[k] for k in range(i + 1, n))) / l[i][i]
    return x


def eigenvalues_symmetric(a, sweeps=60):
    """All eigenvalues of a symmetric matrix by cyclic Jacobi rotations."""
    n = len(a)
    m = [row[:] for row in a]
    for _ in range(sweeps):
        off = sum(m[i][j] ** 2 for i in range(n) for j in range(n) if i != j)
        scale = sum(m[i][i] ** 2 for i in range(n))
        if off <= 1e-30 * scale:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                if abs(m[p][q]) < 1e-300:
                    continue
                theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q])
                t = math.copysign(1.0, theta) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):  # columns p, q
                    mkp, mkq = m[k][p], m[k][q]
                    m[k][p] = c * mkp - s * mkq
                    m[k][q] = s * mkp + c * mkq
                for k in range(n):  # rows p, q
                    mpk, mqk = m[p][k], m[q][k]
                    m[p][k] = c * mpk - s * mqk
                    m[q][k] = s * mpk + c * mqk
    return sorted(m[i][i] for i in range(n))


# ------------------------------------------------------------------------------------------------- spec

class Spec:
    """The parts of a spec this script needs, with the dimensions checked."""

    def __init__(self, path):
        self.path = path
        self.raw = tomllib.loads(Path(path).read_text())
        model, mpc = self.raw["model"], self.raw["mpc"]
        self.dt = float(model["dt"])
        if model["type"] == "double_integrator":
            axes = int(model["axes"])
            dt = self.dt
            self.F = eye(2 * axes)
            self.G = zeros(2 * axes, axes)
            for i in range(axes):
                self.F[i][axes + i] = dt
                self.G[i][i] = dt * dt / 2.0
                self.G[axes + i][i] = dt
        else:
            assert model["type"] == "linear"
            assert model.get("time", "discrete") == "discrete", "only sampled models here"
            self.F = [[float(x) for x in r] for r in model["a"]]
            self.G = [[float(x) for x in r] for r in model["b"]]
        nx, nu = len(self.F), len(self.G[0])
        assert all(len(r) == nx for r in self.F), "a is not square"
        assert len(self.G) == nx and all(len(r) == nu for r in self.G), "b is not nx × nu"
        if "c" in model:
            assert all(len(r) == nx for r in model["c"]), "c is not ny × nx"
        assert "outputs" not in mpc, "this script handles specs that track the state"
        self.nx, self.nu, self.N = nx, nu, int(mpc["horizon"])
        self.Q = diag_or_matrix(mpc["q"], nx, "q")
        self.R = diag_or_matrix(mpc["r"], nu, "r")
        if "qf" in mpc:
            self.Qf = diag_or_matrix(mpc["qf"], nx, "qf")
        else:
            k = float(mpc.get("qf_scale", 1.0))
            self.Qf = [[k * x for x in r] for r in self.Q]
        self.u_min = self.vector(mpc, "u_min", nu)
        self.u_max = self.vector(mpc, "u_max", nu)
        inf = math.inf
        self.x_min = self.vector(mpc, "x_min", nx, -inf)
        self.x_max = self.vector(mpc, "x_max", nx, inf)
        self.x_soft = mpc.get("x_soft")
        self.du_min = self.vector(mpc, "du_min", nu, -inf)
        self.du_max = self.vector(mpc, "du_max", nu, inf)
        self.groups = []
        for g in mpc.get("constraint", []):
            ax = [[float(x) for x in r] for r in g["ax"]]
            rows = len(ax)
            assert all(len(r) == nx for r in ax), "constraint ax is not rows × nx"
            au = [[float(x) for x in r] for r in g.get("au", [[0.0] * nu] * rows)]
            assert len(au) == rows and all(len(r) == nu for r in au), "constraint au is not rows × nu"
            lower = [float(x) for x in g.get("lower", [-inf] * rows)]
            upper = [float(x) for x in g.get("upper", [inf] * rows)]
            assert len(lower) == rows and len(upper) == rows, "constraint lower/upper: one per row"
            self.groups.append((ax, au, lower, upper, g.get("soft")))
        for lo, hi, name in [(self.u_min, self.u_max, "u"), (self.x_min, self.x_max, "x"),
                             (self.du_min, self.du_max, "du")]:
            assert all(a <= b for a, b in zip(lo, hi)), f"{name}_min > {name}_max"
        region = mpc.get("region", {})
        self.region_min = self.vector(region, "x_min", nx) if "x_min" in region else self.x_min
        self.region_max = self.vector(region, "x_max", nx) if "x_max" in region else self.x_max
        assert all(math.isfinite(v) for v in self.region_min + self.region_max), "region not finite"
        self.ref_min = self.vector(region, "reference_min", nx) if "reference_min" in region else None
        self.ref_max = self.vector(region, "reference_max", nx) if "reference_max" in region else None
        for lo, hi in [(self.region_min, self.region_max), (self.ref_min, self.ref_max)]:
            if lo is not None:
                assert all(a <= b for a, b in zip(lo, hi)), "region min > max"
        if self.x_soft is None:
            assert all(self.x_min[i] <= self.region_min[i] and self.region_max[i] <= self.x_max[i]
                       for i in range(nx)), "region outside the hard state bounds"
        self.method = mpc.get("method", "fgm")
        self.iterations = mpc.get("iterations")
        self.scalar = self.raw.get("codegen", {}).get("scalar", "f32")
        self.condense()

    @staticmethod
    def vector(table, key, n, default=None):
        if key not in table:
            return [default] * n if default is not None else None
        v = table[key]
        if isinstance(v, (int, float)):
            v = [v] * n
        assert len(v) == n, f"{key}: {len(v)} entries, expected {n}"
        return [float(x) for x in v]

    def condense(self):
        """Sx (N·nx × nx), Su (N·nx × N·nu), H and the gradient's maps, as `codegen::lower` forms them."""
        nx, nu, N = self.nx, self.nu, self.N
        powers = [eye(nx)]
        for _ in range(N):
            powers.append(matmul(self.F, powers[-1]))
        self.Sx = [row for k in range(1, N + 1) for row in powers[k]]
        AkB = [matmul(powers[k], self.G) for k in range(N)]
        self.Su = zeros(N * nx, N * nu)
        for k in range(1, N + 1):  # x_k = F^k x0 + Σ_{j<k} F^{k-1-j} G u_j
            for j in range(k):
                block = AkB[k - 1 - j]
                for i in range(nx):
                    for c in range(nu):
                        self.Su[(k - 1) * nx + i][j * nu + c] = block[i][c]
        self.Qbar = zeros(N * nx, N * nx)
        for k in range(N):
            W = self.Qf if k == N - 1 else self.Q
            for i in range(nx):
                for j in range(nx):
                    self.Qbar[k * nx + i][k * nx + j] = W[i][j]
        SuT = transpose(self.Su)
        self.SuTQ = matmul(SuT, self.Qbar)
        SuTQSu = matmul(self.SuTQ, self.Su)
        n = N * nu
        self.H = [[2.0 * (SuTQSu[i][j] + (self.R[i % nu][j % nu] if i // nu == j // nu else 0.0))
                   for j in range(n)] for i in range(n)]

    def gradient(self, x0, ref):
        """f = 2 Suᵀ Q̄ (Sx x0 − R_ref), `ref` one reference state for the whole window."""
        pred = matvec(self.Sx, x0)
        err = [pred[k * self.nx + i] - ref[i] for k in range(self.N) for i in range(self.nx)]
        return [2.0 * v for v in matvec(self.SuTQ, err)]

    def predict(self, x, u):
        return [a + b for a, b in zip(matvec(self.F, x), matvec(self.G, u))]


# ---------------------------------------------------------------------------------------------------- IPM

def ipm(P, c, rows, b, max_iter=100, tol=1e-9):
    """min ½vᵀPv + cᵀv s.t. rows·v ≤ b (rows sparse: lists of (index, value)); Mehrotra's
    predictor-corrector. Returns (v, λ, converged)."""
    n, m = len(c), len(rows)
    v = [0.0] * n
    z = [max(1.0, b[r] - sum(a * v[j] for j, a in rows[r])) for r in range(m)]
    lam = [1.0] * m
    scale = 1.0 + max(abs(x) for x in c + [bb for bb in b if math.isfinite(bb)])

    def Av(x):
        return [sum(a * x[j] for j, a in row) for row in rows]

    def ATv(y):
        out = [0.0] * n
        for row, yr in zip(rows, y):
            if yr != 0.0:
                for j, a in row:
                    out[j] += a * yr
        return out

    for it in range(max_iter):
        Pv = matvec(P, v)
        ATl = ATv(lam)
        rd = [Pv[i] + c[i] + ATl[i] for i in range(n)]
        Avv = Av(v)
        rp = [Avv[r] + z[r] - b[r] for r in range(m)]
        mu = sum(zi * li for zi, li in zip(z, lam)) / m
        if max(map(abs, rd)) < tol * scale and max(map(abs, rp)) < tol * scale and mu < tol * scale:
            return v, lam, True
        W = [l / s for l, s in zip(lam, z)]
        K = [row[:] for row in P]
        for row, w in zip(rows, W):
            for j, a in row:
                for k, bk in row:
                    K[j][k] += w * a * bk
        # Rounding can make K indefinite in the last, ill-conditioned steps: a small diagonal shift, grown
        # until the factorization succeeds, then only costs a little accuracy in the direction.
        reg = 1e-14 * max(P[i][i] for i in range(n))
        while True:
            try:
                L = cholesky(K)
                break
            except ValueError:
                if reg > 1e-6 * max(K[i][i] for i in range(n)):
                    return v, lam, False
                for i in range(n):
                    K[i][i] += reg
                reg *= 100.0

        def direction(rc):
            rhs_r = [W[r] * rp[r] - rc[r] / z[r] for r in range(m)]
            t = ATv(rhs_r)
            dv = cho_solve(L, [-rd[i] - t[i] for i in range(n)])
            Adv = Av(dv)
            dl = [W[r] * (Adv[r] + rp[r]) - rc[r] / z[r] for r in range(m)]
            dz = [-rp[r] - Adv[r] for r in range(m)]
            return dv, dz, dl

        def step(dz, dl):
            a = 1.0
            for x, dx in zip(z + lam, dz + dl):
                if dx < 0.0:
                    a = min(a, -x / dx)
            return a

        dv, dz, dl = direction([zi * li for zi, li in zip(z, lam)])
        a = step(dz, dl)
        mu_aff = sum((z[r] + a * dz[r]) * (lam[r] + a * dl[r]) for r in range(m)) / m
        sigma = (mu_aff / mu) ** 3
        rc = [z[r] * lam[r] + dz[r] * dl[r] - sigma * mu for r in range(m)]
        dv, dz, dl = direction(rc)
        a = min(1.0, 0.99 * step(dz, dl))
        v = [x + a * d for x, d in zip(v, dv)]
        z = [x + a * d for x, d in zip(z, dz)]
        lam = [x + a * d for x, d in zip(lam, dl)]
    return v, lam, False


def constrained_qp(spec, x0, ref, soft_weight=None, u_prev=None):
    """The condensed QP of `spec` at (x0, ref) with its input box, state bounds (hard, or soft with
    `soft_weight`: one slack per bounded component, shared over the horizon and both sides), moves and
    row groups (hard here). Returns (U, slacks, multipliers of the state bounds per (k, i, side), ok)."""
    nx, nu, N = spec.nx, spec.nu, spec.N
    n_u = N * nu
    bounded = [i for i in range(nx) if math.isfinite(spec.x_min[i]) or math.isfinite(spec.x_max[i])]
    slack_of = {i: n_u + s for s, i in enumerate(bounded)} if soft_weight else {}
    n = n_u + len(slack_of)
    P = zeros(n, n)
    for i in range(n_u):
        for j in range(n_u):
            P[i][j] = spec.H[i][j]
    c = spec.gradient(x0, ref) + [0.0] * len(slack_of)
    for j in slack_of.values():
        P[j][j] = QUAD_SOFT * soft_weight
        c[j] = soft_weight
    rows, b, tags = [], [], []
    for j in range(n_u):
        rows.append([(j, 1.0)]); b.append(spec.u_max[j % nu]); tags.append(None)
        rows.append([(j, -1.0)]); b.append(-spec.u_min[j % nu]); tags.append(None)
    free = matvec(spec.Sx, x0)
    for k in range(N):
        for i in bounded:
            r = k * nx + i
            su = [(j, spec.Su[r][j]) for j in range(n_u) if spec.Su[r][j] != 0.0]
            extra = [(slack_of[i], -1.0)] if i in slack_of else []
            if math.isfinite(spec.x_max[i]):
                rows.append(su + extra); b.append(spec.x_max[i] - free[r]); tags.append((k, i, +1))
            if math.isfinite(spec.x_min[i]):
                rows.append([(j, -a) for j, a in su] + extra); b.append(free[r] - spec.x_min[i])
                tags.append((k, i, -1))
    u_prev = u_prev or [0.0] * nu
    for k in range(N):
        for c_ in range(nu):
            cur = [(k * nu + c_, 1.0)] + ([(k * nu - nu + c_, -1.0)] if k else [])
            prev = 0.0 if k else u_prev[c_]
            if math.isfinite(spec.du_max[c_]):
                rows.append(cur); b.append(spec.du_max[c_] + prev); tags.append(None)
            if math.isfinite(spec.du_min[c_]):
                rows.append([(j, -a) for j, a in cur]); b.append(-spec.du_min[c_] - prev); tags.append(None)
    for g_, (ax, au, lower, upper, _soft) in enumerate(spec.groups):
        for r_ in range(len(ax)):
            with_u = any(x != 0.0 for x in au[r_])
            stages = range(0, N) if with_u else range(1, N + 1)
            for k in stages:
                # ax·x_k + au·u_k = ax·(Sx_k x0) + ax·Su_k U + au·u_k (x_0 is data)
                coef = [0.0] * n
                const = 0.0
                if k == 0:
                    const = sum(a * x for a, x in zip(ax[r_], x0))
                else:
                    for i in range(nx):
                        const += ax[r_][i] * free[(k - 1) * nx + i]
                        for j in range(n_u):
                            coef[j] += ax[r_][i] * spec.Su[(k - 1) * nx + i][j]
                if with_u:
                    for c_ in range(nu):
                        coef[k * nu + c_] += au[r_][c_]
                sparse = [(j, a) for j, a in enumerate(coef) if a != 0.0]
                if math.isfinite(upper[r_]):
                    rows.append(sparse); b.append(upper[r_] - const); tags.append((k, ("row", g_, r_), +1))
                if math.isfinite(lower[r_]):
                    rows.append([(j, -a) for j, a in sparse]); b.append(const - lower[r_])
                    tags.append((k, ("row", g_, r_), -1))
    for j in slack_of.values():
        rows.append([(j, -1.0)]); b.append(0.0); tags.append(None)
    v, lam, ok = ipm(P, c, rows, b)
    mult = {}
    for t, l in zip(tags, lam):
        if t is not None:
            mult[t] = l
    slacks = {i: v[j] for i, j in slack_of.items()}
    return v[:n_u], slacks, mult, ok


def multiplier_sums(spec, mult):
    """Σ_k (λ⁺_{k,i} + λ⁻_{k,i}) per state component i, and per row ("row", group, row) of the
    `[[mpc.constraint]]` groups: what a shared slack's weight must exceed."""
    sums = {}
    for (k, i, _side), l in mult.items():
        sums[i] = sums.get(i, 0.0) + l
    return sums


# --------------------------------------------------------------------------------------------- scenarios

QUADCOPTER_LOOP = ([0.0] * 12, [0.0, 0.0, 1.0] + [0.0] * 9, 15)  # OSQP mpc.rst: x0, xr, nsim
HOVER_LOOP = ([0.0, 1.0, 0.0, 0.2, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0],
              [0.0, 0.0, 2.0] + [0.0] * 9, 100)                 # TinyMPC quadrotor_hovering.cpp
PAPER_STEP = ([0.0, 0.0, 10.0, 0.0, 0.0, 0.0], [1.0, 1.0, 11.0, 0.0, 0.0, 0.0], 150)  # Table 3's step


def closed_loop(spec, x0, ref, steps, soft_weight=None):
    """The source's closed loop with the exact constrained solution: the largest |x_i| reached and the
    largest multiplier sum met."""
    x = x0[:]
    peak = [abs(v) for v in x]
    worst = 0.0
    for _ in range(steps):
        U, slacks, mult, ok = constrained_qp(spec, x, ref, soft_weight)
        assert ok, "the IPM did not converge on the closed loop"
        worst = max([worst] + list(multiplier_sums(spec, mult).values()))
        x = spec.predict(x, U[:spec.nu])
        peak = [max(p, abs(v)) for p, v in zip(peak, x)]
    return x, peak, worst


def region_points(spec, count, seed):
    """Points (x0, reference) of `[mpc.region]`: `count` seeded draws inside it, `count` random vertices,
    the two opposite corners (every state at one end, the reference at the other) and, for a
    `double_integrator` (decoupled axes), the 16 vertices that give every axis the same pattern of
    (position, velocity, reference position, reference velocity) ends; and, for every side of a state row
    (a `[[mpc.constraint]]` row without `au`), `count` draws moved to within a metre inside that side with
    the reference moved beyond it, where the row is active (the draws above rarely reach a wall)."""
    rng = random.Random(seed)
    lo, hi = spec.region_min, spec.region_max
    rlo = spec.ref_min or lo
    rhi = spec.ref_max or hi
    points = []
    for _ in range(count):
        points.append(([rng.uniform(a, b) for a, b in zip(lo, hi)],
                       [rng.uniform(a, b) for a, b in zip(rlo, rhi)]))
    for _ in range(count):
        points.append(([rng.choice(e) for e in zip(lo, hi)], [rng.choice(e) for e in zip(rlo, rhi)]))
    points.append((hi[:], rlo[:]))
    points.append((lo[:], rhi[:]))
    if spec.raw["model"]["type"] == "double_integrator":
        axes = spec.nx // 2
        for pattern in range(16):
            ends = [(pattern >> bit) & 1 for bit in range(4)]  # position, velocity, their references
            x = [(hi if ends[i // axes] else lo)[i] for i in range(spec.nx)]
            r = [(rhi if ends[2 + i // axes] else rlo)[i] for i in range(spec.nx)]
            points.append((x, r))
    clip = lambda v, a, b: [min(max(x, l), h) for x, l, h in zip(v, a, b)]
    for ax, au, lower, upper, _soft in spec.groups:
        for r_, row in enumerate(ax):
            if any(a != 0.0 for a in au[r_]):
                continue
            norm2 = sum(a * a for a in row)
            # The row's reach over the reference box: how far beyond the side a reference can be.
            reach_hi = sum(a * (h if a > 0 else l) for a, l, h in zip(row, rlo, rhi))
            reach_lo = sum(a * (l if a > 0 else h) for a, l, h in zip(row, rlo, rhi))
            for sign, bound, reach in [(+1, upper[r_], reach_hi), (-1, lower[r_], reach_lo)]:
                if not math.isfinite(bound):
                    continue
                for _ in range(count):
                    x = [rng.uniform(a, b) for a, b in zip(lo, hi)]
                    r = [rng.uniform(a, b) for a, b in zip(rlo, rhi)]
                    inside = bound - sign * rng.uniform(0.0, 1.0)
                    beyond = bound + sign * rng.uniform(0.0, max(0.0, sign * (reach - bound)))
                    ax_x = sum(a * v for a, v in zip(row, x))
                    ax_r = sum(a * v for a, v in zip(row, r))
                    x = [v + (inside - ax_x) * a / norm2 for v, a in zip(x, row)]
                    r = [v + (beyond - ax_r) * a / norm2 for v, a in zip(r, row)]
                    points.append((clip(x, lo, hi), clip(r, rlo, rhi)))
    return points


def report(path, samples):
    spec = Spec(path)
    print(f"{path}: nx = {spec.nx}, nu = {spec.nu}, N = {spec.N}, dt = {spec.dt}, method = {spec.method}, "
          f"iterations = {spec.iterations}, scalar = {spec.scalar}")
    lam = eigenvalues_symmetric(spec.H)
    print(f"  H: {len(spec.H)} × {len(spec.H)}, λmin = {lam[0]:.6g}, λmax = {lam[-1]:.6g}, "
          f"κ(H) = {lam[-1] / lam[0]:.4g}")
    bounded = [i for i in range(spec.nx) if math.isfinite(spec.x_min[i]) or math.isfinite(spec.x_max[i])]
    print(f"  bounded states {bounded}, {'soft, weight ' + str(spec.x_soft) if spec.x_soft else 'hard'}; "
          f"region x ∈ [{', '.join(f'{a:g}' for a in spec.region_min)}] .. "
          f"[{', '.join(f'{a:g}' for a in spec.region_max)}]")
    stem = Path(path).stem
    loop = {"quadcopter": QUADCOPTER_LOOP, "hover": HOVER_LOOP, "paper-limits": PAPER_STEP,
            "paper-geofence": PAPER_STEP}.get(stem)
    if loop:
        x0, ref, steps = loop
        x, peak, worst = closed_loop(spec, x0, ref, steps)
        outside = [i for i in range(spec.nx)
                   if not spec.region_min[i] - 1e-9 <= x0[i] <= spec.region_max[i] + 1e-9
                   or peak[i] > max(abs(spec.region_min[i]), abs(spec.region_max[i]))]
        print(f"  source closed loop, {steps} steps (hard constraints): final x = "
              f"[{', '.join(f'{v:.3g}' for v in x)}]")
        print(f"    peak |x_i| = [{', '.join(f'{v:.3g}' for v in peak)}]; largest multiplier sum {worst:.4g}")
        print(f"    region covers it: {'yes' if not outside else 'NO, components ' + str(outside)}")
    infeasible, unsolved, worst, by_key = 0, 0, 0.0, {}
    points = region_points(spec, samples, seed=17)
    for x0, ref in points:
        U, slacks, mult, ok = constrained_qp(spec, x0, ref, soft_weight=1e9)
        if not ok or max(slacks.values(), default=0.0) > 1e-7:
            infeasible += 1
            continue
        U, _, mult, ok = constrained_qp(spec, x0, ref)
        if not ok:
            unsolved += 1
            continue
        sums = multiplier_sums(spec, mult)
        worst = max([worst] + list(sums.values()))
        for key, v in sums.items():
            by_key[key] = max(by_key.get(key, 0.0), v)
    print(f"  region: {len(points)} points, hard problem infeasible "
          f"at {infeasible}{f', not solved at {unsolved}' if unsolved else ''}; largest multiplier sum where "
          f"feasible {worst:.4g}")
    states = max([v for k, v in by_key.items() if not isinstance(k, tuple)], default=0.0)
    if spec.x_soft is not None:
        verdict = "exact" if spec.x_soft > states else "NOT exact"
        print(f"  x_soft = {spec.x_soft:g}: {verdict} at every feasible point checked "
              f"(threshold {states:.4g}, the largest state component's)")
    for g, (ax, _au, _lower, _upper, soft) in enumerate(spec.groups):
        for r in range(len(ax)):
            t = by_key.get(("row", g, r), 0.0)
            verdict = "" if soft is None else (
                f"; soft = {soft:g}: {'exact' if soft > t else 'NOT exact'} at every feasible point checked")
            print(f"  [[mpc.constraint]] {g + 1}, row {r + 1}: largest multiplier sum {t:.4g}{verdict}")
    return spec


def main(argv):
    if any(a.startswith("-") for a in argv[1:]):
        print(__doc__)
        return
    paths = argv[1:] or [str(ROOT / p) for p in DEFAULT_SPECS]
    for p in paths:
        report(p, samples=20)
        print()


if __name__ == "__main__":
    main(sys.argv)
