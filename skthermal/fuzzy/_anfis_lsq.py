"""Least squares for the consequents of ANFIS (the linear half of hybrid learning).

METHODS §6 (Jang 1993, §IV): with the premise parameters fixed, the output is
linear in the consequents, ``yhat = A theta`` with the design matrix ``A``
holding one column ``wbar_r x~_a`` per rule ``r`` and input ``a`` of
``x~ = [x, 1]``. :func:`solve_consequents` solves it for any ``A``;
:class:`NormalEquations` forms ``A^T A`` and ``A^T Y`` of the training loop
without ``A`` (the bulk of the work of an epoch).
"""

import numpy as np
from scipy import linalg
from scipy.linalg import blas, lapack

# Largest block of rule-pair products formed at once (elements): bounds the
# memory of :class:`NormalEquations` for large rule bases, whatever the
# number of samples.
_BLOCK_ELEMENTS = 1 << 21
# Most input-pair products kept per design-matrix column (see
# :meth:`NormalEquations.plan`).
_MAX_PAIR_RATIO = 4
# Relative ridge of the columns a ridge leaves free (the rules' constant terms
# with ``penalize_intercepts=False``): enough to keep a rule that hardly fires
# well posed, too little to shrink anything. (It equals the default ridge,
# itself only a stabiliser: the inputs are centred for the solve, so the
# constant terms it touches sit at the output's level at the data.)
FREE_RIDGE = 1e-8


def solve_consequents(A, Y, ridge, free=None):
    """Least-squares consequents for the design matrix ``A`` and targets ``Y``.

    ``ridge > 0`` solves the ridge problem by Cholesky with
    ``lam = ridge * mean(diag(A^T A))`` (free of the target's unit; it keeps
    rules that hardly fire, and collinear inputs, well posed): from the normal
    equations ``(A^T A + lam I) theta = A^T Y`` when ``A`` has more rows than
    columns, else from the dual ``(A A^T + lam I) alpha = Y``,
    ``theta = A^T alpha`` (the same solution, and a grid of many rules on few
    samples never forms a huge ``A^T A``). Columns marked in ``free`` (the
    rules' constant terms, when the ridge should shrink slopes only) get
    only the stabilising ridge :data:`FREE_RIDGE` instead of ``ridge``.
    ``ridge == 0`` (or a failed factorisation) uses LAPACK's SVD-based
    ``gelsd``, the minimum-norm solution. All outputs are solved at once.

    Returns
    -------
    ndarray of shape (n_columns, n_outputs)
    """
    n, p = A.shape
    if ridge > 0:
        if p > n:  # the dual, on columns scaled so that every penalty is lam
            weights = np.sqrt(penalty_weights(ridge, p, free))
            lam = relative_lambda(ridge, float(np.einsum("ij,ij->", A, A)), p)
            As = A / weights
            theta = _cholesky(_gram(As.T), Y, np.full(n, lam))
            if theta is not None:
                return (As.T @ theta) / weights[:, None]
        else:
            theta = cholesky_ridge(_gram(A), A.T @ Y, ridge, p, free)
            if theta is not None:
                return theta
    theta, *_ = linalg.lstsq(A, Y, lapack_driver="gelsd")
    return theta


def _gram(A):
    """Upper triangle of ``A^T A`` (BLAS ``syrk``: half the work of a product)."""
    A = np.ascontiguousarray(A)
    # A C-ordered A is a Fortran-ordered A^T: syrk(trans=0) on it gives A^T A.
    return blas.dsyrk(1.0, A.T, trans=0, lower=0)


def relative_lambda(ridge, trace, n_columns):
    """The ridge's penalty ``lam``: ``ridge`` times the mean diagonal of the
    normal equations (``trace`` of ``A^T A`` over its ``n_columns``)."""
    return ridge * trace / max(n_columns, 1)


def penalty_weights(ridge, n_columns, free=None):
    """Relative ridge of every column: 1, or ``FREE_RIDGE / ridge`` if free."""
    weights = np.ones(n_columns)
    if free is not None:
        weights[np.asarray(free, dtype=bool)] = min(1.0, FREE_RIDGE / ridge)
    return weights


def cholesky_ridge(G, B, ridge, n_columns, free=None):
    """Solve ``(G + lam D) theta = B``, ``lam = ridge * trace(G) / n_columns``.

    ``D`` is the identity, except that columns marked in ``free`` get the
    stabilising ridge :data:`FREE_RIDGE` in place of ``ridge``. Only the
    upper triangle of ``G`` is read (and ``G`` is overwritten). Returns None
    when ``lam`` is 0 or the factorisation fails.
    """
    lam = relative_lambda(ridge, np.trace(G), n_columns)
    if not lam > 0:
        return None
    return _cholesky(G, B, lam * penalty_weights(ridge, G.shape[0], free))


