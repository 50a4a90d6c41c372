#include "udvr/classify/expected_tf2_fast.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <numbers>

#include "udvr/classify/expected_tf2_gaussian.h"
#include "udvr/util/fast_math.h"
#include "udvr/util/normal_cdf.h"

namespace udvr {

/// One axis of N points (raster cells 0 … N − 1): per blur level its grid and the blurred
/// piecewise-quadratic basis (index 2i: the C0 quadratic node i, 2i + 1: the bubble of cell i;
/// node 0 and N − 1 continued as constants beyond the domain, as the raster clamps) at each
/// grid point, as a window of nonzero values.
struct Tf2BlurTables::Axis {
    struct Level {
        double blur = 0.0, spacing = 0.0, start = 0.0;
        int count = 0;
        std::vector<int> first, size, offset;  // per grid point: the basis window into `values`
        std::vector<double> values;
    };
    int points = 2;
    std::vector<Level> levels;

    /// Levels kMinBlur·√2^k up to past `widest`, with steps − 1 levels 2^(1/(2·steps)) apart
    /// between each two (the y axis: `gaussian` takes them all, the box spline every steps-th,
    /// the same blurs to the bit as with steps 1).
    Axis(int n, double widest, int steps = 1) : points(n) {
        for (double b = kMinBlur;; b *= std::sqrt(2.0)) {
            levels.push_back(level(b));
            if (b > widest) break;
            for (int k = 1; k < steps; ++k) levels.push_back(level(b * std::exp2(0.5 * k / steps)));
        }
    }
    /// The bytes its levels hold.
    std::size_t bytes() const {
        std::size_t n = 0;
        for (const Level& l : levels)
            n += l.values.size() * sizeof(double) +
                 (l.first.size() + l.size.size() + l.offset.size()) * sizeof(int);
        return n;
    }
    Level level(double b) const {
        Level l;
        l.blur = b;
        l.spacing = kSpacing * b;
        l.start = -kPad * b;
        l.count = static_cast<int>(std::ceil((points - 1 + 2 * kPad * b) / l.spacing)) + 1;
        const int basis = 2 * points - 1;
        for (int p = 0; p < l.count; ++p) {
            const double u = l.start + p * l.spacing;
            const int c0 = std::max(0, static_cast<int>(std::floor(u - 9.0 * b)) - 1);
            const int c1 = std::min(points - 2, static_cast<int>(std::ceil(u + 9.0 * b)) + 1);
            std::vector<double> v(static_cast<std::size_t>(basis), 0.0);
            // Beyond the domain: the end nodes' constants.
            v[0] += normalCdfPdf(u / b).upper;
            v[basis - 1] += normalCdf((u - (points - 1)) / b);
            for (int c = c0; c <= c1; ++c) {
                const double v0 = u - c;  // y = u − b·z, local v = v0 − b·z ∈ [0, 1]
                const double zl = (v0 - 1.0) / b, zh = v0 / b;
                const NormalAt<double> nl = normalAt(zl), nh = normalAt(zh);
                const double m0 = zl >= 0.0 ? nl.upper - nh.upper : nh.cdf - nl.cdf;
                if (!(m0 > 0.0)) continue;
                const double m1 = nl.pdf - nh.pdf;
                const double m2 = m0 + zl * nl.pdf - zh * nh.pdf;
                const double ev = v0 * m0 - b * m1;
                const double ev2 = v0 * v0 * m0 - 2.0 * v0 * b * m1 + b * b * m2;
                v[2 * c] += m0 - 2.0 * ev + ev2;   // (1 − v)²
                v[2 * c + 1] += 2.0 * (ev - ev2);  // 2v(1 − v)
                v[2 * c + 2] += ev2;               // v²
            }
            int f = 0, e = basis;
            while (f < basis && v[f] == 0.0) ++f;
            while (e > f && v[e - 1] == 0.0) --e;
            l.first.push_back(f);
            l.size.push_back(e - f);
            l.offset.push_back(static_cast<int>(l.values.size()));
            l.values.insert(l.values.end(), v.begin() + f, v.begin() + e);
        }
        return l;
    }
};

/// A table: (α·c_r, α·c_g, α·c_b, α) at the grid points of levels (i, j), float.
struct Tf2BlurTables::Table {
    int nx = 0, ny = 0;
    std::vector<float> v;  // (q·4 + ch)·nx + p: per row q the four channels' planes (a row's
                           // points of one channel are contiguous: the lanes' loads)
};

namespace {
/// `gaussian`'s blurs and window (the header comment's are share ½ and kRadius, which the box
/// spline keeps): the blur takes up to kGaussianShare·(1 − |ρ|) of each axis' variance, so
/// Σ − D ≥ (1 − s)/s·D and the summand's spectrum falls as exp(−½(1 − s)ωᵀDω): aliasing ≤
/// exp(−(1 − s)·2π²/kSpacing²) = 2.1e−3 where the blur sits at its bound (the ladder's rounding
/// down leaves it below: on the 64³ tangle's samples the bound's median is 3e−7); the window's
/// radius leaves out mass exp(−4²/2) = 3.4e−4 (the weights are normalised, so E moves by that
/// mass times T's spread over it). Measured against `gaussian-exact` (docs/models.md): max
/// 1.4e−4 in the unit tests (lanes), against 4.6e−5 with share 0.65 and radius 4.25 (2026-12-02 to
/// 12-04), which took ~1.3× the rows on the tangle (issue 33's speed).
constexpr double kGaussianShare = 0.8;
constexpr double kGaussianRadius = 4.0;
/// The y axis' levels per √2 step: `gaussian` takes blurs 2^¼ apart in y (its window's rows, one
/// chunk of lanes each, are ~20 % fewer than on the √2 ladder, whose rounding down leaves the
/// blur between √½ and 1 of its bound), the box spline every second one (its blurs as before).
constexpr int kGaussianYSteps = 2;
/// `gaussian` takes 0 where its rectangle m ± kEmptySigmas·σ meets only cells with α = 0.
constexpr double kEmptySigmas = 5.0;
}  // namespace

/// The table sum's setup for N(m, Σ) in raster cells (gaussianCells): given the blur's largest
/// share of each axis' variance (b² ≤ share·(1 − |ρ|)·σ²) and the window's radius, the table,
/// the residual's inverse covariance (A, B; B, C) and the rows q0 … q1 of the window.
struct Tf2BlurTables::Window {
    double share = 0.5, radius = kRadius;
    bool fineY = false;  // the y ladder's 2^¼ steps (`gaussian`), else its √2 steps
    const Table* t = nullptr;
    double rxx = 0, ryy = 0, A = 0, B = 0, C = 0;
    double hx = 0, hy = 0, xStart = 0, yStart = 0;
    int q0 = 0, q1 = -1;
};

/// The y pass of a level: per grid row q and channel, Σ_R My[q][R]·Q[R][P] over the x basis P,
/// with the range of P where it is not 0.
struct Tf2BlurTables::Pass {
    int basis = 0;
    std::vector<float> z;     // (q·4 + ch)·basis + P
    std::vector<int> lo, hi;  // per q
};

std::uint64_t Tf2BlurTables::hashOf(const Tf2Raster<double>& r) {
    std::uint64_t h = 1469598103934665603ull;  // FNV-1a over the points' bits, 8 bytes a step
    const auto mix = [&](std::uint64_t v) { h = (h ^ v) * 1099511628211ull; };
    const std::size_t n = static_cast<std::size_t>(r.width) * r.height * 4;
    for (std::size_t k = 0; k + 1 < n; k += 2) {
        std::uint64_t v;
        std::memcpy(&v, r.rgba + k, sizeof v);
        mix(v);
    }
    if (n % 2) {
        std::uint32_t v;
        std::memcpy(&v, r.rgba + n - 1, sizeof v);
        mix(v);
    }
    return h;
}

bool Tf2BlurTables::matches(const Tf2Raster<double>& r) const {
    return r.width == width_ && r.height == height_ && r.x0 == x0_ && r.y0 == y0_ &&
           r.invDx == invDx_ && r.invDy == invDy_ && hashOf(r) == hash_;
}

namespace {
/// The bytes of every Tf2BlurTables' built y passes and tables in the process, and their cap:
/// past it a table is not built and its samples take the exact evaluation (`udvr serve` keeps
/// the tables of earlier TF2s alive in its render cache; its soak test saw 529 MiB resident
/// without a cap). At the cap which samples take the exact path depends on the order they come
/// in (the two agree to ~3e−6, docs/models.md).
std::atomic<std::size_t> gTableBytes{0};
constexpr std::size_t kMaxTableBytes = std::size_t{160} << 20;
/// Reserves `bytes` under the cap; false (nothing reserved) where they do not fit.
bool reserveTableBytes(std::size_t bytes) {
    std::size_t now = gTableBytes.load();
    do {
        if (now + bytes > kMaxTableBytes) return false;
    } while (!gTableBytes.compare_exchange_weak(now, now + bytes));
    return true;
}
}  // namespace

Tf2BlurTables::Tf2BlurTables(const Tf2Raster<double>& r)
    : width_(r.width),
      height_(r.height),
      x0_(r.x0),
      y0_(r.y0),
      invDx_(r.invDx),
      invDy_(r.invDy),
      hash_(hashOf(r)) {
    const int W = r.width, H = r.height, BW = 2 * W - 1, BH = 2 * H - 1;
    // The coefficients and ladders under the cap, or no tables (available() false: levels 0).
    if (static_cast<std::size_t>(W) * H > kMaxRasterPoints) return;
    const std::size_t qBytes = static_cast<std::size_t>(BW) * BH * 4 * sizeof(double) +
                               static_cast<std::size_t>(BH) * 2 * sizeof(int) +
                               static_cast<std::size_t>(W) * H * sizeof(std::int32_t);
    if (!reserveTableBytes(qBytes)) return;
    baseBytes_ = qBytes;
    ax_ = std::make_unique<Axis>(W, 8.0 * std::max(W, H));
    ay_ = std::make_unique<Axis>(H, 8.0 * std::max(W, H), kGaussianYSteps);
    const std::size_t axisBytes = ax_->bytes() + ay_->bytes();
    if (!reserveTableBytes(axisBytes)) {
        gTableBytes -= baseBytes_;
        baseBytes_ = 0;
        ax_.reset();
        ay_.reset();
        return;
    }
    baseBytes_ += axisBytes;
    levelsX_ = static_cast<int>(ax_->levels.size());
    levelsY_ = static_cast<int>(ay_->levels.size());
    once_ = std::make_unique<std::once_flag[]>(static_cast<std::size_t>(levelsX_ * levelsY_));
    tables_ =
        std::make_unique<std::unique_ptr<Table>[]>(static_cast<std::size_t>(levelsX_ * levelsY_));
    passOnce_ = std::make_unique<std::once_flag[]>(static_cast<std::size_t>(levelsY_));
    passes_ = std::make_unique<std::unique_ptr<Pass>[]>(static_cast<std::size_t>(levelsY_));
    for (auto& q : q_) q.assign(static_cast<std::size_t>(BW) * BH, 0.0);
    const auto at = [&](int i, int j, int ch) {
        const double v = r.rgba[(static_cast<std::size_t>(j) * W + i) * 4 + ch];
        return std::isfinite(v) ? v : 0.0;
    };
    for (int ch = 0; ch < 4; ++ch) {
        // Channel ch's function: α·c (ch < 3) or α.
        const auto a = [&](int i, int j) { return at(i, j, 3); };
        const auto c = [&](int i, int j) { return ch == 3 ? 1.0 : at(i, j, ch); };
        double* q = q_[ch].data();
        for (int j = 0; j < H; ++j)
            for (int i = 0; i < W; ++i) {
                q[static_cast<std::size_t>(2 * j) * BW + 2 * i] = a(i, j) * c(i, j);
                if (i + 1 < W)
                    q[static_cast<std::size_t>(2 * j) * BW + 2 * i + 1] =
                        0.5 * (a(i, j) * c(i + 1, j) + a(i + 1, j) * c(i, j));
                if (j + 1 < H)
                    q[static_cast<std::size_t>(2 * j + 1) * BW + 2 * i] =
                        0.5 * (a(i, j) * c(i, j + 1) + a(i, j + 1) * c(i, j));
                if (i + 1 < W && j + 1 < H)
                    q[static_cast<std::size_t>(2 * j + 1) * BW + 2 * i + 1] =
                        0.25 * (a(i, j) * c(i + 1, j + 1) + a(i + 1, j + 1) * c(i, j) +
                                a(i, j + 1) * c(i + 1, j) + a(i + 1, j) * c(i, j + 1));
            }
    }
    qRange_.assign(2 * static_cast<std::size_t>(BH), 0);
    for (int R = 0; R < BH; ++R) {
        int lo = BW, hi = 0;
        for (int P = 0; P < BW; ++P)
            for (int ch = 0; ch < 4; ++ch)
                if (q_[ch][static_cast<std::size_t>(R) * BW + P] != 0.0) {
                    lo = std::min(lo, P);
                    hi = P + 1;
                }
        qRange_[2 * R] = lo;
        qRange_[2 * R + 1] = hi;
    }
    // The cells with α > 0 at a corner, summed over [0, i) × [0, j) (cells; W × H entries).
    opaqueCellSums(r.rgba, W, H, alphaCells_);
}

Tf2BlurTables::~Tf2BlurTables() {
    std::size_t bytes = 0;
    for (int k = 0; k < levelsX_ * levelsY_; ++k)
        if (tables_[k]) bytes += tables_[k]->v.size() * sizeof(float);
    for (int j = 0; j < levelsY_; ++j)
        if (passes_[j]) bytes += passes_[j]->z.size() * sizeof(float);
    gTableBytes -= bytes + baseBytes_;
}

const Tf2BlurTables::Pass* Tf2BlurTables::pass(int j) const {
    std::call_once(passOnce_[j], [&] {
        const Axis::Level& ly = ay_->levels[j];
        const int BW = 2 * width_ - 1;
        // Reserved under the process's cap (else none: its callers take the exact evaluation).
        const std::size_t bytes = static_cast<std::size_t>(ly.count) * 4 * BW * sizeof(float);
        if (!reserveTableBytes(bytes)) return;
        struct Release {  // the reservation, where building throws (bad_alloc)
            std::size_t bytes;
            bool done = false;
            ~Release() {
                if (!done) gTableBytes -= bytes;
            }
        } release{bytes};
        auto z = std::make_unique<Pass>();
        z->basis = BW;
        z->z.assign(static_cast<std::size_t>(ly.count) * 4 * BW, 0.0f);
        z->lo.assign(static_cast<std::size_t>(ly.count), BW);
        z->hi.assign(static_cast<std::size_t>(ly.count), 0);
        std::vector<double> row(static_cast<std::size_t>(BW) * 4);
        for (int qy = 0; qy < ly.count; ++qy) {
            int lo = BW, hi = 0;
            const double* wy = ly.values.data() + ly.offset[qy];
            for (int k2 = 0; k2 < ly.size[qy]; ++k2) {
                const int R = ly.first[qy] + k2;
                if (qRange_[2 * R] >= qRange_[2 * R + 1]) continue;
                if (lo >= hi) std::fill(row.begin(), row.end(), 0.0);
                const int a = qRange_[2 * R], b = qRange_[2 * R + 1];
                if (lo < hi) {  // zero what the range grows over
                    for (int ch = 0; ch < 4; ++ch) {
                        double* o = row.data() + static_cast<std::size_t>(ch) * BW;
                        for (int P = std::min(a, lo); P < lo; ++P) o[P] = 0.0;
                        for (int P = hi; P < std::max(b, hi); ++P) o[P] = 0.0;
                    }
                }
                lo = std::min(lo, a);
                hi = std::max(hi, b);
                const double w = wy[k2];
                for (int ch = 0; ch < 4; ++ch) {
                    const double* q = q_[ch].data() + static_cast<std::size_t>(R) * BW;
                    double* o = row.data() + static_cast<std::size_t>(ch) * BW;
                    for (int P = a; P < b; ++P) o[P] += w * q[P];
                }
            }
            z->lo[qy] = lo;
            z->hi[qy] = hi;
            for (int ch = 0; ch < 4; ++ch)
                for (int P = lo; P < hi; ++P)
                    z->z[(static_cast<std::size_t>(qy) * 4 + ch) * BW + P] =
                        static_cast<float>(row[static_cast<std::size_t>(ch) * BW + P]);
        }
        passes_[j] = std::move(z);
        release.done = true;
    });
    return passes_[j].get();
}

const Tf2BlurTables::Table* Tf2BlurTables::table(int i, int j) const {
    const Axis::Level &lx = ax_->levels[i], &ly = ay_->levels[j];
    if (static_cast<std::size_t>(lx.count) * ly.count > kMaxTablePoints) return nullptr;
    const std::size_t k = static_cast<std::size_t>(j) * levelsX_ + i;
    std::call_once(once_[k], [&] {
        // The table and level j's y pass (if that is built already, counted twice here: the
        // check errs on the safe side) under the process's cap.
        const std::size_t bytes = (static_cast<std::size_t>(lx.count) * ly.count +
                                   std::size_t{1} * ly.count * (2 * width_ - 1)) *
                                  4 * sizeof(float);
        if (!reserveTableBytes(bytes)) return;
        gTableBytes -= bytes;  // counted again as each is built
        const Pass* zp = pass(j);
        if (!zp) return;
        const Pass& z = *zp;
        auto t = std::make_unique<Table>();
        t->nx = lx.count;
        t->ny = ly.count;
        // W floats past the last plane: the lane sums read a whole chunk from a row's last
        // points (gaussianCellsLanes).
        t->v.assign(static_cast<std::size_t>(t->nx) * t->ny * 4 + lanes::kWidth, 0.0f);
        const int BW = z.basis;
        for (int qy = 0; qy < t->ny; ++qy) {
            if (z.lo[qy] >= z.hi[qy]) continue;
            const float* zr = z.z.data() + static_cast<std::size_t>(qy) * 4 * BW;
            for (int px = 0; px < t->nx; ++px) {
                const int a = std::max(lx.first[px], z.lo[qy]);
                const int b = std::min(lx.first[px] + lx.size[px], z.hi[qy]);
                const double* wx = lx.values.data() + lx.offset[px] - lx.first[px];
                double s[4] = {};
                for (int ch = 0; ch < 4; ++ch) {
                    const float* zc = zr + static_cast<std::size_t>(ch) * BW;
                    double acc = 0.0;
                    for (int P = a; P < b; ++P) acc += wx[P] * zc[P];
                    s[ch] = acc;
                }
                float* o = t->v.data() + static_cast<std::size_t>(qy) * 4 * t->nx + px;
                for (int ch = 0; ch < 4; ++ch)
                    o[static_cast<std::size_t>(ch) * t->nx] = static_cast<float>(s[ch]);
            }
        }
        gTableBytes += t->v.size() * sizeof(float);
        tables_[k] = std::move(t);
    });
    return tables_[k].get();
}

namespace {
/// The 4 channel planes (nx floats each, from `row`) at points p … p + W − 1 into v: one load
/// each where `whole` (the caller's check that the lanes it weights lie within the row; lanes
/// past them read the next plane or the tables' padding: finite), else gathered at p clamped to
/// the row for the lanes in `in`.
UDVR_INLINE void loadPlanes(const float* row, int nx, int p, bool whole, lanes::Mask in,
                            lanes::Vi iota, lanes::Vf v[4]) {
    if (whole) {
        for (int ch = 0; ch < 4; ++ch)
            v[ch] = lanes::load(row + static_cast<std::size_t>(ch) * nx + p);
    } else {
        const lanes::Vi idx = lanes::min(lanes::max(iota + p, lanes::Vi{}), lanes::splati(nx - 1));
        for (int ch = 0; ch < 4; ++ch)
            v[ch] = lanes::gather(row + static_cast<std::size_t>(ch) * nx, idx, in);
    }
}

}  // namespace

bool Tf2BlurTables::windowOf(double t0, double sxx, double sxy, double syy, Window& w) const {
    if (!available()) return false;
    if (!(sxx > 0.0 && syy > 0.0)) return false;
    const double sx = std::sqrt(sxx), sy = std::sqrt(syy);
    const double rho = std::clamp(sxy / (sx * sy), -1.0, 1.0);
    const double f = std::sqrt(w.share * (1.0 - std::abs(rho)));
    const double bxMax = f * sx, byMax = f * sy;
    if (!(bxMax >= kMinBlur && byMax >= kMinBlur)) return false;
    // The √2 ladder's level ⌊2·log2(b/kMinBlur) + 1e−9⌋: the exponent of (b/kMinBlur)²·2^(1e−9),
    // a double ≥ 1 (std::log2 took 3.4 % of a gaussian frame); the y axis' 2^¼ ladder's (fineY)
    // the exponent of its square.
    const auto levelOf = [](double b, int levels, int steps) {
        const double y = b / kMinBlur;
        double p = y * y * (1.0 + 6.931471805599453e-10);
        for (int s = 1; s < steps; s *= 2) p *= p;
        const int k = static_cast<int>(std::bit_cast<std::uint64_t>(p) >> 52) - 1023;
        return std::clamp(k, 0, levels - 1);
    };
    int i = levelOf(bxMax, levelsX_, 1);
    const int jStep = w.fineY ? 1 : kGaussianYSteps;
    int j = w.fineY ? levelOf(byMax, levelsY_, kGaussianYSteps)
                    : kGaussianYSteps * levelOf(byMax, (levelsY_ - 1) / kGaussianYSteps + 1, 1);
    // Floating rounding of the ladder: keep b ≤ bMax.
    while (i > 0 && ax_->levels[i].blur > bxMax) --i;
    while (j > 0 && ay_->levels[j].blur > byMax) j -= jStep;
    const Axis::Level &lx = ax_->levels[i], &ly = ay_->levels[j];
    w.t = table(i, j);
    if (!w.t) return false;
    w.rxx = sxx - lx.blur * lx.blur, w.ryy = syy - ly.blur * ly.blur;
    const double det = w.rxx * w.ryy - sxy * sxy;
    if (!(det > 0.0)) return false;
    w.A = w.ryy / det, w.B = -sxy / det, w.C = w.rxx / det;
    w.hx = lx.spacing, w.hy = ly.spacing;
    w.xStart = lx.start, w.yStart = ly.start;
    const double ey = w.radius * std::sqrt(w.ryy);
    w.q0 = static_cast<int>(std::ceil((t0 - ey - ly.start) / w.hy));
    w.q1 = static_cast<int>(std::floor((t0 + ey - ly.start) / w.hy));
    return true;
}

bool Tf2BlurTables::gaussianCells(double s0, double t0, double sxx, double sxy, double syy,
                                  double out[4]) const {
    Window win;
    win.share = kGaussianShare, win.radius = kGaussianRadius, win.fineY = true;
    if (!windowOf(t0, sxx, sxy, syy, win)) return false;
    const Table* t = win.t;
    const double A = win.A, B = win.B, C = win.C;
    const double R2 = win.radius * win.radius;
    const double hx = win.hx, hy = win.hy;
    const int q0 = win.q0, q1 = win.q1;
    const double g = std::exp(-A * hx * hx);
    double acc[4] = {}, wsum = 0.0;
    for (int q = q0; q <= q1; ++q) {
        const double e = win.yStart + q * hy - t0;
        const double disc = B * B * e * e - A * (C * e * e - R2);
        if (!(disc > 0.0)) continue;
        const double sq = std::sqrt(disc);
        const double dlo = (-B * e - sq) / A, dhi = (-B * e + sq) / A;
        const int p0 = static_cast<int>(std::ceil((s0 + dlo - win.xStart) / hx));
        const int p1 = static_cast<int>(std::floor((s0 + dhi - win.xStart) / hx));
        if (p1 < p0) continue;
        const int qc = std::clamp(q, 0, t->ny - 1);
        const float* row = t->v.data() + static_cast<std::size_t>(qc) * t->nx * 4;
        const std::size_t plane = static_cast<std::size_t>(t->nx);
        const double d = win.xStart + p0 * hx - s0;
        double w = std::exp(-0.5 * (A * d * d + 2.0 * B * e * d + C * e * e));
        double ratio = std::exp(-0.5 * (A * (2.0 * d * hx + hx * hx) + 2.0 * B * e * hx));
        double s[4] = {}, ws = 0.0;
        for (int p = p0; p <= p1; ++p) {
            const float* v = row + std::clamp(p, 0, t->nx - 1);
            for (int ch = 0; ch < 4; ++ch) s[ch] += w * v[ch * plane];
            ws += w;
            w *= ratio;
            ratio *= g;
        }
        for (int ch = 0; ch < 4; ++ch) acc[ch] += s[ch];
        wsum += ws;
    }
    if (!(wsum > 0.0)) return false;
    for (int ch = 0; ch < 4; ++ch) out[ch] = acc[ch] / wsum;
    return true;
}

void Tf2BlurTables::gaussian(const Tf2Raster<double>& r, double mx, double my, double vxx,
                             double vxy, double vyy, double out[4]) const {
    const double s0 = (mx - r.x0) * r.invDx, t0 = (my - r.y0) * r.invDy;
    if (std::isfinite(s0) && std::isfinite(t0) && std::abs(s0) < 1e9 && std::abs(t0) < 1e9 &&
        gaussianCells(s0, t0, vxx * r.invDx * r.invDx, vxy * r.invDx * r.invDy,
                      vyy * r.invDy * r.invDy, out))
        return;
    expectedTf2Gaussian(r, mx, my, vxx, vxy, vyy, out);
}

bool Tf2BlurTables::gaussianCellsLanes(const Window& win, double s0, double t0,
                                       float out[4]) const {
    using lanes::Vf;
    using RowsD = lanes::V8d;  // one lane per table row: the rows' setups
    constexpr int W = lanes::kWidth, kRowLanes = 8;
    const Table* t = win.t;
    const int nx = t->nx;
    const double A = win.A, B = win.B, C = win.C, hx = win.hx;
    const double R2 = win.radius * win.radius, invA = 1.0 / A, invHx = 1.0 / hx;
    const lanes::Vi iota = lanes::iota();
    const Vf kf = lanes::toFloat(iota);
    // The exponent along a row is a parabola in the point's index k, c2·(k − kv)² + top: in float
    // about its vertex kv the terms stay under kRadius²/2 (no cancellation of large ones).
    const double c2 = -0.5 * A * hx * hx;
    const Vf c2v = lanes::splat<Vf>(static_cast<float>(c2));
    // The rows' points in chunks of at most W (a row of the table (clamped to it), its first
    // point p, the chunk's first index k in the row, the vertex and top of the row's parabola and
    // the chunk's point count), summed once the buffer is full or the rows are done. Every chunk
    // takes the same instructions: the rows' varying extents are settled before (a chunk loop per
    // row mispredicted its exit and serialised the exp's latency with the row's scalar setup).
    // Where each of kRowLanes rows holds at most W points (all but a few on the tangle) their
    // chunks are stored as the setup's lanes, a row a chunk (an empty row weighs 0).
    constexpr int kChunks = 64;
    int chunkQ[kChunks + kRowLanes], chunkP[kChunks + kRowLanes], chunkN[kChunks + kRowLanes];
    float chunkK[kChunks + kRowLanes], chunkKv[kChunks + kRowLanes], chunkTop[kChunks + kRowLanes];
    int chunks = 0;
    const float* table = t->v.data();
    const std::size_t rowStride = 4 * static_cast<std::size_t>(nx);
    Vf acc[4] = {}, wsum = {};
    const auto sumChunks = [&] {
        for (int c = 0; c < chunks; ++c) {
            const int p = chunkP[c], n = chunkN[c];
            const Vf dk = kf + chunkK[c] - lanes::splat<Vf>(chunkKv[c]);
            const Vf x = lanes::min(c2v * dk * dk + lanes::splat<Vf>(chunkTop[c]), Vf{});
            const lanes::Mask in = iota < n;
            const Vf w = lanes::select(in, detail::expNonPositive(x), Vf{});
            const float* row = table + static_cast<std::size_t>(chunkQ[c]) * rowStride;
            Vf v[4];  // lanes from n on (n ≤ W) are weighted 0
            loadPlanes(row, nx, p, p >= 0 && p + n <= nx, in, iota, v);
            for (int ch = 0; ch < 4; ++ch) acc[ch] = lanes::fma(w, v[ch], acc[ch]);
            wsum += w;
        }
        chunks = 0;
    };
    // The rows' setups, kRowLanes rows at a time in double lanes (the scalar body's arithmetic
    // lane by lane): the row's points p0 … p1 within the window's ellipse, d = d0 + k·hx
    // (k = p − p0), the exponent −½(A d² + 2B e d + C e²) with its vertex at d = −B e / A.
    const RowsD rowIota = {0, 1, 2, 3, 4, 5, 6, 7};
    const lanes::V8i rowIotaI = {0, 1, 2, 3, 4, 5, 6, 7};
    const double topScale = -0.5 * (C - B * B * invA);
    for (int qb = win.q0; qb <= win.q1; qb += kRowLanes) {
        const RowsD q = rowIota + static_cast<double>(qb);
        const RowsD e = win.yStart + q * win.hy - t0;
        const RowsD disc = B * B * e * e - A * (C * e * e - R2);
        const auto inside = lanes::less(RowsD{}, disc);
        const RowsD sq = lanes::sqrt(lanes::selectBits(inside, disc, RowsD{}));
        const RowsD dlo = (-B * e - sq) * invA, dhi = (-B * e + sq) * invA;
        const RowsD p0d = lanes::ceil((s0 + dlo - win.xStart) * invHx);
        const RowsD p1d = lanes::floor((s0 + dhi - win.xStart) * invHx);
        const RowsD d0 = win.xStart + p0d * hx - s0;
        const lanes::V8f kv = lanes::toFloat((-B * e * invA - d0) * invHx);
        const lanes::V8f top = lanes::toFloat(topScale * e * e);
        const lanes::V8i p0 = lanes::truncToInt(p0d);
        const lanes::V8i n = lanes::truncToInt(lanes::selectBits(inside, p1d - p0d + 1.0, RowsD{}));
        const lanes::V8i qc =
            lanes::min(lanes::max(rowIotaI + qb, lanes::V8i{}), lanes::V8i{} + (t->ny - 1));
        const int rows = std::min(kRowLanes, win.q1 - qb + 1);
        bool short8 = true;
        for (int i = 0; i < kRowLanes; ++i) short8 = short8 && n[i] <= W;
        if (short8) {
            if (chunks + kRowLanes > kChunks) sumChunks();
            static_assert(sizeof kv == kRowLanes * sizeof(float) && sizeof n == sizeof kv);
            std::memcpy(chunkQ + chunks, &qc, sizeof qc);
            std::memcpy(chunkP + chunks, &p0, sizeof p0);
            std::memcpy(chunkN + chunks, &n, sizeof n);
            std::memcpy(chunkKv + chunks, &kv, sizeof kv);
            std::memcpy(chunkTop + chunks, &top, sizeof top);
            std::fill_n(chunkK + chunks, kRowLanes, 0.0f);
            chunks += rows;
            continue;
        }
        for (int i = 0; i < rows; ++i) {
            const int count = n[i];
            if (count <= 0) continue;
            for (int k = 0; k < count; k += W) {
                if (chunks == kChunks) sumChunks();
                chunkQ[chunks] = qc[i];
                chunkP[chunks] = p0[i] + k;
                chunkN[chunks] = std::min(count - k, W);
                chunkK[chunks] = static_cast<float>(k);
                chunkKv[chunks] = kv[i];
                chunkTop[chunks] = top[i];
                ++chunks;
            }
        }
    }
    sumChunks();
    const float total = lanes::sum(wsum);
    if (!(total > 0.0f)) return false;
    for (int ch = 0; ch < 4; ++ch) out[ch] = lanes::sum(acc[ch]) / total;
    return true;
}

std::uint32_t Tf2BlurTables::gaussianWindows(const lanes::V8d& s0, const lanes::V8d& t0,
                                             const lanes::V8d& sxx, const lanes::V8d& sxy,
                                             const lanes::V8d& syy, Window win[8],
                                             std::uint32_t& empty) const {
    using D = lanes::V8d;
    using L = lanes::V8l;
    empty = 0;
    if (!available()) return 0;
    // windowOf's arithmetic lane by lane (the same values), the sqrt and divisions of 8 samples
    // at once where one sample's chain of them took 12 % of a frame.
    const auto absOf = [](D x) { return lanes::max(x, -x); };  // NaN stays NaN
    const D big = D{} + 1e9, zero = D{};
    const auto valid = lanes::less(absOf(s0), big) & lanes::less(absOf(t0), big) &
                       lanes::less(zero, sxx) & lanes::less(zero, syy);  // false for NaN
    const D sx = lanes::sqrt(lanes::selectBits(valid, sxx, D{} + 1.0));
    const D sy = lanes::sqrt(lanes::selectBits(valid, syy, D{} + 1.0));
    // The cells the rectangle m ± kEmptySigmas·σ meets (clamped to the raster: beyond it the TF2
    // is its edge's); where none has α > 0, E[(α·c, α)] ≤ P(outside) ≤ 4Φ(−kEmptySigmas) =
    // 1.1e−6 and the sample takes 0 (on the 64³ tangle 11 % of the samples), tables or not.
    const D cells[4] = {lanes::floor(s0 - kEmptySigmas * sx), lanes::floor(s0 + kEmptySigmas * sx),
                        lanes::floor(t0 - kEmptySigmas * sy), lanes::floor(t0 + kEmptySigmas * sy)};
    for (int l = 0; l < 8; ++l) {
        if (!valid[l] || width_ < 2 || height_ < 2) continue;
        const auto cell = [&](double v, int n) {
            return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(n - 2)));
        };
        const int i0 = cell(cells[0][l], width_), i1 = cell(cells[1][l], width_) + 1;
        const int j0 = cell(cells[2][l], height_), j1 = cell(cells[3][l], height_) + 1;
        const auto sat = [&](int i, int j) {
            return alphaCells_[static_cast<std::size_t>(j) * width_ + i];
        };
        if (sat(i1, j1) - sat(i0, j1) - sat(i1, j0) + sat(i0, j0) == 0) empty |= 1u << l;
    }
    const D rho = lanes::min(lanes::max(sxy / (sx * sy), D{} - 1.0), D{} + 1.0);
    const D f = lanes::sqrt(kGaussianShare * (1.0 - absOf(rho)));
    const D bxMax = f * sx, byMax = f * sy;
    const D minBlur = D{} + kMinBlur;  // b ≥ kMinBlur, not NaN
    const auto ok = valid & lanes::less(zero, bxMax) & lanes::less(zero, byMax) &
                    ~lanes::less(bxMax, minBlur) & ~lanes::less(byMax, minBlur);
    // The levels (windowOf's levelOf): the exponents of (b/kMinBlur)²·2^(1e−9) in x and of its
    // square in y (the 2^¼ ladder), clamped.
    const D yx = bxMax * (1.0 / kMinBlur), yy = byMax * (1.0 / kMinBlur);
    const D px = yx * yx * (1.0 + 6.931471805599453e-10);
    D py = yy * yy * (1.0 + 6.931471805599453e-10);
    for (int s = 1; s < kGaussianYSteps; s *= 2) py *= py;
    const L kx = (std::bit_cast<L>(px) >> 52) - 1023, ky = (std::bit_cast<L>(py) >> 52) - 1023;
    std::uint32_t good = 0;
    D bx{}, by{};
    for (int l = 0; l < 8; ++l) {
        if (!ok[l] || ((empty >> l) & 1u)) continue;
        int i = static_cast<int>(std::clamp<std::int64_t>(kx[l], 0, levelsX_ - 1));
        int j = static_cast<int>(std::clamp<std::int64_t>(ky[l], 0, levelsY_ - 1));
        while (i > 0 && ax_->levels[i].blur > bxMax[l]) --i;
        while (j > 0 && ay_->levels[j].blur > byMax[l]) --j;
        win[l].t = table(i, j);
        if (!win[l].t) continue;
        bx[l] = ax_->levels[i].blur;
        by[l] = ay_->levels[j].blur;
        good |= 1u << l;
    }
    const D rxx = sxx - bx * bx, ryy = syy - by * by;
    const D det = rxx * ryy - sxy * sxy;
    const auto pos = lanes::less(zero, det);
    const D detSafe = lanes::selectBits(pos, det, D{} + 1.0);
    const D A = ryy / detSafe, B = -sxy / detSafe, C = rxx / detSafe;
    const D hx = kSpacing * bx, hy = kSpacing * by;
    const D xStart = -kPad * bx, yStart = -kPad * by;
    const D ey = kGaussianRadius * lanes::sqrt(lanes::selectBits(pos, ryy, D{}));
    const D hySafe = lanes::selectBits(lanes::less(zero, hy), hy, D{} + 1.0);
    const D q0 = lanes::ceil((t0 - ey - yStart) / hySafe);
    const D q1 = lanes::floor((t0 + ey - yStart) / hySafe);
    for (int l = 0; l < 8; ++l) {
        if (!((good >> l) & 1u)) continue;
        if (!pos[l]) {
            good &= ~(1u << l);
            continue;
        }
        Window& w = win[l];
        w.share = kGaussianShare, w.radius = kGaussianRadius, w.fineY = true;
        w.rxx = rxx[l], w.ryy = ryy[l], w.A = A[l], w.B = B[l], w.C = C[l];
        w.hx = hx[l], w.hy = hy[l], w.xStart = xStart[l], w.yStart = yStart[l];
        w.q0 = static_cast<int>(q0[l]), w.q1 = static_cast<int>(q1[l]);
    }
    return good;
}

