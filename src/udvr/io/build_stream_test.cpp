// The out-of-core build (issue 15): slabs of z-planes give the in-memory model bit for bit, and
// ModelVtiStreamWriter writes writeModelVti's file byte for byte.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "udvr/io/io_test_util.h"
#include "udvr/io/model_io.h"
#include "udvr/stats/build_model.h"
#include "udvr/util/random.h"

namespace udvr {
namespace {

using testing::readBytes;
using testing::TempDir;

// n members on an X×Y×Z grid; bimodal noise, some constant voxels, optionally NaNs.
Ensemble randomEnsemble(std::array<int, 3> dims, int n, std::uint64_t seed, bool nans = false) {
    Ensemble e;
    e.grid.dims = dims;
    e.grid.origin = {1.0, -2.0, 0.5};
    e.grid.spacing = {0.5, 0.25, 2.0};
    e.members = n;
    e.name = "value";
    const std::size_t P = e.grid.pointCount();
    e.values.resize(P * static_cast<std::size_t>(n));
    for (int m = 0; m < n; ++m)
        for (std::size_t v = 0; v < P; ++v) {
            CounterRng rng(seed, v, static_cast<std::uint64_t>(m));
            const double truth = std::sin(0.05 * static_cast<double>(v));
            double x =
                truth + (rng.uniform() < 0.7 ? 0.3 * rng.normal() : 1.5 + 0.5 * rng.normal());
            if (v % 11 == 3) x = truth;  // constant voxel
            if (nans && v % 13 == 5 && m == 1) x = std::nan("");
            e.member(m)[v] = static_cast<float>(x);
        }
    return e;
}

/// The ensemble as a SlabInput that reads from memory.
SlabInput slabsOf(const Ensemble& e) {
    SlabInput in;
    in.grid = e.grid;
    in.members = e.members;
    in.valueStep = e.valueStep;
    in.valueType = e.valueType;
    const std::size_t plane =
        static_cast<std::size_t>(e.grid.dims[0]) * static_cast<std::size_t>(e.grid.dims[1]);
    in.read = [&e, plane](int z0, int z1, std::span<float> out) {
        const std::size_t count = static_cast<std::size_t>(z1 - z0) * plane;
        ASSERT_EQ(out.size(), count * static_cast<std::size_t>(e.members));
        for (int m = 0; m < e.members; ++m)
            std::memcpy(out.data() + static_cast<std::size_t>(m) * count,
                        e.member(m) + static_cast<std::size_t>(z0) * plane, count * sizeof(float));
    };
    return in;
}

/// Collects the slabs into one model (arrays concatenated in order).
struct Collect {
    ModelVolume all;
    std::size_t next = 0;
    void operator()(const ModelVolume& s, std::size_t first) {
        EXPECT_EQ(first, next);
        next += s.mean.size();
        auto cat = [](std::vector<float>& a, const std::vector<float>& b) {
            a.insert(a.end(), b.begin(), b.end());
        };
        cat(all.mean, s.mean);
        cat(all.stddev, s.stddev);
        cat(all.min, s.min);
        cat(all.max, s.max);
        cat(all.quantiles, s.quantiles);
        cat(all.iqr, s.iqr);
        cat(all.gmm, s.gmm);
    }
};

bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

void expectSameModel(const ModelVolume& ref, const ModelVolume& meta, const ModelVolume& arrays) {
    EXPECT_TRUE(sameBits(ref.mean, arrays.mean));
    EXPECT_TRUE(sameBits(ref.stddev, arrays.stddev));
    EXPECT_TRUE(sameBits(ref.min, arrays.min));
    EXPECT_TRUE(sameBits(ref.max, arrays.max));
    EXPECT_TRUE(sameBits(ref.quantiles, arrays.quantiles));
    EXPECT_TRUE(sameBits(ref.iqr, arrays.iqr));
    EXPECT_TRUE(sameBits(ref.gmm, arrays.gmm));
    EXPECT_EQ(ref.bandwidth, meta.bandwidth);
    EXPECT_EQ(ref.density, meta.density);
    EXPECT_EQ(ref.tailEps, meta.tailEps);
    EXPECT_EQ(ref.samplesPerVoxel, meta.samplesPerVoxel);
    EXPECT_EQ(ref.grid.dims, meta.grid.dims);
    EXPECT_EQ(ref.bounds, meta.bounds);
    EXPECT_EQ(ref.downsample, meta.downsample);
}

}  // namespace

TEST(BuildStream, EnsembleSlabsGiveTheInMemoryModelBitForBit) {
    const Ensemble e = randomEnsemble({9, 6, 17}, 12, 7);
    for (DensityEstimate d : {DensityEstimate::Empirical, DensityEstimate::Kde}) {
        BuildOptions opt;
        opt.density = d;
        opt.quantiles = 6;
        opt.gmmComponents = 3;
        BuildReport refReport;
        const ModelVolume ref = buildModel(e, opt, &refReport);
        for (int planes : {1, 7, 17, 40}) {
            SCOPED_TRACE("slab planes " + std::to_string(planes));
            Collect c;
            BuildReport rep;
            const ModelVolume meta = buildModelStreamed(
                slabsOf(e), planes, opt,
                [&c](const ModelVolume& s, std::size_t first) { c(s, first); }, {}, &rep);
            expectSameModel(ref, meta, c.all);
            EXPECT_EQ(rep.constantVoxels, refReport.constantVoxels);
            EXPECT_EQ(rep.meanGmmIterations, refReport.meanGmmIterations);
            EXPECT_EQ(rep.slabs, (17 + std::min(planes, 17) - 1) / std::min(planes, 17));
        }
    }
}

TEST(BuildStream, NanSkipAndNanErrorAsInMemory) {
    const Ensemble e = randomEnsemble({5, 4, 9}, 6, 3, true);
    BuildOptions opt;
    opt.nan = NanPolicy::Skip;
    BuildReport refReport;
    const ModelVolume ref = buildModel(e, opt, &refReport);
    Collect c;
    BuildReport rep;
    const ModelVolume meta = buildModelStreamed(
        slabsOf(e), 2, opt, [&c](const ModelVolume& s, std::size_t first) { c(s, first); }, {},
        &rep);
    expectSameModel(ref, meta, c.all);
    EXPECT_EQ(rep.nonFiniteSamples, refReport.nonFiniteSamples);
    EXPECT_EQ(rep.fewestFiniteSamples, refReport.fewestFiniteSamples);

    // --nan error: the same line, from two passes (GMM) or one (no GMM: the slab with the NaN
    // ends the build, the rest is only scanned for the count).
    opt.nan = NanPolicy::Error;
    for (int K : {4, 0}) {
        opt.gmmComponents = K;
        std::string want, got;
        try {
            buildModel(e, opt);
        } catch (const UdvrError& err) {
            want = err.what();
        }
        std::size_t sunk = 0;
        try {
            buildModelStreamed(slabsOf(e), 2, opt,
                               [&sunk](const ModelVolume&, std::size_t) { ++sunk; });
        } catch (const UdvrError& err) {
            got = err.what();
        }
        EXPECT_FALSE(want.empty());
        EXPECT_EQ(want, got);
        EXPECT_EQ(sunk, 0u);  // the first NaN is in slab 0
    }
    // No GMM and no NaN: one pass, the same model.
    const Ensemble clean = randomEnsemble({5, 4, 9}, 6, 3);
    opt.gmmComponents = 0;
    const ModelVolume cleanRef = buildModel(clean, opt);
    Collect c0;
    BuildReport rep0;
    const ModelVolume meta0 = buildModelStreamed(
        slabsOf(clean), 4, opt, [&c0](const ModelVolume& s, std::size_t first) { c0(s, first); },
        {}, &rep0);
    expectSameModel(cleanRef, meta0, c0.all);
    EXPECT_EQ(rep0.inputPasses, 1);
}

TEST(BuildStream, BrickSlabsGiveTheInMemoryModelBitForBit) {
    const Ensemble e = randomEnsemble({11, 8, 23}, 1, 5);
    ScalarField f;
    f.grid = e.grid;
    f.values = e.values;
    BuildOptions opt;
    opt.density = DensityEstimate::Kde;
    opt.gmmComponents = 2;
    const int k = 3;
    BuildReport refReport;
    const ModelVolume ref = buildModelDownsampled(f, k, opt, &refReport);
    SlabInput in = slabsOf(e);
    for (int bricks : {1, 2, 7, 100}) {
        SCOPED_TRACE("slab bricks " + std::to_string(bricks));
        Collect c;
        BuildReport rep;
        const ModelVolume meta = buildModelDownsampledStreamed(
            in, k, bricks, opt, [&c](const ModelVolume& s, std::size_t first) { c(s, first); }, {},
            &rep);
        expectSameModel(ref, meta, c.all);
        EXPECT_EQ(rep.droppedPlanes, refReport.droppedPlanes);
    }
}

TEST(BuildStream, StreamWriterWritesTheSameFileByteForByte) {
    TempDir dir;
    const Ensemble e = randomEnsemble({31, 29, 23}, 8, 11);  // > 32 KiB per array: many blocks
    for (int q : {0, 8}) {
        BuildOptions opt;
        opt.quantiles = q;
        opt.gmmComponents = q == 0 ? 0 : 4;
        opt.source = "test source";
        const ModelVolume ref = buildModel(e, opt);
        writeModelVti(dir / "ref.vti", ref);
        for (int planes : {1, 7, 23}) {
            SCOPED_TRACE("q " + std::to_string(q) + ", slab planes " + std::to_string(planes));
            ModelVtiStreamWriter writer(dir / "stream.vti", e.grid, opt.quantiles,
                                        opt.gmmComponents);
            const ModelVolume meta = buildModelStreamed(
                slabsOf(e), planes, opt,
                [&writer](const ModelVolume& s, std::size_t) { writer.append(s); });
            writer.finish(meta);
            EXPECT_EQ(readBytes(dir / "ref.vti"), readBytes(dir / "stream.vti"));
            const ModelVolume back = readModelVti(dir / "stream.vti");
            EXPECT_TRUE(sameBits(ref.quantiles, back.quantiles));
            EXPECT_TRUE(sameBits(ref.gmm, back.gmm));
        }
    }
    // Nothing but the two outputs is left in the directory (the spill files are unnamed).
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path()))
        ++files;
    EXPECT_EQ(files, 2u);
}

}  // namespace udvr