def _cholesky(G, B, diagonal):
    """``(G + diag(diagonal))^-1 B`` from the upper triangle of ``G``, or None."""
    G.flat[:: G.shape[0] + 1] += diagonal
    # LAPACK directly: the scipy wrappers' checks cost more than this small
    # factorisation.
    factor, info = lapack.dpotrf(G, lower=0, overwrite_a=1, clean=0)
    if info != 0:
        return None
    theta, info = lapack.dpotrs(factor, B, lower=0)
    return theta if info == 0 else None


def _pair_positions(k):
    """``(k, k)`` table of the position of pair ``(min, max)`` in ``triu(k)``."""
    iu, ju = np.triu_indices(k)
    pos = np.empty((k, k), dtype=np.intp)
    pos[iu, ju] = pos[ju, iu] = np.arange(iu.size)
    return pos


def _outer_rows(factors):
    """Row-wise outer product of ``(k_i, n)`` matrices, ``(prod k_i, n)``.

    Rows ordered with the first factor slowest; a loop over the factors, not
    the samples.
    """
    out = factors[0]
    for f in factors[1:]:
        out = np.multiply(out[:, None, :], f[None, :, :]).reshape(-1, f.shape[-1])
    return out


def _grid_split(n_t, d, n_z):
    """Where to split the inputs of a grid for :class:`NormalEquations`.

    The first ``s`` inputs' membership-pair products form the left factor
    (``n_t^s`` rows), the others' times the ``n_z`` input-pair products the
    right one (``n_t^(d-s) n_z`` rows); returns the ``s`` forming the fewest
    rows, and that number.
    """

    def built(k):  # rows formed by the outer products of k inputs
        return sum(n_t**i for i in range(2, k + 1))

    best = None
    for s in range(1, d + 1):
        rows = built(s) + (built(d - s) + n_t ** (d - s) * n_z if s < d else 0)
        if best is None or rows < best[1]:
            best = (s, rows)
    return best