void Tf2BlurTables::gaussian(const Tf2Raster<double>& r, const lanes::Vf m[5], lanes::Mask live,
                             lanes::Vf out[4]) const {
    using D = lanes::V8d;
    const std::uint32_t liveBits = lanes::bits(live);
    for (int g = 0; g < lanes::kWidth; g += 8) {
        const std::uint32_t groupLive = (liveBits >> g) & 0xFFu;
        if (!groupLive) continue;
        D mx{}, my{}, vxx{}, vxy{}, vyy{};
        for (int l = 0; l < 8 && g + l < lanes::kWidth; ++l) {
            mx[l] = m[0][g + l], my[l] = m[1][g + l], vxx[l] = m[2][g + l];
            vxy[l] = m[3][g + l], vyy[l] = m[4][g + l];
        }
        const D s0 = (mx - r.x0) * r.invDx, t0 = (my - r.y0) * r.invDy;
        Window win[8];
        std::uint32_t empty = 0;
        const std::uint32_t good =
            groupLive & gaussianWindows(s0, t0, vxx * r.invDx * r.invDx, vxy * r.invDx * r.invDy,
                                        vyy * r.invDy * r.invDy, win, empty);
        for (std::uint32_t b = groupLive & empty; b; b &= b - 1) {
            const int l = std::countr_zero(b);
            for (int ch = 0; ch < 4; ++ch) out[ch][g + l] = 0.0f;
        }
        for (std::uint32_t b = groupLive & ~empty; b; b &= b - 1) {
            const int l = std::countr_zero(b);
            float v[4];
            if (((good >> l) & 1u) && gaussianCellsLanes(win[l], s0[l], t0[l], v)) {
                for (int ch = 0; ch < 4; ++ch) out[ch][g + l] = v[ch];
                continue;
            }
            double e[4];
            expectedTf2Gaussian(r, mx[l], my[l], vxx[l], vxy[l], vyy[l], e);
            for (int ch = 0; ch < 4; ++ch) out[ch][g + l] = static_cast<float>(e[ch]);
        }
    }
}

