#include "udvr/stats/model_volume.h"

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <utility>

#include "udvr/stats/model_view.h"
#include "udvr/util/check.h"
#include "udvr/util/parallel.h"

namespace udvr {

std::vector<double> normalizedQuantileLevels(const std::vector<double>& levels, int q,
                                             const std::string& what) {
    if (levels.empty()) return {};
    if (static_cast<int>(levels.size()) != q + 1)
        UDVR_FAIL(what << " has " << levels.size() << " levels for " << q
                       << " quantiles; expected q + 1 = " << q + 1);
    if (levels.front() != 0.0 || levels.back() != 1.0)
        UDVR_FAIL(what << " must start at 0 and end at 1 (got " << levels.front() << " … "
                       << levels.back() << ")");
    bool even = true;
    for (std::size_t j = 0; j < levels.size(); ++j) {
        if (!std::isfinite(levels[j]) || (j > 0 && !(levels[j] > levels[j - 1])))
            UDVR_FAIL(what << " must be strictly increasing finite numbers; level " << j << " is "
                           << levels[j]);
        even = even && std::abs(levels[j] - static_cast<double>(j) / q) <= 1e-9;
    }
    return even ? std::vector<double>{} : levels;
}

int ModelView::boundaryAtLevel(double t) const {
    for (int j = 0; j <= quantileCount; ++j)
        if (std::abs(quantileLevel(j) - t) <= 1e-9) return j;
    return -1;
}

std::span<const float>& ModelView::array(const ModelFileArray& a) {
    static_assert(std::size(kModelFileArrays) == 7, "a view member per model file array");
    std::span<const float> ModelView::*const inOrder[] = {
        &ModelView::mean,      &ModelView::stddev, &ModelView::min, &ModelView::max,
        &ModelView::quantiles, &ModelView::iqr,    &ModelView::gmm};
    for (std::size_t i = 0; i < std::size(kModelFileArrays); ++i)
        if (kModelFileArrays[i].values == a.values) return this->*inOrder[i];
    UDVR_FAIL("unknown model array '" << a.name << "'");
}

void checkModelArrays(const ModelVolume& m, const std::string& what) {
    checkModelArrays(ModelView(m), what);
}

void checkModelArrays(const ModelView& m, const std::string& what) {
    const std::size_t n = m.voxelCount();
    const auto voxel = [&](std::size_t v) {
        const auto nx = static_cast<std::size_t>(m.grid.dims[0]);
        const auto ny = static_cast<std::size_t>(m.grid.dims[1]);
        return "(" + std::to_string(v % nx) + ", " + std::to_string(v / nx % ny) + ", " +
               std::to_string(v / (nx * ny)) + ")";
    };
    const auto fail = [&](const char* array, const std::string& problem, std::size_t v) {
        UDVR_FAIL(what << ": array '" << array << "' " << problem << " at voxel " << voxel(v));
    };
    const auto number = [](double x) {
        std::ostringstream s;
        s << x;
        return s.str();
    };
    for (const ModelFileArray& a : kModelFileArrays) {
        const std::span<const float> values = m.array(a);
        const int per = a.floatsPerVoxel(m.quantileCount, m.gmmComponents);
        if (values.empty() || per <= 0 || values.size() != n * static_cast<std::size_t>(per))
            continue;
        for (std::size_t i = 0; i < values.size(); ++i)
            if (!std::isfinite(values[i]))
                fail(a.name,
                     std::string("holds ") + (std::isnan(values[i]) ? "NaN" : "Inf") +
                         (per > 1 ? " (component " + std::to_string(i % per) + ")" : ""),
                     i / per);
    }
    const auto sigma = [&](const char* array, float s, std::size_t v, const std::string& which) {
        if (s < 0.f) fail(array, which + "is negative (" + number(s) + ")", v);
        if (s > kMaxModelSigma)
            fail(array, which + "is " + number(s) + ", over " + number(kMaxModelSigma), v);
    };
    if (m.stddev.size() == n)
        for (std::size_t v = 0; v < n; ++v) sigma("stddev", m.stddev[v], v, "");
    if (m.min.size() == n && m.max.size() == n)
        for (std::size_t v = 0; v < n; ++v)
            if (m.min[v] > m.max[v])
                fail("min", "is " + number(m.min[v]) + ", over max " + number(m.max[v]), v);
    // Increasing rows: quantile boundaries b_0 ≤ … ≤ b_q, the iqr pair.
    const auto increasing = [&](const char* array, std::span<const float> values, int per) {
        if (per < 2 || values.size() != n * static_cast<std::size_t>(per)) return;
        for (std::size_t v = 0; v < n; ++v) {
            const float* row = values.data() + v * static_cast<std::size_t>(per);
            for (int j = 1; j < per; ++j)
                if (row[j] < row[j - 1])
                    fail(array,
                         "decreases: boundary " + std::to_string(j) + " (" + number(row[j]) +
                             ") is below boundary " + std::to_string(j - 1) + " (" +
                             number(row[j - 1]) + ")",
                         v);
        }
    };
    if (m.quantileCount > 0) increasing("quantiles", m.quantiles, m.quantileCount + 1);
    increasing("iqr", m.iqr, 2);
    const int k = m.gmmComponents;
    if (k > 0 && m.gmm.size() == n * 3 * static_cast<std::size_t>(k))
        for (std::size_t v = 0; v < n; ++v) {
            const float* g = m.gmmAt(v);
            for (int c = 0; c < k; ++c) {
                const std::string which = "component " + std::to_string(c) + " ";
                if (!(g[c] >= 0.f && g[c] <= 1.f))
                    fail("gmm", which + "weight is " + number(g[c]) + ", outside [0, 1]", v);
                sigma("gmm", g[2 * k + c], v, which + "sigma ");
            }
        }
}

ModelVolume modelFromField(const ScalarField& field) {
    ModelVolume m;
    m.grid = field.grid;
    m.mean = field.values;
    m.min = field.values;
    m.max = field.values;
    m.stddev.assign(field.values.size(), 0.f);
    m.samplesPerVoxel = 1;
    m.setFullResolution(field.grid, 0);
    m.source = field.name;
    return m;
}

ModelVolume membersModel(Ensemble ensemble) {
    const int n = ensemble.members;
    const std::size_t voxels = ensemble.grid.pointCount();
    UDVR_CHECK_MSG(n >= 1 && ensemble.values.size() == voxels * static_cast<std::size_t>(n),
                   "ensemble size vs members x grid");
    ModelVolume m;
    m.grid = ensemble.grid;
    m.memberCount = n;
    if (ensemble.voxelMajor) {
        m.members = std::move(ensemble.values);
    } else {
        m.members.resize(ensemble.values.size());
        parallelForChunks(voxels, 4096, [&](std::size_t begin, std::size_t end) {
            for (int i = 0; i < n; ++i) {
                const float* member = ensemble.member(i);
                for (std::size_t v = begin; v < end; ++v) m.members[v * n + i] = member[v];
            }
        });
        ensemble.values = {};
    }
    m.mean.resize(voxels);
    parallelForChunks(voxels, 4096, [&](std::size_t begin, std::size_t end) {
        for (std::size_t v = begin; v < end; ++v) {
            double sum = 0.0;
            for (int i = 0; i < n; ++i) sum += m.members[v * n + i];
            m.mean[v] = static_cast<float>(sum / n);
        }
    });
    m.samplesPerVoxel = n;
    m.setFullResolution(ensemble.grid, 0);
    m.source = ensemble.name;
    return m;
}

}  // namespace udvr
