"""An independent NumPy reference of SPEC §9 (gradients, 2D transfer functions, the joint
distribution of value and gradient magnitude), written from the SPEC, not from the C++.

It extends reference.py (SPEC §3–§5) and reuses its model (RefModel: arrays, trilinear corners),
its 1D TF (for the 1D-equivalence checks) and its ray caster (render). Everything is float64.

Conventions (SPEC §1, §9):
- arrays are (Z, Y, X[, c]), x fastest; points are index coordinates (i, j, k) = (x, y, z);
- the gradient at a grid point: central differences in world units, one-sided at the first and
  last point, 0 along an axis of one point; components (d/dx, d/dy, d/dz);
- the gradient at a sample p: the 8 corners' grid gradients blended trilinearly, so
  (X, Y) = Σ_i L_i X_i with L_i = (w_i, g_i) ∈ R⁴ over at most 32 voxels (`linear_form`);
- G = n̂·Y with n̂ = μ_Y/|μ_Y| from the `mean` array (+x where |μ_Y| = 0); u_i = n̂·g_i;
- a raster TF2: W×H points over [x0,x1]×[y0,y1], rgba (H, W, 4) with straight colour and α;
  colour and α each bilinear, clamped outside; classification gives (α·r, α·g, α·b, α).

Exactness:
- along a straight line inside a raster cell, α and c are each quadratic in the line parameter and
  α·c is quartic, so `mean_along_segment` splits a segment at every raster line it crosses (the
  first and last lines are where the clamping starts) and uses 3-point Gauss–Legendre per piece
  (exact to degree 5);
- the bivariate normal expectation conditions on one variable (the outer one, chosen as the one
  spreading over more raster cells): given the outer value a, the inner variable is normal with a
  mean linear in a and a fixed variance s², and along the inner axis the TF2 is piecewise
  quadratic, integrated in closed form (Gaussian moments per piece, as reference.py in 1D). The
  outer integral over [μ ± 10σ] uses 16-point Gauss–Legendre on pieces split every σ/2, at every
  raster line of the outer axis (kinks) and, graded geometrically (δ·{0, ±1/16, ±1/4, ±1, ±4, ±16,
  ±64}), around every outer value where the inner mean crosses an inner raster line (δ = s/|β|
  the width of that transition; with s = 0 it is a kink, hit exactly). test_reference2d_self.py
  checks it against dense tensor Gauss–Legendre over the raster cells, the other conditioning
  order, the 1D closed form, an exact line integral (rank 1) and Monte Carlo.
"""
import math

import numpy as np
from scipy.special import ndtr

import reference as ref

_GL3_X, _GL3_W = np.polynomial.legendre.leggauss(3)  # exact to degree 5
_GL16_X, _GL16_W = np.polynomial.legendre.leggauss(16)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)

# ----------------------------------------------------------------------------------------------
# Gradients (SPEC §9)
# ----------------------------------------------------------------------------------------------


def grid_gradients(values, spacing):
    """Grid-point gradients of values (..., Z, Y, X) in world units: (..., Z, Y, X, 3) with
    components (d/dx, d/dy, d/dz). Central differences, one-sided at the first and last point
    of an axis, 0 along an axis of one point."""
    v = np.asarray(values, float)
    sp = np.asarray(spacing, float)
    out = np.zeros(v.shape + (3,))
    for comp, axis in ((0, -1), (1, -2), (2, -3)):
        n = v.shape[axis]
        if n == 1:
            continue
        i = np.arange(n)
        plus, minus = np.minimum(i + 1, n - 1), np.maximum(i - 1, 0)
        den = (plus - minus) * sp[comp]  # 2·s inside, s at the ends
        shape = [1] * v.ndim
        shape[axis] = n
        d = (np.take(v, plus, axis=axis) - np.take(v, minus, axis=axis)) / den.reshape(shape)
        out[..., comp] = d
    return out