namespace {
/// Settings of boxSpline.
/// The moments E[ψ_P(X)·G_c^j] taken, j < kMomentsG: the law of G per basis index to κ6.
constexpr int kMomentsG = 7;
constexpr double kColumnsTailTol = 1e-8;   // the x series stops where (2/L)·envelope·m is below
constexpr int kColumnsMaxTerms = 4096;     // … or past this many terms: the exact evaluation
static_assert(kColumnsMaxTerms % 8 == 0);  // the terms go 8 a batch
constexpr int kColumnsMaxWindow = 1024;    // a y sum's points at most (else exact)
/// Fewer corners (directions with a ≠ 0: voxels of zero spread drop out, e.g. the tooth's constant
/// bricks) take the exact evaluation. With the law of G to κ4 and cutting only corners wider than
/// the widest G-only box, 2–7 corners were up to 5.6e−3 off uniform-exact (so 8 were required);
/// to κ6 with the cut rule of 2026-12-05, 5760 random cases of 2–7 corners on rough rasters
/// 8.1e−4 (one corner: X a single box, cut into pieces past the node cap: the exact evaluation).
/// Samples at voxel faces, edges and grid points still take the exact evaluation before this
/// (Uniform2DKernel: JointBoxSpline::allCorners).
constexpr int kColumnsMinCorners = 2;
/// A corner's box is cut into pieces (boxSpline) past this share of var G (a box-dominated law
/// of G is far from a Gram–Charlier normal), a second one past this share of the rest; each piece
/// at most kColumnsPieceShare of its law given X. Measured against uniform-exact (docs/models.md,
/// 2026-12-05): with none cut the random coarse models of JointDistribution.Every2D… were 7.3e−3
/// off; cut past 0.25 with pieces of 0.3, 1.8e−4 there and 6.4e−4 on the rough rasters (one
/// corner kept by Gauss–Legendre past 0.35: 6.8e−4 and 1.4e−3, at 1.45× the time). Past 0.15
/// since the law is taken to κ6: 4000 rough cases 1.74e−3 → 9.8e−4 (0.25 → 0.15), the tangle's
/// frame within noise.
constexpr double kColumnsKeepShare = 0.15;
constexpr double kColumnsPieceShare = 0.3;
/// Above the y blur ladder the widest G-only box is folded into the law (variance, κ4, κ6) where
/// it holds at most this share of var G (given X), so the weights need no normal CDF.
/// Measured 2026-12-05 (docs/models.md): the 7 real tangle calls 1.5e−4 → 2.4e−4 off
/// uniform-exact, the other sets unchanged; −28 % of the tangle's frame time (0.25: no box
/// folded there, 0.5: no faster, 150 tangle probes 3.0e−4 → 4.0e−4).
constexpr double kColumnsFoldShare = 0.4;
/// Nodes of the cut boxes' pieces at most (else the exact evaluation). 16 before 2026-12-05: 437
/// of the 2002 classified samples of a 16² tooth frame took the exact evaluation through it (the
/// frame 641 → 469 ms at 64; tangle 369 → 351 ms). The work stays bounded by kColumnsMaxWork and
/// kColumnsMaxPoints.
constexpr int kColumnsMaxNodes = 64;
/// Bounds on one sample's work (else the exact evaluation at the coarse settings): X's half
/// support (raster cells; the basis indices to sum, ≤ 4·512 + 4 a node), G's reach |t0| + Σ|b|
/// (raster cells; the int row indices), the product nodes × basis indices × Fourier terms, and
/// the y sums' points over the whole sample.
constexpr double kColumnsMaxSupport = 512.0;
constexpr double kColumnsMaxReachG = 1e6;
constexpr double kColumnsMaxWork = 1 << 24;
constexpr long kColumnsMaxPoints = 1 << 22;
/// Basis indices whose weight E[ψ_P(X)] is under this are left out: the x series is truncated at
/// ~1e−8, so their moments are mostly its noise.
constexpr double kColumnsMinWeight = 1e-9;
/// The basis indices at each end of X's support whose weights sum to under half this are left out
/// too (at every node): E moves by at most their weight (the TF2's values are in [0, 1]), and X's
/// tails near its support's ends (a box spline's density there goes as the distance to the end
/// to the power corners − 1) hold many indices of little weight.
constexpr double kColumnsTailMass = 1e-5;

/// g^(p)(θ), p = 0 … 6, of g(θ) = sin θ / θ (the characteristic function of U[−1, 1] at θ), in
/// eight lanes, from sn = sin θ and cs = cos θ: below |θ| = 1 the Taylor series, else the
/// recurrence θ·g^(p) = sin^(p)(θ) − p·g^(p−1)(θ).
void sincDerivatives(lanes::V8d th, lanes::V8d sn, lanes::V8d cs, lanes::V8d g[kMomentsG]) {
    using lanes::V8d;
    // c[p][k]: the coefficient of θ^(2k − p) in g^(p), (−1)^k (2k)! / ((2k − p)! (2k + 1)!).
    static const auto coefficients = [] {
        std::array<std::array<double, 14>, kMomentsG> c{};
        for (int p = 0; p < kMomentsG; ++p)
            for (int k = 0; k < 14; ++k) {
                if (2 * k < p) continue;
                double v = (k % 2 ? -1.0 : 1.0);
                for (int i = 2 * k - p + 1; i <= 2 * k; ++i) v *= i;
                for (int i = 2; i <= 2 * k + 1; ++i) v /= i;
                c[p][k] = v;
            }
        return c;
    }();
    const V8d one = V8d{} + 1.0;
    const auto small = lanes::less(lanes::max(th, -th), one);
    const V8d inv = one / lanes::selectBits(small, one, th);
    g[0] = sn * inv;
    g[1] = (cs - g[0]) * inv;
    g[2] = (-sn - 2.0 * g[1]) * inv;
    g[3] = (-cs - 3.0 * g[2]) * inv;
    g[4] = (sn - 4.0 * g[3]) * inv;
    g[5] = (cs - 5.0 * g[4]) * inv;
    g[6] = (-sn - 6.0 * g[5]) * inv;
    bool any = false;
    for (int l = 0; l < 8; ++l) any = any || small[l];
    if (!any) return;
    const V8d t2 = th * th;
    for (int p = 0; p < kMomentsG; ++p) {
        const int k0 = (p + 1) / 2;
        V8d acc{};
        for (int k = 13; k >= k0; --k) acc = acc * t2 + coefficients[p][k];
        g[p] = lanes::selectBits(small, (2 * k0 - p == 1 ? th : one) * acc, g[p]);
    }
}

/// ∫ψ(x)·e^{iωx} dx of the x basis' interior node (1 − |x|)² on [−1, 1] and of the bubble
/// 2v(1 − v) on [0, 1] about its centre ½ (both real: even functions), ω ≥ 0 in eight lanes,
/// from sh = sin(ω/2) and ch = cos(ω/2).
lanes::V8d nodeSpectrum(lanes::V8d w, lanes::V8d sh, lanes::V8d ch) {
    using lanes::V8d;
    const V8d w2 = w * w;
    const V8d series = 4.0 * (1.0 / 6.0 - w2 * (1.0 / 120.0 - w2 * (1.0 / 5040.0 - w2 / 362880.0)));
    const auto small = lanes::less(w, V8d{} + 0.5);
    const V8d ws = lanes::selectBits(small, V8d{} + 1.0, w);
    return lanes::selectBits(small, series, 4.0 * (ws - 2.0 * sh * ch) / (ws * ws * ws));
}
lanes::V8d bubbleSpectrum(lanes::V8d w, lanes::V8d sh, lanes::V8d ch) {
    using lanes::V8d;
    const V8d y = 0.5 * w, y2 = y * y;
    const V8d series = 1.0 / 3.0 - y2 * (1.0 / 30.0 - y2 * (1.0 / 840.0 - y2 / 45360.0));
    const auto small = lanes::less(y, V8d{} + 0.5);
    const V8d ys = lanes::selectBits(small, V8d{} + 1.0, y);
    return lanes::selectBits(small, series, (sh - ys * ch) / (ys * ys * ys));
}

/// (c, s) = (cos, sin)(θ) turned on by the angle of (cr, sr): θ + that angle, lane by lane.
template <class V, class R>
inline void rotate(V& c, V& s, R cr, R sr) {
    const V nc = c * cr - s * sr;
    s = s * cr + c * sr;
    c = nc;
}

/// Eight lanes of (cos, sin)(l·δ), l = 0 … 7, and (cos, sin)(8δ): the start and the step of a
/// rotation that walks the angles m·δ eight terms a batch.
struct Rotation8 {
    lanes::V8d c{}, s{};
    double c8 = 1.0, s8 = 0.0;
    Rotation8() = default;
    explicit Rotation8(double delta) {
        const double c1 = std::cos(delta), s1 = std::sin(delta);
        c[0] = 1.0, s[0] = 0.0;
        for (int l = 1; l < 8; ++l)
            c[l] = c[l - 1] * c1 - s[l - 1] * s1, s[l] = s[l - 1] * c1 + c[l - 1] * s1;
        c8 = c[7] * c1 - s[7] * s1, s8 = s[7] * c1 + c[7] * s1;
    }
    void step() { rotate(c, s, c8, s8); }
};

/// A row cell c's moments M_k = ∫v^k·density (v = g − c) onto its Bernstein basis functions
/// (1 − v)², 2v(1 − v), v² (w[2c], w[2c + 1], w[2c + 2]), times `weight`.
inline void addCellMoments(std::vector<double>& w, int c, double weight, double M0, double M1,
                           double M2) {
    w[2 * c] += weight * (M0 - 2.0 * M1 + M2);
    w[2 * c + 1] += weight * 2.0 * (M1 - M2);
    w[2 * c + 2] += weight * M2;
}

/// Per row cell of the y basis (Bernstein: (1 − v)², 2v(1 − v), v² on cell c, v = g − c), the
/// expectation under the law μ + s·Z, Z with density φ·(1 + c3·He3 + c4·He4) (an Edgeworth
/// normal), added into w[2c + β] with weight `weight`; the law's mass below row 0 and above row
/// H − 1 into w[0] and w[2H − 2] (the raster clamps). Closed form: ∫ He_n φ over an interval is
/// [−He_(n−1) φ], z^k He_n expanded in He by z·He_n = He_(n+1) + n·He_(n−1).
void edgeworthRowWeights(double mu, double s, double c3, double c4, int H, double weight,
                         std::vector<double>& w, int& rLo, int& rHi) {
    // Cells cLo … cHi within 9 s of μ (clamped to the raster: beyond, the end rows' masses).
    const int cLo = std::clamp(static_cast<int>(std::floor(mu - 9.0 * s)), 0, H - 1);
    const int cHi = std::clamp(static_cast<int>(std::floor(mu + 9.0 * s)), -1, H - 2);
    // He_0 … He_5, φ, Φ and 1 − Φ at z; the tails ∫_{−∞}^{z} and ∫_{z}^{∞} of the density.
    struct At {
        double he[6], phi, cdf, upperCdf, lower, upper;
    };
    const auto at = [&](double g) {
        At a;
        const double z = (g - mu) / s;
        const NormalAt<double> n = normalAt(z);
        a.phi = n.pdf, a.cdf = n.cdf, a.upperCdf = n.upper;
        a.he[0] = 1.0, a.he[1] = z;
        for (int k = 2; k < 6; ++k) a.he[k] = z * a.he[k - 1] - (k - 1) * a.he[k - 2];
        // ∫_{−∞}^{z} He_n φ = −He_(n−1)(z)·φ(z) (n ≥ 1).
        const double corr = -(c3 * a.he[2] + c4 * a.he[3]) * a.phi;
        a.lower = n.cdf + corr;
        a.upper = n.upper - corr;
        return a;
    };
    At lo = at(static_cast<double>(cLo));
    if (cLo == 0) {
        w[0] += weight * lo.lower;
        rLo = std::min(rLo, 0);
    }
    for (int c = cLo; c <= cHi; ++c) {
        const At hi = at(c + 1.0);
        // I_n = ∫_{zl}^{zh} He_n φ: I_0 by the tails (upper ones above the mean, no digits lost
        // to 1 − Φ), I_n = He_(n−1)φ|zl − He_(n−1)φ|zh.
        double I[7];
        I[0] = c >= mu ? lo.upperCdf - hi.upperCdf : hi.cdf - lo.cdf;
        for (int k = 1; k < 7; ++k) I[k] = lo.he[k - 1] * lo.phi - hi.he[k - 1] * hi.phi;
        const double Z0 = I[0] + c3 * I[3] + c4 * I[4];
        const double Z1 = I[1] + c3 * (I[4] + 3.0 * I[2]) + c4 * (I[5] + 4.0 * I[3]);
        const double Z2 = I[2] + I[0] + c3 * (I[5] + 7.0 * I[3] + 6.0 * I[1]) +
                          c4 * (I[6] + 9.0 * I[4] + 12.0 * I[2]);
        // v = v0 + s·z on the cell, v0 = μ − c.
        const double v0 = mu - c;
        addCellMoments(w, c, weight, Z0, v0 * Z0 + s * Z1,
                       v0 * v0 * Z0 + 2.0 * v0 * s * Z1 + s * s * Z2);
        lo = hi;
    }
    if (cHi == H - 2) w[2 * H - 2] += weight * lo.upper;
    rLo = std::min(rLo, 2 * cLo);
    rHi = std::max(rHi, cHi == H - 2 ? 2 * H - 1 : 2 * cHi + 3);
}

/// edgeworthRowWeights for the law μ + s·Z + U, Z the Edgeworth normal and U uniform on [−h, h]
/// (the widest G-only box), h > 0: its density is (F(g − μ + h) − F(g − μ − h))/(2h), F the
/// Edgeworth normal's CDF, so a cell's ∫v^k·density are, by parts, differences of F's repeated
/// antiderivatives, which are closed forms (∫Φ = uΦ + φ, ∫∫Φ = ((u² + 1)Φ + uφ)/2, ∫∫∫Φ =
/// ((u³ + 3u)Φ + (u² + 2)φ)/6 in u = x/s, and ∫He_n·φ = −He_(n−1)·φ). Where a cell lies beyond
/// 9s of an edge, that edge's term is F = 1 or 0 over it (integrals 1/(k + 1) or 0).
void edgeworthBoxRowWeights(double mu, double s, double c3, double c4, double h, int H,
                            double weight, std::vector<double>& w, int& rLo, int& rHi) {
    const double reach = 9.0 * s;
    const int cLo = std::clamp(static_cast<int>(std::floor(mu - h - reach)), 0, H - 1);
    const int cHi = std::clamp(static_cast<int>(std::floor(mu + h + reach)), -1, H - 2);
    // F's first three antiderivatives at x (in g's units): H1, H2, H3.
    struct Anti {
        double h1, h2, h3;
    };
    const auto anti = [&](double x) {
        const double u = x / s, u2 = u * u;
        const NormalAt<double> n = normalAt(u);
        const double P = n.cdf, p = n.pdf;
        return Anti{s * (u * P + p + (c3 * u + c4 * (u2 - 1.0)) * p),
                    s * s * (0.5 * ((u2 + 1.0) * P + u * p) - (c3 + c4 * u) * p),
                    s * s * s * (((u2 + 3.0) * u * P + (u2 + 2.0) * p) / 6.0 - (c3 * P - c4 * p))};
    };
    // ∫_0^1 v^k F(x0 + v) dv, k = 0, 1, 2. An edge's term keeps the antiderivatives at the
    // cell's end for the next cell's start (its x0 + 1 is that x0 up to rounding) where the cell
    // computed them.
    struct Edge {
        Anti end{};
        bool has = false;
    };
    const auto cellIntegrals = [&](double x0, Edge& edge, double I[3]) {
        if (x0 >= reach || x0 + 1.0 <= -reach) {
            const bool one = x0 >= reach;
            I[0] = one ? 1.0 : 0.0, I[1] = one ? 0.5 : 0.0, I[2] = one ? 1.0 / 3.0 : 0.0;
            edge.has = false;
            return;
        }
        const Anti a0 = edge.has ? edge.end : anti(x0);
        const Anti a1 = anti(x0 + 1.0);
        edge.end = a1, edge.has = true;
        I[0] = a1.h1 - a0.h1;
        I[1] = a1.h1 - a1.h2 + a0.h2;
        I[2] = a1.h1 - 2.0 * a1.h2 + 2.0 * (a1.h3 - a0.h3);
    };
    // H1 at x, closed beyond 9s (H1(x) = x above: the law's mean is 0; 0 below).
    const auto h1At = [&](double x) { return x >= reach ? x : x <= -reach ? 0.0 : anti(x).h1; };
    const double inv2h = 1.0 / (2.0 * h);
    if (cLo == 0) {  // the mass below row 0
        w[0] += weight * (h1At(-mu + h) - h1At(-mu - h)) * inv2h;
        rLo = std::min(rLo, 0);
    }
    // The terms of the box's lower edge (F(g − μ + h)) and its upper edge (F(g − μ − h)).
    Edge lower, upper;
    for (int c = cLo; c <= cHi; ++c) {
        double A[3], B[3];
        cellIntegrals(c - mu + h, lower, A);
        cellIntegrals(c - mu - h, upper, B);
        addCellMoments(w, c, weight, (A[0] - B[0]) * inv2h, (A[1] - B[1]) * inv2h,
                       (A[2] - B[2]) * inv2h);
    }
    if (cHi == H - 2) {  // the mass above row H − 1
        const double g = H - 1.0;
        w[2 * H - 2] += weight * (1.0 - (h1At(g - mu + h) - h1At(g - mu - h)) * inv2h);
    }
    rLo = std::min(rLo, 2 * cLo);
    rHi = std::max(rHi, cHi == H - 2 ? 2 * H - 1 : 2 * cHi + 3);
}
}  // namespace