class NormalEquations:
    """The consequents' normal equations of one training set, without ``A``.

    The design matrix has one column per input ``a`` (of ``x~ = [x, 1]``) and
    rule ``r``, ``wbar_r x~_a``, so that its Gram matrix is

    ``G[(a, i), (b, j)] = sum_n wbar_ni wbar_nj x~_na x~_nb``,

    the single matrix product ``Q Z^T`` of the rule-pair products ``Q``
    (``wbar_i wbar_j``, i <= j) and the input-pair products ``Z``
    (``x~_a x~_b``, a <= b, fixed: formed once), read out by an index table.
    For a grid rule base with normalised memberships ``nu_jm`` on every input
    (``wbar_r = prod_j nu_{j, rules[r, j]}``), a rule-pair product is a product
    over inputs of membership-pair products ``nu_jm nu_jm'``, so only
    ``(M (M + 1) / 2)^d`` of them are distinct (81 rather than the 136 rule
    pairs of 16 rules on 4 inputs), formed by outer products. Likewise
    ``A^T Y`` is one product of the rule weights with the fixed ``x~ y``.

    Compared with the BLAS ``syrk`` of the ``(R (d + 1), n)`` design matrix
    this takes ``n (#Q) (d + 1)(d + 2) / 2`` rather than
    ``n R^2 (d + 1)^2 / 2`` multiply-adds; :meth:`plan` picks it only when
    that is fewer.

    Parameters
    ----------
    X1T : ndarray of shape (d + 1, n)
        Inputs with a trailing row of ones, samples along the last axis.
    YT : ndarray of shape (n_outputs, n)
        Targets.
    rules : ndarray of shape (n_rules, d)
    n_mfs : int
    grid : bool
        Whether ``rules`` is the full grid (then :meth:`gram` takes the
        per-input normalised memberships).
    """

    def __init__(self, X1T, YT, rules, n_mfs, grid):
        p, n = X1T.shape
        n_rules, d = rules.shape
        self.grid = grid
        self.n_rules = n_rules
        self.n_columns = p * n_rules
        ia, ib = np.triu_indices(p)
        self.Z = X1T[ia] * X1T[ib]  # (p (p + 1) / 2, n)
        self.XY = (X1T[:, None, :] * YT[None]).reshape(-1, n)  # (p o, n)
        self.n_outputs = YT.shape[0]
        n_z = self.Z.shape[0]
        if grid:
            pos = _pair_positions(n_mfs)
            self.mi, self.mj = np.triu_indices(n_mfs)
            n_t = self.mi.size
            t = pos[rules[:, None, :], rules[None, :, :]]  # (R, R, d)
            qidx = t @ (n_t ** np.arange(d - 1, -1, -1))
            self.n_pairs = n_t**d
            self.split, rows = _grid_split(n_t, d, n_z)
        else:
            self.iu, self.ju = np.triu_indices(n_rules)
            qidx = _pair_positions(n_rules)
            self.n_pairs = self.iu.size
            rows = self.n_pairs + n_z
        self.rows_built = rows
        zidx = _pair_positions(p)
        # Flat position of every Gram entry in the matrix product below: row
        # major (rule pair, input pair) for either split of a grid.
        self.index = (qidx[None, :, None, :] * n_z + zidx[:, None, :, None]).reshape(
            self.n_columns, self.n_columns
        )
        self.block = max(1, _BLOCK_ELEMENTS // (rows + n_z))

    @staticmethod
    def plan(X1T, YT, rules, n_mfs, grid, ridge):
        """A :class:`NormalEquations`, or None when the ``syrk`` route is cheaper.

        None also when ``ridge`` is 0 (the minimum-norm solution needs ``A``)
        or there are more columns than samples (the dual is cheaper).
        """
        p, n = X1T.shape
        n_rules, d = rules.shape
        n_columns = p * n_rules
        if not ridge > 0 or n_columns > n:
            return None
        n_z = p * (p + 1) // 2
        if grid:
            n_t = n_mfs * (n_mfs + 1) // 2
            n_pairs, rows = n_t**d, _grid_split(n_t, d, n_z)[1]
        else:
            n_pairs = n_rules * (n_rules + 1) // 2
            rows = n_pairs
        # Multiply-adds per sample of each route (products formed, then the
        # matrix product; syrk: the design matrix, then half its Gram).
        if n_pairs * n_z + rows >= n_columns * (n_columns + 3) // 2:
            return None
        # Memory: the input-pair products are kept for every sample. Many
        # inputs on few rules (300 inputs: 45,000 products, 0.7 GB on 2,000
        # rows) take the design matrix instead, 50 times smaller there.
        if n_z > _MAX_PAIR_RATIO * n_columns and n_z * n > _BLOCK_ELEMENTS:
            return None
        return NormalEquations(X1T, YT, rules, n_mfs, grid)

    def _factors(self, wT, nu, sl):
        """Two matrices whose product ``L @ R.T`` holds every Gram entry.

        Generic rule base: the rule-pair products and the input-pair
        products. Grid: the outer product of the membership-pair products of
        the first ``split`` inputs, and that of the other inputs times the
        input-pair products (the same numbers as all rule-pair products
        against the input-pair products, with fewer products formed and a
        squarer matrix product).
        """
        Z = self.Z[:, sl]
        if not self.grid:
            w = wT[:, sl]
            return w[self.iu] * w[self.ju], Z
        nu = nu[:, :, sl]
        d, _, n = nu.shape
        q = np.empty((d, self.mi.size, n))  # membership-pair products
        for t, (a, b) in enumerate(zip(self.mi, self.mj, strict=True)):
            np.multiply(nu[:, a], nu[:, b], out=q[:, t])
        left = _outer_rows(q[: self.split])
        right = Z
        if self.split < d:
            right = _outer_rows([_outer_rows(q[self.split :]), Z])
        return left, right

    def gram(self, wT, nu=None):
        """``A^T A`` (n_columns, n_columns), columns ordered (input, rule).

        ``wT`` are the normalised firing strengths (R, n); ``nu`` the
        per-input normalised memberships (d, M, n) of a grid rule base.
        """
        n = wT.shape[1]
        if n <= self.block:
            left, right = self._factors(wT, nu, slice(None))
            GP = left @ right.T
        else:
            GP = 0.0
            for start in range(0, n, self.block):  # blocks of samples
                left, right = self._factors(wT, nu, slice(start, start + self.block))
                GP = GP + left @ right.T
        return GP.ravel()[self.index]

    def rhs(self, wT):
        """``A^T Y`` (n_columns, n_outputs), columns ordered (input, rule)."""
        B = (self.XY @ wT.T).reshape(-1, self.n_outputs, self.n_rules)
        return B.transpose(0, 2, 1).reshape(self.n_columns, self.n_outputs)

    def solve(self, wT, nu, ridge, free=None):
        """Ridge consequents ``(n_columns, n_outputs)``, or None on failure.

        ``free`` marks the columns :func:`cholesky_ridge` leaves unshrunk.
        """
        return cholesky_ridge(
            self.gram(wT, nu), self.rhs(wT), ridge, self.n_columns, free
        )