def linear_form(model, p):
    """The 32-voxel linear form of (X, Y) at index-space points p (N, 3), clamped as SPEC §3
    (RefModel.corners): flat voxel indices (N, M) and coefficients (N, M, 4) = (w_i, g_i) with
    X = Σ w_i X_i (the trilinear weights) and Y = Σ g_i X_i (the trilinear blend of the corners'
    grid gradients). Each voxel appears once per row (duplicates merged, coefficients summed);
    rows are padded with index 0 and coefficient 0."""
    p = np.atleast_2d(np.asarray(p, float))
    cidx, cw = model.corners(p)  # (N, 8)
    X, Y, Z = (int(d) for d in model.dims)
    ijk = [cidx % X, (cidx // X) % Y, cidx // (X * Y)]
    N = len(p)
    idx_l = [cidx]
    coef_l = [np.concatenate([cw[..., None], np.zeros((N, 8, 3))], -1)]
    for a, n in enumerate((X, Y, Z)):
        if n == 1:
            continue
        v = ijk[a]
        plus, minus = np.minimum(v + 1, n - 1), np.maximum(v - 1, 0)
        den = (plus - minus) * float(model.spacing[a])
        for nb, sign in ((plus, 1.0), (minus, -1.0)):
            q = [c.copy() for c in ijk]
            q[a] = nb
            idx_l.append((q[2] * Y + q[1]) * X + q[0])
            c = np.zeros((N, 8, 4))
            c[..., 1 + a] = sign * cw / den
            coef_l.append(c)
    idx = np.concatenate(idx_l, 1)  # (N, K)
    coef = np.concatenate(coef_l, 1)  # (N, K, 4)
    # Merge duplicates: sort each row, number the groups, add coefficients per group.
    order = np.argsort(idx, axis=1, kind="stable")
    idx_s = np.take_along_axis(idx, order, 1)
    coef_s = np.take_along_axis(coef, order[..., None], 1)
    new = np.ones_like(idx_s, bool)
    new[:, 1:] = idx_s[:, 1:] != idx_s[:, :-1]
    gid = np.cumsum(new, 1) - 1
    M = int(gid.max()) + 1
    rows = np.repeat(np.arange(N)[:, None], idx.shape[1], 1)
    out_idx = np.zeros((N, M), int)
    out_coef = np.zeros((N, M, 4))
    out_idx[rows[new], gid[new]] = idx_s[new]
    np.add.at(out_coef, (rows, gid), coef_s)
    return out_idx, out_coef


def gradient_at(model, arr, p):
    """Direct evaluation: trilinear blend of grid_gradients(arr) at p (N, 3) → (N, 3)."""
    g = grid_gradients(arr, model.spacing)
    idx, w = model.corners(np.atleast_2d(np.asarray(p, float)))
    return model._lerp(g, idx, w)


# ----------------------------------------------------------------------------------------------
# Raster 2D TF (SPEC §9)
# ----------------------------------------------------------------------------------------------


class TF2:
    """W×H raster over [x0,x1]×[y0,y1]: rgba (H, W, 4), straight colour (r, g, b) and α; row j at
    y0 + j·(y1−y0)/(H−1), column i at x0 + i·(x1−x0)/(W−1). Colour and α each bilinear, clamped
    outside the domain."""

    def __init__(self, rgba, domain):
        self.rgba = np.array(rgba, float)
        assert self.rgba.ndim == 3 and self.rgba.shape[2] == 4
        self.H, self.W = self.rgba.shape[:2]
        assert self.W >= 2 and self.H >= 2
        self.x0, self.x1, self.y0, self.y1 = (float(v) for v in domain)
        assert self.x1 > self.x0 and self.y1 > self.y0
        self.xs = self.x0 + (self.x1 - self.x0) * np.arange(self.W) / (self.W - 1)
        self.ys = self.y0 + (self.y1 - self.y0) * np.arange(self.H) / (self.H - 1)
        self.dx = (self.x1 - self.x0) / (self.W - 1)
        self.dy = (self.y1 - self.y0) / (self.H - 1)

    @property
    def domain(self):
        return (self.x0, self.x1, self.y0, self.y1)

    @property
    def T(self):
        """The same TF2 with its axes swapped: T(y, x) = self(x, y)."""
        return TF2(self.rgba.transpose(1, 0, 2), (self.y0, self.y1, self.x0, self.x1))

    @staticmethod
    def from_1d(rgb, alpha, x0, x1, y0=0.0, y1=1.0, H=2):
        """A TF2 constant in y with columns (rgb (W,3), alpha (W,)) at W even x, and the 1D TF of
        reference.py that is the same function of x (control points at the columns)."""
        rgb = np.asarray(rgb, float)
        alpha = np.asarray(alpha, float)
        W = len(alpha)
        col = np.concatenate([rgb, alpha[:, None]], 1)  # (W, 4)
        t2 = TF2(np.broadcast_to(col, (H, W, 4)), (x0, x1, y0, y1))
        return t2, ref.TF(t2.xs, rgb, t2.xs, alpha)

    def _locate(self, v, lo, hi, n):
        u = np.clip((np.asarray(v, float) - lo) / (hi - lo) * (n - 1), 0.0, n - 1.0)
        i0 = np.minimum(np.floor(u).astype(int), n - 2)
        return i0, u - i0

    def straight(self, x, y):
        """Bilinear straight (r, g, b, α) at (x, y): shape x.shape + (4,)."""
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        i0, fx = self._locate(x, self.x0, self.x1, self.W)
        j0, fy = self._locate(y, self.y0, self.y1, self.H)
        R = self.rgba
        fx, fy = fx[..., None], fy[..., None]
        return ((1 - fy) * ((1 - fx) * R[j0, i0] + fx * R[j0, i0 + 1])
                + fy * ((1 - fx) * R[j0 + 1, i0] + fx * R[j0 + 1, i0 + 1]))

    def __call__(self, x, y):
        """(α·r, α·g, α·b, α) at (x, y): shape x.shape + (4,)."""
        s = self.straight(x, y)
        return np.concatenate([s[..., :3] * s[..., 3:], s[..., 3:]], -1)

    classify = __call__

    # -- files --------------------------------------------------------------------------------
    def write_npy(self, path):
        """(H, W, 4) float32; the domain goes on the command line (--tf2-domain x0,x1,y0,y1)."""
        np.save(str(path), self.rgba.astype(np.float32))

    def domain_arg(self):
        return ",".join(repr(v) for v in self.domain)

    def write_vti(self, path, binary=False):
        """VTK XML ImageData, W×H×1 points, one 4-component Float32 point array "rgba" (the
        active scalars), inline ASCII or raw base64 (UInt64 header)."""
        import base64
        data = np.ascontiguousarray(self.rgba, dtype="<f4")  # x fastest, then y
        if binary:
            raw = data.tobytes()
            payload = base64.b64encode(np.uint64(len(raw)).astype("<u8").tobytes() + raw)
            text, fmt = payload.decode("ascii"), "binary"
        else:
            text, fmt = " ".join(repr(float(v)) for v in data.ravel()), "ascii"
        ext = "0 %d 0 %d 0 0" % (self.W - 1, self.H - 1)
        xml = (
            '<?xml version="1.0"?>\n'
            '<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian"'
            ' header_type="UInt64">\n'
            '  <ImageData WholeExtent="%s" Origin="%r %r 0" Spacing="%r %r 1">\n'
            '    <Piece Extent="%s">\n'
            '      <PointData Scalars="rgba">\n'
            '        <DataArray type="Float32" Name="rgba" NumberOfComponents="4"'
            ' format="%s">\n'
            '          %s\n'
            '        </DataArray>\n'
            '      </PointData>\n'
            '      <CellData>\n'
            '      </CellData>\n'
            '    </Piece>\n'
            '  </ImageData>\n'
            '</VTKFile>\n') % (ext, self.x0, self.y0, self.dx, self.dy, ext, fmt, text)
        with open(path, "w") as fh:
            fh.write(xml)

    @staticmethod
    def read_vti(path):
        """Read back what write_vti writes (ASCII or binary with a UInt64 header)."""
        import base64
        import xml.etree.ElementTree as ET
        root = ET.parse(str(path)).getroot()
        img = root.find("ImageData")
        ext = [int(v) for v in img.get("WholeExtent").split()]
        org = [float(v) for v in img.get("Origin").split()]
        spc = [float(v) for v in img.get("Spacing").split()]
        W, H = ext[1] - ext[0] + 1, ext[3] - ext[2] + 1
        da = img.find("Piece/PointData/DataArray")
        if da.get("format") == "ascii":
            vals = np.array(da.text.split(), float)
        else:
            raw = base64.b64decode(da.text.strip())
            vals = np.frombuffer(raw[8:], "<f4").astype(float)
        return TF2(vals.reshape(H, W, 4),
                   (org[0], org[0] + spc[0] * (W - 1), org[1], org[1] + spc[1] * (H - 1)))


def random_tf2(rng, xr, yr, W=7, H=5, zero_frac=0.25):
    """Random raster over [xr]×[yr], float32-exact values, some α exactly 0."""
    rgba = rng.uniform(0, 1, (H, W, 4))
    rgba[..., 3][rng.random((H, W)) < zero_frac] = 0.0
    rgba = rgba.astype(np.float32).astype(float)
    return TF2(rgba, (xr[0], xr[1], yr[0], yr[1]))


# ----------------------------------------------------------------------------------------------
# Exact mean along a segment (quantile models)
# ----------------------------------------------------------------------------------------------


def mean_along_segment(tf2, P0, P1):
    """Mean of (α·c, α) over the segment P0 → P1 (uniform in the line parameter), exactly: split
    at every raster line crossed, 3-point Gauss–Legendre per piece. P0, P1 (..., 2); a
    zero-length segment gives TF2 at the point. Returns (..., 4)."""
    P0 = np.asarray(P0, float)
    P1 = np.asarray(P1, float)
    shape = np.broadcast_shapes(P0.shape, P1.shape)[:-1]
    A = np.broadcast_to(P0, shape + (2,)).reshape(-1, 2)
    B = np.broadcast_to(P1, shape + (2,)).reshape(-1, 2)
    d = B - A
    cuts = [np.zeros((len(A), 1)), np.ones((len(A), 1))]
    for comp, lines in ((0, tf2.xs), (1, tf2.ys)):
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (lines[None, :] - A[:, comp:comp + 1]) / d[:, comp:comp + 1]
        cuts.append(np.where(np.isfinite(t), np.clip(t, 0.0, 1.0), 0.0))
    T = np.sort(np.concatenate(cuts, 1), 1)
    lo, hi = T[:, :-1], T[:, 1:]
    half = 0.5 * (hi - lo)
    nodes = (0.5 * (hi + lo))[..., None] + half[..., None] * _GL3_X  # (N, P, 3)
    pts = A[:, None, None, :] + nodes[..., None] * d[:, None, None, :]
    f = tf2(pts[..., 0], pts[..., 1])  # (N, P, 3, 4)
    m = np.einsum("np,g,npgc->nc", half, _GL3_W, f)
    zero = np.all(d == 0, axis=1)
    if zero.any():
        m[zero] = tf2(A[zero, 0], A[zero, 1])
    return m.reshape(shape + (4,))


# ----------------------------------------------------------------------------------------------
# Bivariate normal expectation
# ----------------------------------------------------------------------------------------------

_GRADING = np.array([0.0, 1 / 16, -1 / 16, 0.25, -0.25, 1.0, -1.0, 4.0, -4.0, 16.0, -16.0, 64.0,
                     -64.0])


def inner_normal(tf2, a, mb, s):
    """E[(α·c, α)(a, B)] with B ~ N(mb, s²) (a = the tf2's x, B its y): closed form per piece
    between the y lines (along y at fixed x, α and c are linear, α·c quadratic). a, mb any
    broadcastable shapes, s > 0. Returns shape + (4,)."""
    a, mb, s = np.broadcast_arrays(np.asarray(a, float), np.asarray(mb, float),
                                   np.asarray(s, float))
    i0, fa = tf2._locate(a, tf2.x0, tf2.x1, tf2.W)
    Rt = tf2.rgba.transpose(1, 0, 2)  # (W, H, 4)
    fa = fa[..., None, None]
    lines = (1 - fa) * Rt[i0] + fa * Rt[i0 + 1]  # (..., H, 4) straight values on the y lines
    al, col = lines[..., 3], lines[..., :3]
    z = (tf2.ys - mb[..., None]) / s[..., None]  # (..., H)
    cdf, sf = ndtr(z), ndtr(-z)
    pdf = np.exp(-0.5 * z * z) * _INV_SQRT_2PI
    za, zb = z[..., :-1], z[..., 1:]
    M0 = np.where(za > 0, sf[..., :-1] - sf[..., 1:], cdf[..., 1:] - cdf[..., :-1])
    M1 = pdf[..., :-1] - pdf[..., 1:]
    M2 = M0 + za * pdf[..., :-1] - zb * pdf[..., 1:]
    tm = (mb[..., None] - tf2.ys[:-1]) / tf2.dy  # τ at z = 0, (..., H−1)
    e = (s / tf2.dy)[..., None]
    da = al[..., 1:] - al[..., :-1]
    p0, p1 = al[..., :-1] + da * tm, da * e
    dc = col[..., 1:, :] - col[..., :-1, :]
    q0, q1 = col[..., :-1, :] + dc * tm[..., None], dc * e[..., None]
    P0, P1 = p0[..., None], p1[..., None]
    rgb = np.sum(P0 * q0 * M0[..., None] + (P0 * q1 + P1 * q0) * M1[..., None]
                 + P1 * q1 * M2[..., None], axis=-2)
    alpha = np.sum(p0 * M0 + p1 * M1, axis=-1)
    lo_v = np.concatenate([col[..., 0, :] * al[..., 0:1], al[..., 0:1]], -1)
    hi_v = np.concatenate([col[..., -1, :] * al[..., -1:], al[..., -1:]], -1)
    out = np.concatenate([rgb, alpha[..., None]], -1)
    return out + cdf[..., 0:1] * lo_v + sf[..., -1:] * hi_v


def _gauss_outer(tf2, ma, mb, vaa, vab, vbb, L=10.0, width=0.5):
    """E over (A, B) ~ N((ma, mb), [[vaa, vab], [vab, vbb]]), A the tf2's x, vaa > 0; arrays (N,).
    Conditions on A (see the module docstring)."""
    sa = np.sqrt(vaa)
    beta = vab / vaa
    s = np.sqrt(np.maximum(vbb - vab * beta, 0.0))
    N = len(ma)
    base = ma[:, None] + sa[:, None] * np.arange(-L, L + 0.5 * width, width)[None, :]
    grid = np.broadcast_to(tf2.xs, (N, tf2.W))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        astar = ma[:, None] + (tf2.ys[None, :] - mb[:, None]) / beta[:, None]  # (N, H)
        delta = s / np.abs(beta)
        g = astar[..., None] + delta[:, None, None] * _GRADING  # (N, H, 13)
    g = np.where(np.isfinite(g), g, ma[:, None, None]).reshape(N, -1)
    pts = np.concatenate([base, grid, g], 1)
    pts = np.sort(np.clip(pts, (ma - L * sa)[:, None], (ma + L * sa)[:, None]), 1)
    lo, hi = pts[:, :-1], pts[:, 1:]
    half = 0.5 * (hi - lo)
    nodes = (0.5 * (hi + lo))[..., None] + half[..., None] * _GL16_X  # (N, I, 16)
    zz = (nodes - ma[:, None, None]) / sa[:, None, None]
    wts = half[..., None] * _GL16_W * np.exp(-0.5 * zz * zz) * _INV_SQRT_2PI / sa[:, None, None]
    mbn = mb[:, None, None] + beta[:, None, None] * (nodes - ma[:, None, None])
    pos = s > 1e-13 * tf2.dy  # below this the inner normal is a point (error O(s), and z
    inner = np.empty(nodes.shape + (4,))  # = (y − mb)/s would overflow)
    if pos.any():
        inner[pos] = inner_normal(tf2, nodes[pos], mbn[pos],
                                  np.broadcast_to(s[:, None, None], nodes.shape)[pos])
    if (~pos).any():
        inner[~pos] = tf2(nodes[~pos], mbn[~pos])
    return np.einsum("nig,nigc->nc", wts, inner)


def gaussian_expectation2d(tf2, mx, my, vxx, vxy, vyy, orient=None, chunk=48):
    """E[(α·c, α)(X, Y)] for (X, Y) ~ N((mx, my), [[vxx, vxy], [vxy, vyy]]); arrays (N,).
    orient: None (condition on the variable spreading over more raster cells), "x" or "y"
    (force the conditioning variable where its variance is positive; for the self-test)."""
    mx, my, vxx, vxy, vyy = (np.atleast_1d(np.asarray(v, float)) for v in
                             np.broadcast_arrays(mx, my, vxx, vxy, vyy))
    out = np.empty(mx.shape + (4,))
    rx = np.sqrt(np.maximum(vxx, 0)) / tf2.dx
    ry = np.sqrt(np.maximum(vyy, 0)) / tf2.dy
    if orient == "x":
        use_x = vxx > 0
    elif orient == "y":
        use_x = ~(vyy > 0) & (vxx > 0)
    else:
        use_x = (rx >= ry) & (vxx > 0)
    use_y = ~use_x & (vyy > 0)
    point = ~use_x & ~use_y
    if point.any():
        out[point] = tf2(mx[point], my[point])
    t2T = tf2.T
    for sel, t, a, b, vaa, vbb in ((use_x, tf2, mx, my, vxx, vyy),
                                   (use_y, t2T, my, mx, vyy, vxx)):
        ids = np.nonzero(sel)[0]
        for k in range(0, len(ids), chunk):
            c = ids[k:k + chunk]
            out[c] = _gauss_outer(t, a[c], b[c], vaa[c], vxy[c], vbb[c])
    return out


# ----------------------------------------------------------------------------------------------
# The joint distributions of SPEC §9 and classification with a TF2
# ----------------------------------------------------------------------------------------------

QUANTILE_KINDS = ("quantile-range", "quantile-mean", "quantile-mean-mass", "iqr",
                  "quartile-lower", "quartile-middle", "quartile-upper")
KINDS = ("mean", "gaussian") + QUANTILE_KINDS
# Every model of the model table (udvr.models()) that renders with a 2D TF, by CLI name → the
# joint distribution of SPEC §9 this module evaluates for it (Sample2D.classify); a fast form and
# its exact form share one. test_reference_coverage.py fails for a row of the table that is
# neither here nor in NO_REFERENCE: adding a model adds its reference.
MODELS = dict({k: k for k in KINDS}, **{"gaussian-exact": "gaussian"})
# Rows of the table with a 2D TF and no reference here, each with why and what checks it instead
# (test_reference2d_cli.py runs those checks over exactly these names).
NO_REFERENCE = {
    name: "the bivariate box spline (X, G) = Σ_i t_i·(w_i, u_i)·h_i has no closed form here: "
          "checked against Monte Carlo at probe level (test_reference2d_cli.py "
          "test_probe_tf2_uniform_matches_monte_carlo) and, with a TF2 constant in y, against "
          "the 1D image (test_render_tf2_constant_in_y_is_the_1d_render)"
    for name in ("uniform", "uniform-fast", "uniform-exact")}


class Sample2D:
    """Everything SPEC §9 defines at index-space points p (N, 3) of a RefModel."""

    def __init__(self, model, p):
        self.model = model
        self.p = np.atleast_2d(np.asarray(p, float))
        self.idx, self.coef = linear_form(model, self.p)  # (N, M), (N, M, 4)
        self.w = self.coef[..., 0]
        # x̄ and μ_Y by the direct path (corners' values and grid gradients blended), so that a
        # constant field has μ_Y = 0 exactly (the merged form's coefficients need not cancel).
        self.xbar = model.mean_at(self.p)
        self.mu_y = gradient_at(model, model.mean, self.p)  # μ_Y (N, 3), world units
        norm = np.linalg.norm(self.mu_y, axis=1)
        self.grad_norm = norm
        nh = np.zeros_like(self.mu_y)
        nh[:, 0] = 1.0
        ok = norm > 0
        nh[ok] = self.mu_y[ok] / norm[ok, None]
        self.nhat = nh
        self.u = np.einsum("nmc,nc->nm", self.coef[..., 1:], nh)  # u_i = n̂·g_i

    # -- gaussian ----------------------------------------------------------------------------
    def gaussian(self):
        """(μ_X, μ_G, var X, cov, var G), each (N,)."""
        s2 = self.model.stddev.ravel()[self.idx] ** 2
        w, u = self.w, self.u
        mg = np.einsum("nc,nc->n", self.nhat, self.mu_y)
        return (self.xbar, mg, np.sum(w * w * s2, 1), np.sum(w * u * s2, 1),
                np.sum(u * u * s2, 1))

    # -- quantile models ---------------------------------------------------------------------
    def polyline(self, arr="quantiles"):
        """Vertices (X_j, G_j) of the rank-coupled polyline: (N, q+1) each."""
        A = self.model.quantiles if arr == "quantiles" else self.model.iqr
        Bv = A.reshape(-1, A.shape[-1])[self.idx]  # (N, M, q+1)
        return np.einsum("nm,nmj->nj", self.w, Bv), np.einsum("nm,nmj->nj", self.u, Bv)

    def vertices(self, kind):
        """The polyline's vertices over the kind's population and each segment's share."""
        Xv, Gv = self.polyline("iqr" if kind == "iqr" else "quantiles")
        j0, j1, share = self.model.population(kind)
        return Xv[:, j0:j1 + 1], Gv[:, j0:j1 + 1], share

    def classify(self, kind, tf2):
        kind = MODELS.get(kind, kind)  # a CLI name → its joint distribution
        if kind == "mean":
            return tf2(self.xbar, self.grad_norm)
        if kind == "gaussian":
            mx, mg, vxx, vxg, vgg = self.gaussian()
            return gaussian_expectation2d(tf2, mx, mg, vxx, vxg, vgg)
        if kind not in QUANTILE_KINDS:
            raise ValueError("no 2D classification for model " + kind)
        Xv, Gv, share = self.vertices(kind)
        P = np.stack([Xv, Gv], -1)  # (N, S+1, 2)
        if kind in ("quantile-mean", "quantile-mean-mass"):
            mids = 0.5 * (P[:, 1:] + P[:, :-1])
            pw = self.model.quantile_mean_weights(np.diff(Xv, axis=1), kind)
            return np.sum(pw[..., None] * tf2(mids[..., 0], mids[..., 1]), axis=1)
        m = mean_along_segment(tf2, P[:, :-1], P[:, 1:])  # (N, S, 4)
        return np.sum(share[None, :, None] * m, axis=1)

    def gradient_magnitude(self, kind):
        """Mean and standard deviation of G (N,) each (SPEC §9 probe output)."""
        kind = MODELS.get(kind, kind)
        if kind == "mean":
            return self.grad_norm, np.zeros_like(self.grad_norm)
        if kind == "gaussian":
            _, mg, _, _, vgg = self.gaussian()
            return mg, np.sqrt(vgg)
        _, Gv, share = self.vertices(kind)  # t uniform within each segment's rank range
        a, b = Gv[:, :-1], Gv[:, 1:]
        m = np.sum(share * 0.5 * (a + b), axis=1)
        m2 = np.sum(share * (a * a + a * b + b * b) / 3.0, axis=1)
        return m, np.sqrt(np.maximum(m2 - m * m, 0.0))


def classify2d(model, kind, tf2, p):
    """(N, 4) expected (α·r, α·g, α·b, α) with a TF2 at index-space points p (N, 3)."""
    return Sample2D(model, p).classify(kind, tf2)


def probe2d(model, kind, tf2, point):
    """What `udvr probe --tf2 --json` reports at one point (SPEC §9)."""
    s = Sample2D(model, np.asarray(point, float)[None, :])
    gm, gs = s.gradient_magnitude(kind)
    return dict(expected_rgba=s.classify(kind, tf2)[0], gradient=s.mu_y[0],
                gradient_magnitude=dict(mean=float(gm[0]), stddev=float(gs[0])))


# ----------------------------------------------------------------------------------------------
# Rendering (SPEC §5 with the 2D classification)
# ----------------------------------------------------------------------------------------------


class _Classify2D:
    """A RefModel whose classify(kind, tf2, p) is the 2D one, for reference.render."""

    def __init__(self, model, chunk=4096):
        self._m = model
        self._chunk = chunk

    def __getattr__(self, name):
        return getattr(self._m, name)

    def classify(self, kind, tf2, p):
        p = np.atleast_2d(p)
        return np.concatenate([classify2d(self._m, kind, tf2, p[k:k + self._chunk])
                               for k in range(0, len(p), self._chunk)] or [np.zeros((0, 4))])


def render2d(model, kind, tf2, width, height, cam, **kw):
    """reference.render (SPEC §5: camera, samples, opacity correction, compositing) with the
    SPEC §9 classification per sample. Keyword arguments as reference.render."""
    return ref.render(_Classify2D(model), kind, tf2, width, height, cam, **kw)


def gradient_magnitude_range(model):
    """Largest |μ_Y| over the grid points (the 2D TF's natural y range is [0, this])."""
    return float(np.linalg.norm(grid_gradients(model.mean, model.spacing), axis=-1).max())