bool Tf2BlurTables::boxSpline(const Tf2Raster<double>& r, double cx, double cy,
                              const BoxDirection2* d, int n, double tinyWidth,
                              double out[4]) const {
    const auto exact = [&] {
        expectedTf2UniformRefined(r, cx, cy, d, n, tinyWidth, out);
        return false;
    };
    if (!available()) return exact();
    const int W = width_, H = height_, BW = 2 * W - 1;
    // In raster cells.
    const double sc = (cx - r.x0) * r.invDx, tc = (cy - r.y0) * r.invDy;
    if (!(std::abs(sc) < 1e9 && std::abs(tc) < 1e9) || n > 32) return exact();
    double ca[32], cb[32];  // the corners (a ≠ 0)
    int ncAll = 0;
    double restVar = 0.0, restK4 = 0.0, restK6 = 0.0, half = 0.0;
    for (int k = 0; k < n && k < 32; ++k) {
        const double ak = d[k].a * r.invDx, bk = d[k].b * r.invDy;
        if (!(std::abs(ak) < 1e9 && std::abs(bk) < 1e9)) return exact();
        if (std::abs(d[k].a) > tinyWidth && ak != 0.0) {
            ca[ncAll] = ak, cb[ncAll] = bk, ++ncAll;
        } else {
            // G-only: the widest kept exact, the others as variance b²/3 and κ4 −2b⁴/15.
            double g = std::abs(bk);
            if (g > half) std::swap(g, half);
            restVar += g * g / 3.0;
            restK4 -= 2.0 / 15.0 * g * g * g * g;
            restK6 += 16.0 / 63.0 * g * g * g * g * g * g;
        }
    }
    if (ncAll < kColumnsMinCorners) return exact();
    {
        double reach = std::abs(tc) + half;  // G's support bounds every row index below
        for (int k = 0; k < n; ++k) reach += std::abs(d[k].b * r.invDy);
        if (!(reach < kColumnsMaxReachG)) return exact();
    }
    // The corners whose box dominates the law of G (far from a Gram–Charlier normal): the widest in
    // G where its b²/3 is over kColumnsKeepShare of var G, then the next where it is over that
    // share of what is left (also when narrower than the widest G-only box: that box is exact, and
    // a corner beside it can still dominate the rest; sweep of 2026-12-05, 3.4e−3 off where such a
    // corner was left in the law). Each is cut along its t into
    // `pieces` boxes of 1/pieces its length: a sub-box stays a corner of the moments (exact in x,
    // a small share of G), and the sample is the mixture over the pieces' centres (nodes, equal
    // weights; with two cut, their product), so the law at every node is near a normal. Pieces:
    // a sub-box's b²/3 at most kColumnsPieceShare of it and the rest's var G given X (the
    // rest's normal regression: its var G − cov²/var X), at most kColumnsMaxNodes nodes.
    int cut[2] = {-1, -1}, pieces[2] = {1, 1};
    {
        double varG = restVar + half * half / 3.0;
        for (int i = 0; i < ncAll; ++i) varG += cb[i] * cb[i] / 3.0;
        for (int k = 0; k < 2; ++k) {
            double widest = 0.0;
            int w = -1;
            for (int i = 0; i < ncAll; ++i)
                if (i != cut[0] && cb[i] * cb[i] > widest) widest = cb[i] * cb[i], w = i;
            if (!(widest / 3.0 > kColumnsKeepShare * varG)) break;
            cut[k] = w;
            varG -= widest / 3.0;
        }
    }
    double a[32], bp[32][kMomentsG];  // the corners in the moments: x extent, b^p/p!
    int nc = 0;
    double A = 0.0, sxx = 0.0, sxg = 0.0, sgg = restVar + half * half / 3.0;
    const auto addCorner = [&](double ai, double bi) {
        a[nc] = ai;
        double f = 1.0;
        for (int p = 0; p < kMomentsG; ++p) bp[nc][p] = f, f *= bi / (p + 1);
        A += std::abs(ai);
        ++nc;
    };
    for (int i = 0; i < ncAll; ++i) {
        if (i == cut[0] || i == cut[1]) continue;
        addCorner(ca[i], cb[i]);
        sxx += ca[i] * ca[i] / 3.0, sxg += ca[i] * cb[i] / 3.0, sgg += cb[i] * cb[i] / 3.0;
    }
    const double restGivenX = sgg - (sxx > 0.0 ? sxg * sxg / sxx : 0.0);
    for (int k = 0; k < 2 && cut[k] >= 0; ++k) {
        const double boxVar = cb[cut[k]] * cb[cut[k]] / 3.0;
        const double want = std::ceil(
            std::sqrt(boxVar * (1.0 - kColumnsPieceShare) / (kColumnsPieceShare * restGivenX)));
        if (!(want <= kColumnsMaxNodes)) return exact();
        pieces[k] = std::max(1, static_cast<int>(want));
        addCorner(ca[cut[k]] / pieces[k], cb[cut[k]] / pieces[k]);
    }
    if (pieces[0] * pieces[1] > kColumnsMaxNodes) return exact();
    // X's support past kColumnsMaxSupport cells: the exact evaluation (the basis indices to sum;
    // the nodes move X by up to the cut boxes' whole extents).
    double reachX = A;
    for (int k = 0; k < 2 && cut[k] >= 0; ++k)
        reachX += std::abs(ca[cut[k]]) * (1.0 - 1.0 / pieces[k]);
    if (!(reachX < kColumnsMaxSupport)) return exact();
    // The corners' E[ψ_P(X)·G_c^j] by the Fourier series of X's law made periodic with period
    // L ≥ 2A + 2 (no copy meets a ψ_P that meets X): ρ̂_j(ω) = E[e^{−iωX} G_c^j]
    // = e^{−iωs0}·j!·i^j·R_j(ω), R_j the coefficient of s^j in Π_i Σ_p g^(p)(ωa_i)(b_i s)^p/p!
    // (real); m_P^j = (1/L)·Σ_m ρ̂_j(ω_m)·∫ψ_P e^{iω_m x}.
    const double L = 2.0 * A + 3.0, dw = 2.0 * std::numbers::pi / L;
    std::vector<double> Wn, Wb;  // per term m ≥ 1 and j: 2·Ψ(ω_m)·R_j(ω_m)
    double R0[kMomentsG] = {};
    {
        // Eight terms a batch in double lanes; the corners' sin and cos of ω_m·a_i and the
        // spectra's of ω_m/2 by rotation (a libm call a term and corner took 17 % of a tooth
        // frame).
        using lanes::V8d;
        std::array<Rotation8, 32> corner;
        for (int i = 0; i < nc; ++i) corner[i] = Rotation8(dw * a[i]);
        Rotation8 halfw(0.5 * dw);
        const V8d iota = {0, 1, 2, 3, 4, 5, 6, 7};
        bool done = false;
        for (int m0 = 0; !done; m0 += 8) {
            if (m0 + 8 > kColumnsMaxTerms) return exact();  // terms m < kColumnsMaxTerms only
            const V8d w = (iota + m0) * dw;
            V8d R[kMomentsG] = {V8d{} + 1.0}, env = V8d{} + 1.0;
            for (int i = 0; i < nc; ++i) {
                const V8d th = w * a[i];
                V8d g[kMomentsG];
                sincDerivatives(th, corner[i].s, corner[i].c, g);
                corner[i].step();
                V8d e[kMomentsG];
                for (int p = 0; p < kMomentsG; ++p) e[p] = g[p] * bp[i][p];
                for (int j = kMomentsG - 1; j >= 0; --j) {
                    V8d acc = R[j] * e[0];
                    for (int p = 1; p <= j; ++p) acc += R[j - p] * e[p];
                    R[j] = acc;
                }
                env *= lanes::min(V8d{} + 1.0, 1.0 / lanes::max(th, -th));
            }
            const V8d pn = 2.0 * nodeSpectrum(w, halfw.s, halfw.c);
            const V8d pb = 2.0 * bubbleSpectrum(w, halfw.s, halfw.c);
            halfw.step();
            for (int l = 0; l < 8 && !done; ++l) {
                const int m = m0 + l;
                if (m == 0) {
                    for (int j = 0; j < kMomentsG; ++j) R0[j] = R[j][0];
                    continue;
                }
                for (int j = 0; j < kMomentsG; ++j)
                    Wn.push_back(pn[l] * R[j][l]), Wb.push_back(pb[l] * R[j][l]);
                done = 2.0 / L * env[l] * 4.0 / (w[l] * w[l]) * m < kColumnsTailTol;
            }
        }
    }
    const int M = static_cast<int>(Wn.size() / kMomentsG);
    // i^j, i^(j+1) real parts; j!
    static constexpr double kSign[kMomentsG] = {1.0, -1.0, -1.0, 1.0, 1.0, -1.0, -1.0};
    static constexpr double kFact[kMomentsG] = {1.0, 1.0, 2.0, 6.0, 24.0, 120.0, 720.0};
    // The sum over the basis at one node (a centre of the cut boxes' pieces): (s0, t0) the centre
    // in raster cells; false where it does not apply (a y window or the sample's y budget past its
    // cap, no y pass under the process's cap, the weights' sum not positive).
    if (static_cast<double>(pieces[0] * pieces[1]) * (4.0 * A + 6.0) * M > kColumnsMaxWork)
        return exact();
    long points = kColumnsMaxPoints;  // the y sums' budget
    const Rotation8 unit(dw);         // the basis sums' lanes: (cos, sin)(l·dw), and of 8·dw
    const double cHalf = std::cos(0.5 * dw), sHalf = std::sin(0.5 * dw);
    std::vector<double> mom, rowW(static_cast<std::size_t>(2 * H - 1), 0.0);
    const auto atNode = [&](double s0, double t0, double weight, double acc[4]) {
        // The basis indices whose support meets X's, [s0 − A, s0 + A]: node k (P = 2k) on
        // [k − 1, k + 1], bubble k (P = 2k + 1) on [k, k + 1]. Beyond the raster (P < 0, P > 2W −
        // 2) virtual ones: the TF2 is constant in x there (the raster clamps), so their Z is the
        // end node's, and each keeps its own narrow law of G (one weight over all of x < 0 would
        // mix the G of a wide range of X).
        const int P0 = 2 * static_cast<int>(std::floor(s0 - A));  // node ⌊s0 − A⌋ …
        const int P1 = 2 * static_cast<int>(std::ceil(s0 + A));   // … node ⌈s0 + A⌉
        const int count = P1 - P0 + 1;
        mom.assign(static_cast<std::size_t>(count) * kMomentsG, 0.0);  // m_P^j
        // Per basis index: (j!/L)·i^j·Σ_m 2Ψ(ω_m)R_j(ω_m)·e^{iω_m(centre − s0)}, real: cos for
        // even j, sin for odd. Eight indices of one kind (nodes, or bubbles: P of one parity,
        // the same Ψ) a batch in double lanes, cos and sin of m·Δ by rotation.
        using lanes::V8d;
        // P0 is even: nodes from P0, bubbles from P0 + 1 (their centres half a cell on). Lane l
        // of a batch: Δ = dw·(centre − s0), centres P/2 one cell apart: the first centre's angle
        // rotated by l·dw, a batch on by 8·dw. A node batch and the bubble batch beside it share
        // one loop over the terms: two independent rotation chains (one alone waited on its
        // multiply-add latency).
        const double cN = std::cos(dw * (0.5 * P0 - s0)), sN = std::sin(dw * (0.5 * P0 - s0));
        const double cB = cN * cHalf - sN * sHalf, sB = sN * cHalf + cN * sHalf;
        V8d cdN = cN * unit.c - sN * unit.s, sdN = sN * unit.c + cN * unit.s;
        V8d cdB = cB * unit.c - sB * unit.s, sdB = sB * unit.c + cB * unit.s;
        const auto start = [&](double psi0, V8d sums[kMomentsG]) {  // m = 0: Ψ(0)·R_j(0)
            for (int j = 0; j < kMomentsG; ++j) sums[j] = V8d{} + (j % 2 ? 0.0 : psi0 * R0[j]);
        };
        const auto store = [&](int Pb, const V8d sums[kMomentsG]) {
            const int lanesUsed = std::min(8, (P1 - Pb) / 2 + 1);
            for (int l = 0; l < lanesUsed; ++l) {
                double* o = mom.data() + static_cast<std::size_t>(Pb + 2 * l - P0) * kMomentsG;
                for (int j = 0; j < kMomentsG; ++j) o[j] = kFact[j] * kSign[j] * sums[j][l] / L;
            }
        };
        for (int PbN = P0; PbN <= P1; PbN += 16) {
            const int PbB = PbN + 1;
            V8d c = V8d{} + 1.0, sn = V8d{}, cbub = V8d{} + 1.0, sbub = V8d{};
            V8d sums[kMomentsG], sumsB[kMomentsG];
            start(2.0 / 3.0, sums);
            start(1.0 / 3.0, sumsB);
            for (int m = 0; m < M; ++m) {
                rotate(c, sn, cdN, sdN);
                rotate(cbub, sbub, cdB, sdB);
                const double* wn = Wn.data() + static_cast<std::size_t>(m) * kMomentsG;
                const double* wb = Wb.data() + static_cast<std::size_t>(m) * kMomentsG;
                for (int j = 0; j < kMomentsG; j += 2) sums[j] += wn[j] * c;
                for (int j = 1; j < kMomentsG; j += 2) sums[j] += wn[j] * sn;
                for (int j = 0; j < kMomentsG; j += 2) sumsB[j] += wb[j] * cbub;
                for (int j = 1; j < kMomentsG; j += 2) sumsB[j] += wb[j] * sbub;
            }
            store(PbN, sums);
            if (PbB <= P1) store(PbB, sumsB);
            rotate(cdN, sdN, unit.c8, unit.s8);
            rotate(cdB, sdB, unit.c8, unit.s8);
        }
        // Each basis index's law of G and E[Z_P(μ_P + Y_P)].
        const double mass = std::max(1e-300, R0[0]);  // E[1] = 0!·i⁰·R_0(0)
        int Plo = P0, Phi = P1;  // X's tails left out: weights summing to ≤ kColumnsTailMass / 2
        for (double tail = 0.0; Plo < Phi; ++Plo) {
            tail += std::abs(mom[static_cast<std::size_t>(Plo - P0) * kMomentsG]);
            if (tail > 0.5 * kColumnsTailMass * mass) break;
        }
        for (double tail = 0.0; Phi > Plo; --Phi) {
            tail += std::abs(mom[static_cast<std::size_t>(Phi - P0) * kMomentsG]);
            if (tail > 0.5 * kColumnsTailMass * mass) break;
        }
        int levelY = 0;  // the y ladder's level of the last basis index above it
        for (int Pv = Plo; Pv <= Phi; ++Pv) {
            const double* o = mom.data() + static_cast<std::size_t>(Pv - P0) * kMomentsG;
            const int P = std::clamp(Pv, 0, BW - 1);  // the raster's basis index (virtual: its end)
            const double m0 = o[0];
            if (!(m0 > kColumnsMinWeight * mass)) continue;
            const double mu = o[1] / m0, e2 = o[2] / m0, e3 = o[3] / m0, e4 = o[4] / m0;
            const double e5 = o[5] / m0, e6 = o[6] / m0, mu2 = mu * mu, mu3 = mu2 * mu;
            const double c2 = std::max(0.0, e2 - mu2);
            const double c3 = e3 - 3.0 * mu * e2 + 2.0 * mu3;
            const double c4 = e4 - 4.0 * mu * e3 + 6.0 * mu2 * e2 - 3.0 * mu3 * mu;
            const double c5 =
                e5 - 5.0 * mu * e4 + 10.0 * mu2 * e3 - 10.0 * mu3 * e2 + 4.0 * mu3 * mu2;
            const double c6 = e6 - 6.0 * mu * e5 + 15.0 * mu2 * e4 - 20.0 * mu3 * e3 +
                              15.0 * mu3 * mu * e2 - 5.0 * mu3 * mu3;
            const double var = c2 + restVar;
            // The standardised cumulants held to a box spline's range (|γ1| ≤ 2, γ2 ∈ [−2, 6]; a
            // box: 0, −1.2), so that a weight's few noisy moments cannot blow the density's
            // polynomial factor up.
            const double sv = std::sqrt(var);
            const double k3 = std::clamp(c3, -2.0 * var * sv, 2.0 * var * sv);
            const double k4 =
                std::clamp((c4 - 3.0 * c2 * c2) + restK4, -2.0 * var * var, 6.0 * var * var);
            // κ5 and κ6 likewise held, |κ5|/σ⁵ ≤ 10 and |κ6|/σ⁶ ≤ 20 (a box: 0 and 6.86); the
            // G-only boxes add their κ6, 16b⁶/63 each.
            const double k5 =
                std::clamp(c5 - 10.0 * c3 * c2, -10.0 * var * var * sv, 10.0 * var * var * sv);
            const double k6raw =
                c6 - 15.0 * c4 * c2 - 10.0 * c3 * c3 + 30.0 * c2 * c2 * c2 + restK6;
            const double g = t0 + mu;
            double e[4] = {};
            // Above the ladder the widest G-only box is folded into the law (its variance h²/3,
            // κ4 −2h⁴/15 = −1.2·(h²/3)² and κ6 16h⁶/63) where it holds at most kColumnsFoldShare
            // of it: the weights are then the law's density itself, with no normal CDF.
            const double boxVar = half * half / 3.0;
            const bool fold = boxVar <= kColumnsFoldShare * (var + boxVar);
            const double varW = fold ? var + boxVar : var;
            if (varW >= 2.0 * kMinBlur * kMinBlur) {
                const double hW = fold ? 0.0 : half;
                const double k4W = fold ? std::clamp(k4 - 1.2 * boxVar * boxVar, -2.0 * varW * varW,
                                                     6.0 * varW * varW)
                                        : k4;
                // The y pass of the largest blur b with b² ≤ ½·varW: E = Σ_q p(y_q −
                // g)·Z_P^(b)(y_q) over its rows (trapezoid; p the law less the blur: N(0, varW −
                // b²) with κ3 … κ6 (Gram–Charlier: its first six moments exact), ⊛ the box where it
                // is not folded), weights normalised.
                // (Walked from the previous basis index's level: neighbours' laws are alike, so
                // it moves 0–1 levels; a log2 a basis index took 4 % of the tangle's frame.)
                int& j = levelY;
                while (j > 0 && ay_->levels[j].blur * ay_->levels[j].blur > 0.5 * varW) --j;
                while (j + 1 < levelsY_ &&
                       ay_->levels[j + 1].blur * ay_->levels[j + 1].blur <= 0.5 * varW)
                    ++j;
                const Axis::Level& ly = ay_->levels[j];
                const Pass* zp = pass(j);
                if (!zp) return false;  // past the process's cap
                const Pass& z = *zp;
                const double sr = std::sqrt(varW - ly.blur * ly.blur);
                const double q3 = k3 / (6.0 * sr * sr * sr), q4 = k4W / (24.0 * sr * sr * sr * sr);
                // p(u) = φ(z)/sr·(1 + q3·He3 + q4·He4 + q5·He5 + q6·He6)(z), z = u/sr: q_n =
                // E[He_n(Z)]/n!, so q6 takes κ6 + 10κ3² (the folded box adds its κ6, 16h⁶/63).
                const double v3 = varW * varW * varW;
                const double k6W =
                    std::clamp(k6raw + (fold ? 16.0 / 63.0 * 27.0 * boxVar * boxVar * boxVar : 0.0),
                               -20.0 * v3, 20.0 * v3);
                const double sr2 = sr * sr;
                const double q5 = k5 / (120.0 * sr2 * sr2 * sr);
                const double q6 = (k6W + 10.0 * k3 * k3) / (720.0 * sr2 * sr2 * sr2);
                const double reach = kRadius * sr + hW;
                const int qa = static_cast<int>(std::ceil((g - reach - ly.start) / ly.spacing));
                const int qb = static_cast<int>(std::floor((g + reach - ly.start) / ly.spacing));
                if (qb - qa > kColumnsMaxWindow) return false;
                points -= qb - qa + 1;
                if (points < 0) return false;
                // The weights p(y_q − g) eight rows at a time in double lanes.
                using lanes::V8d;
                const bool boxed = hW > 1e-6 * sr;
                const auto F = [&](V8d u) {  // the antiderivative of the density, z = u/sr
                    const V8d zz = u / sr;
                    const NormalAt<V8d> nn = normalAt(zz, detail::ExpNonPositiveOf{});
                    return nn.cdf - (q3 * (zz * zz - 1.0) + q4 * (zz * zz * zz - 3.0 * zz) +
                                     q5 * ((zz * zz - 6.0) * zz * zz + 3.0) +
                                     q6 * (((zz * zz - 10.0) * zz * zz + 15.0) * zz)) *
                                        nn.pdf;
                };
                // The rows' table values (0 outside a row's [lo, hi)) gathered 8 rows a batch;
                // rows past the ends clamp (the raster does); lanes past qb weigh 0.
                const V8d iota = {0, 1, 2, 3, 4, 5, 6, 7};
                const double u0 = ly.start - g, invSr = 1.0 / sr;
                const float* zP = z.z.data() + P;
                const std::size_t rowStride = static_cast<std::size_t>(4) * BW;
                V8d wv{}, ev[4] = {};
                for (int qc0 = qa; qc0 <= qb; qc0 += 8) {
                    const V8d u = (iota + qc0) * ly.spacing + u0;
                    V8d p;
                    if (boxed) {
                        p = (F(u + hW) - F(u - hW)) / (2.0 * hW);
                    } else {
                        const V8d zz = u * invSr, z2 = zz * zz;
                        p = detail::ExpNonPositiveOf{}(-0.5 * z2) *
                            (std::numbers::inv_sqrtpi / std::numbers::sqrt2 * invSr) *
                            (1.0 + q3 * (z2 * zz - 3.0 * zz) + q4 * (z2 * z2 - 6.0 * z2 + 3.0) +
                             q5 * (((z2 - 10.0) * z2 + 15.0) * zz) +
                             q6 * (((z2 - 15.0) * z2 + 45.0) * z2 - 15.0));
                    }
                    if (qb - qc0 < 7) p = iota <= qb - qc0 ? p : V8d{};
                    wv += p;
                    V8d t[4];
                    for (int l = 0; l < 8; ++l) {
                        const float* zr =
                            zP + static_cast<std::size_t>(std::clamp(qc0 + l, 0, ly.count - 1)) *
                                     rowStride;
                        for (int ch = 0; ch < 4; ++ch)
                            t[ch][l] = zr[static_cast<std::size_t>(ch) * BW];
                    }
                    for (int ch = 0; ch < 4; ++ch) ev[ch] += p * t[ch];
                }
                double wsum = 0.0;
                for (int l = 0; l < 8; ++l) {
                    wsum += wv[l];
                    for (int ch = 0; ch < 4; ++ch) e[ch] += ev[ch][l];
                }
                if (!(wsum > 0.0)) return false;
                for (double& v : e) v /= wsum;
            } else {
                // Below the ladder: the rows' Bernstein basis in closed form (edgeworthRowWeights),
                // the G-only box convolved in closed form (edgeworthBoxRowWeights) unless it is
                // under 1e−3 of the normal's std (then its variance h²/3 is added: the box's κ4
                // is 1e−12 of the normal's scale).
                double s = std::max(std::sqrt(var), 1e-9);
                // (Under 1e−6 cells, also where s is at its floor, the box's (F(+h) − F(−h))/2h
                // would lose digits; its variance moves the mass by ≲ 1e−6 there.)
                const bool boxed = half > std::max(1e-3 * s, 1e-6);
                if (!boxed) s = std::sqrt(s * s + half * half / 3.0);
                const double q3 = k3 / (6.0 * s * s * s), q4 = k4 / (24.0 * s * s * s * s);
                int rLo = 2 * H, rHi = 0;
                if (boxed)
                    edgeworthBoxRowWeights(g, s, q3, q4, half, H, 1.0, rowW, rLo, rHi);
                else
                    edgeworthRowWeights(g, s, q3, q4, H, 1.0, rowW, rLo, rHi);
                points -= rHi - rLo;
                if (points < 0) return false;
                for (int R = rLo; R < rHi; ++R) {
                    const double wr = rowW[static_cast<std::size_t>(R)];
                    rowW[static_cast<std::size_t>(R)] = 0.0;  // zero again for the next index
                    if (wr == 0.0) continue;
                    for (int ch = 0; ch < 4; ++ch)
                        e[ch] += wr * q_[ch][static_cast<std::size_t>(R) * BW + P];
                }
            }
            for (int ch = 0; ch < 4; ++ch) acc[ch] += weight * m0 * e[ch];
        }
        return true;
    };
    double acc[4] = {};
    const double nodeWeight = 1.0 / (pieces[0] * pieces[1]);
    for (int k0 = 0; k0 < pieces[0]; ++k0)
        for (int k1 = 0; k1 < pieces[1]; ++k1) {
            double s0 = sc, t0 = tc;  // the pieces' centres t = −1 + (2k + 1)/pieces
            const int ks[2] = {k0, k1};
            for (int k = 0; k < 2 && cut[k] >= 0; ++k) {
                const double t = -1.0 + (2 * ks[k] + 1.0) / pieces[k];
                s0 += ca[cut[k]] * t, t0 += cb[cut[k]] * t;
            }
            if (!atNode(s0, t0, nodeWeight, acc)) return exact();
        }
    for (double v : acc)
        if (!std::isfinite(v)) return exact();
    out[3] = std::clamp(acc[3], 0.0, 1.0);
    for (int ch = 0; ch < 3; ++ch) out[ch] = std::clamp(acc[ch], 0.0, out[3]);
    return true;
}

}  // namespace udvr
