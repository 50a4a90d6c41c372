// `udvr build` on one process (build_steps.h): in memory, or out of core a slab at a time into a
// streamed .vti; the notes before the write and the report after it.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "udvr/classify/tf_presets.h"
#include "udvr/cmd/build_steps.h"
#include "udvr/io/model_io.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/check.h"
#include "udvr/util/memory.h"
#include "udvr/util/parallel.h"
#include "udvr/util/progress.h"

namespace udvr::cmd {
namespace {

std::string shortNumber(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

/// Models whose arrays pass this are announced before they are written (a small one is not:
/// its write takes no time, and a failing write stays one error line).
constexpr std::size_t kAnnounceModelBytes = std::size_t{32} << 20;

/// "build: the model: 192x192x96 voxels x 27 floats = 364 MiB uncompressed; writing it
/// LZ4-compressed (--no-compress: raw)\n" for a model over kAnnounceModelBytes, else "": what
/// the file will take, before it is written (issue 35).
std::string modelSizeNote(const Grid3& grid, int q, int k, bool compress) {
    const std::size_t bytes = modelArrayBytes(grid, q, k);
    if (bytes < kAnnounceModelBytes) return "";
    const std::size_t floats = grid.pointCount() > 0 ? bytes / 4 / grid.pointCount() : 0;
    char note[320];
    std::snprintf(note, sizeof note,
                  "build: the model: %dx%dx%d voxels x %zu floats = %s uncompressed; %s\n",
                  grid.dims[0], grid.dims[1], grid.dims[2], floats, byteSizeText(bytes).c_str(),
                  compress ? "writing it LZ4-compressed (ParaView reads it; --no-compress: raw)"
                           : "writing it raw (--no-compress)");
    return note;
}

/// "12.3 MB on disk (44 % of the arrays)" for the written file(s).
std::string diskSizeText(const std::string& path, std::size_t arrayBytes) {
    std::error_code ec;
    std::size_t bytes = 0;
    const std::filesystem::path p(path);
    if (lowerExtension(path) == ".pvti") {  // the pieces sit in <stem>/ beside the header
        const std::filesystem::path dir = p.parent_path() / p.stem();
        for (std::filesystem::recursive_directory_iterator it(dir, ec), end; !ec && it != end;
             it.increment(ec))
            if (it->is_regular_file(ec)) bytes += static_cast<std::size_t>(it->file_size(ec));
    }
    bytes += static_cast<std::size_t>(std::filesystem::file_size(p, ec));
    if (ec || bytes == 0) return "";
    char text[128];
    std::snprintf(
        text, sizeof text, " (%s on disk, %.0f %% of the %s of arrays)",
        byteSizeText(bytes).c_str(),
        arrayBytes > 0 ? 100.0 * static_cast<double>(bytes) / static_cast<double>(arrayBytes) : 0.0,
        byteSizeText(arrayBytes).c_str());
    return text;
}

/// One build on this process (no MPI): in memory, or out of core a slab at a time into a
/// streamed .vti; then the report on stderr.
class LocalBuild {
  public:
    LocalBuild(const BuildFlags& f, BuildOptions opt, MemoryLimit limit)
        : f_(f),
          opt_(std::move(opt)),
          limit_(std::move(limit)),
          forcedSlab_(f.slabHeightOpt->count() > 0 ? f.slabHeight : 0),
          bricks_(f.downsampleOpt->count() > 0),
          partitioned_(lowerExtension(f.out) == ".pvti"),
          skipNan_(opt_.nan == NanPolicy::Skip) {}

    void run() {
        if (bricks_)
            fromBricks();
        else
            fromEnsemble();
        write();
        report();
    }

  private:
    // For stderr once the input has been read (or scanned) without error.
    void sayNotes() {
        std::fputs(notes_.c_str(), stderr);
        notes_.clear();
    }
    SlabProgress progress() {
        return [this](const char* pass, int slab, int slabs, std::size_t voxels) {
            if (std::string(pass) == "build" && slab == 0) sayNotes();  // the scan passed
            return bars_.next(pass, slab, slabs, voxels);
        };
    }
    /// Out of core: the model's slabs go to the writer as they are built.
    void streamTo(const Grid3& modelGrid, const SlabReader& r, int planes,
                  const std::function<ModelVolume(const SlabInput&, const SlabSink&)>& run) {
        if (partitioned_)
            UDVR_FAIL("-o " << f_.out << ": this build runs out of core ("
                            << (forcedSlab_ > 0 ? std::string("--slab-height")
                                                : "its input and model exceed "
                                                  "--memory-limit " +
                                                      limit_.text)
                            << "), which writes a .vti model; write -o with .vti, or "
                               "give a larger --memory-limit");
        if (!r.note.empty()) notes_ = r.note + "\n" + notes_;
        const int slabPlanes = std::min(planes, modelGrid.dims[2]);
        const int slabs = (modelGrid.dims[2] + slabPlanes - 1) / slabPlanes;
        const int k = bricks_ ? f_.downsample : 1;
        const BuildMemory mem =
            buildMemory(r.grid, r.members, k, opt_, r.scratchPerPlane, r.scratchFixed);
        const int lastPlanes = modelGrid.dims[2] - (slabs - 1) * slabPlanes;
        const std::string last = lastPlanes != slabPlanes
                                     ? " (the last " + std::to_string(lastPlanes * k) + ")"
                                     : std::string();
        const std::size_t bytes =
            mem.fixed + residentBytes() + static_cast<std::size_t>(slabPlanes) * mem.perPlane;
        char plan[512];
        std::snprintf(plan, sizeof plan,
                      "build: out of core: %d slab%s of %d z-plane%s%s, about %s in memory "
                      "(limit %s)%s\n",
                      slabs, slabs == 1 ? "" : "s", slabPlanes * k, slabPlanes * k == 1 ? "" : "s",
                      last.c_str(), byteSizeText(bytes).c_str(), limit_.text.c_str(),
                      r.wholeMembers ? "; VTI/NRRD members are read whole for every slab" : "");
        notes_ += plan;
        if (f_.noCompress)
            UDVR_FAIL(
                "--no-compress writes a model built in memory; this build runs out of core "
                "(about "
                << byteSizeText(bytes) << " at a time): drop --no-compress or raise "
                << "--memory-limit");
        notes_ += modelSizeNote(modelGrid, opt_.quantiles, opt_.gmmComponents, true);
        ModelVtiStreamWriter writer(f_.out, modelGrid, opt_.quantiles, opt_.gmmComponents);
        const SlabInput in = slabInputOf(r);
        auto sink = [&](const ModelVolume& slab, std::size_t) {
            const auto ts = std::chrono::steady_clock::now();
            writer.append(slab);
            writeSeconds_ += secondsSince(ts);
        };
        model_ = run(in, sink);
        model_.defaultTf = streamedDefaultTf_;
        bars_.bar.reset();
        sayNotes();  // one pass (no GMM): only now is the whole input known to be finite
        const auto tf = std::chrono::steady_clock::now();
        writer.finish(model_);
        writeSeconds_ += secondsSince(tf);
        readSeconds_ = rep_.readSeconds;
        written_ = true;
    }
    std::vector<double> streamedDefaultTf_;  // the field's default-TF basis (out of core)
    void fromBricks() {
        FieldReadOptions ro;
        ro.var = f_.var;
        ro.raw = toRawLayout(f_.raw);
        ro.allowMissing = skipNan_;  // build's own scan reports them by policy
        SlabReader r = openBrickedField(f_.inputs, ro);
        checkDensityForInput(opt_.density, r.valueStep, r.valueType);
        const Grid3 reduced = downsampledGrid(r.grid, f_.downsample);
        const long long k = f_.downsample;
        fitOptionsToSamples(opt_, k * k * k, f_.gmmOpt->count() > 0, f_.quantilesOpt->count() > 0,
                            notes_);
        BuildMemory mem =
            buildMemory(r.grid, 1, f_.downsample, opt_, r.scratchPerPlane, r.scratchFixed);
        mem.fixed += residentBytes();
        const Grid3 inputGrid = r.grid;
        const std::string field =
            std::to_string(r.grid.dims[0]) + "x" + std::to_string(r.grid.dims[1]) + " field values";
        const int planes =
            planSlabs(mem, limit_, reduced.dims[2], f_.downsample, forcedSlab_, field);
        if (planes > 0) {
            // The field's default TF needs the whole field: read once more where it fits in
            // the memory limit (the file is then the in-memory build's, byte for byte).
            const double fieldBytes = static_cast<double>(inputGrid.pointCount()) * 8.0;
            if (fieldBytes < static_cast<double>(limit_.bytes)) {
                const ScalarField f = readField(f_.inputs[0], ro);
                if (std::all_of(f.values.begin(), f.values.end(),
                                [](float v) { return std::isfinite(v); }))
                    streamedDefaultTf_ = encodeDefaultTfBasis(defaultTfBasis(f.grid, f.values));
            } else {
                notes_ +=
                    "build: out of core, the model records no default TF of the whole field: "
                    "render without --tf spreads it over the brick means (--tf-range or a TF "
                    "file matches the field's rendering)\n";
            }
            streamTo(reduced, r, planes, [&](const SlabInput& in, const SlabSink& sink) {
                return buildModelDownsampledStreamed(in, f_.downsample, planes, opt_, sink,
                                                     progress(), &rep_);
            });
        } else {
            r = SlabReader{};  // what it read to open the field
            // The file opened as a field above (openBrickedField).
            const ScalarField f = readField(f_.inputs[0], ro);
            readSeconds_ = secondsSince(t0_);
            sayNotes();
            ProgressBar bar("build", reduced.pointCount());
            opt_.progress = &bar;
            model_ = buildModelDownsampled(f, f_.downsample, opt_, &rep_);
            bar.finish();
            // The full-resolution field's default TF, so that the model and the field rendered
            // without --tf get the same one (a field with NaN/Inf left out: the model's own).
            if (std::all_of(f.values.begin(), f.values.end(),
                            [](float v) { return std::isfinite(v); }))
                model_.defaultTf = encodeDefaultTfBasis(defaultTfBasis(f.grid, f.values));
        }
        if (rep_.droppedPlanes != std::array<int, 3>{0, 0, 0})
            std::fprintf(stderr,
                         "build: %dx%dx%d is not a multiple of %d; left out the trailing "
                         "%d,%d,%d planes in x,y,z\n",
                         inputGrid.dims[0], inputGrid.dims[1], inputGrid.dims[2], f_.downsample,
                         rep_.droppedPlanes[0], rep_.droppedPlanes[1], rep_.droppedPlanes[2]);
        what_ = std::to_string(inputGrid.dims[0]) + "x" + std::to_string(inputGrid.dims[1]) + "x" +
                std::to_string(inputGrid.dims[2]) + " field in " + std::to_string(f_.downsample) +
                "^3 bricks";
    }
    void fromEnsemble() {
        requireEnsembleInputs(f_.inputs);
        EnsembleReadOptions ro;
        ro.var = f_.var;
        ro.memberDim = f_.memberDim;
        ro.raw = toRawLayout(f_.raw);
        ro.allowMissing = skipNan_;
        SlabReader r = openEnsembleSlabs(f_.inputs, ro);
        checkDensityForInput(opt_.density, r.valueStep, r.valueType);
        // Checks the options before the bar is drawn.
        fitOptionsToSamples(opt_, r.members, f_.gmmOpt->count() > 0, f_.quantilesOpt->count() > 0,
                            notes_);
        BuildMemory mem =
            buildMemory(r.grid, r.members, 1, opt_, r.scratchPerPlane, r.scratchFixed);
        mem.fixed += residentBytes();
        const int planes =
            planSlabs(mem, limit_, r.grid.dims[2], 1, forcedSlab_,
                      std::to_string(r.members) + " members of " + std::to_string(r.grid.dims[0]) +
                          "x" + std::to_string(r.grid.dims[1]) + " values");
        if (planes > 0) {
            streamTo(r.grid, r, planes, [&](const SlabInput& in, const SlabSink& sink) {
                return buildModelStreamed(in, planes, opt_, sink, progress(), &rep_);
            });
        } else {
            r = SlabReader{};
            const Ensemble e = readEnsemble(f_.inputs, ro);
            readSeconds_ = secondsSince(t0_);
            sayNotes();
            ProgressBar bar("build", e.grid.pointCount());
            opt_.progress = &bar;
            model_ = buildModel(e, opt_, &rep_);
            bar.finish();
        }
        what_ = std::to_string(model_.samplesPerVoxel) + "-member ensemble";
    }
    void write() {
        std::string writtenText = f_.out;
        if (!written_) {
            std::fputs(modelSizeNote(model_.grid, model_.quantileCount, model_.gmmComponents,
                                     !f_.noCompress)
                           .c_str(),
                       stderr);
            auto t1 = std::chrono::steady_clock::now();
            if (partitioned_) {
                const int pieces = f_.pieces > 0 ? f_.pieces : threadCount();
                writeModelPvti(f_.out, model_, pieces);
                const int n =
                    static_cast<int>(pvtiPieceBoundaries(model_.grid.dims[2], pieces).size()) - 1;
                writtenText += " (" + std::to_string(n) + (n == 1 ? " piece)" : " pieces)");
            } else {
                writeModelVti(f_.out, model_, !f_.noCompress);
            }
            writeSeconds_ = secondsSince(t1);
        }

        writtenText_ =
            writtenText + diskSizeText(f_.out, modelArrayBytes(model_.grid, model_.quantileCount,
                                                               model_.gmmComponents));
    }
    void report() const {
        const std::string& writtenText = writtenText_;
        const auto& d = model_.grid.dims;
        std::fprintf(
            stderr,
            "build: %s -> %dx%dx%d voxels x %d samples; q=%d (%s%s%s), GMM K=%d; "
            "%d threads\n",
            what_.c_str(), d[0], d[1], d[2], rep_.samplesPerVoxel, opt_.quantiles,
            model_.quantileLevels.empty() ? "" : "uneven levels, ", model_.density.c_str(),
            opt_.density == DensityEstimate::Kde
                ? (", h " + model_.bandwidthRule + " median " + std::to_string(model_.bandwidth))
                      .c_str()
            : opt_.density == DensityEstimate::Dequantized
                ? (", step " + shortNumber(model_.bandwidth)).c_str()
                : "",
            opt_.gmmComponents, threadCount());
        if (opt_.gmmComponents > 0)
            std::fprintf(stderr,
                         "build: EM %.1f iterations per voxel on average, %zu voxels stopped at "
                         "100; %zu constant voxels, %zu with fewer distinct values than K\n",
                         rep_.meanGmmIterations, rep_.gmmNotConverged, rep_.constantVoxels,
                         rep_.gmmFewerDistinct);
        if (rep_.nonFiniteSamples > 0)
            std::fprintf(stderr,
                         "build: --nan skip: left out %zu NaN/Inf samples at %zu voxels (the "
                         "fewest finite samples at a voxel: %d of %d)\n",
                         rep_.nonFiniteSamples, rep_.voxelsWithNonFinite, rep_.fewestFiniteSamples,
                         rep_.samplesPerVoxel);
        // Wall times of the three phases; the statistics' stages as CPU time over all threads.
        std::fprintf(stderr,
                     "build: read %.2f s, statistics %.2f s (CPU: scan %.2f, gather %.2f, "
                     "sort+moments+quantiles %.2f, GMM %.2f s), write %.2f s -> %s\n",
                     readSeconds_, rep_.seconds, rep_.scanCpu, rep_.gatherCpu, rep_.estimateCpu,
                     rep_.gmmCpu, writeSeconds_, writtenText.c_str());
        if (written_) {
            const double total = secondsSince(t0_);
            const double samples = static_cast<double>(rep_.voxels) * rep_.samplesPerVoxel;
            std::fprintf(stderr,
                         "build: out of core: %d slab(s), the input read %s; %.3g samples/s "
                         "over %.1f s\n",
                         rep_.slabs,
                         rep_.inputPasses == 1   ? "once"
                         : rep_.inputPasses == 2 ? "twice (the range scan, then the statistics)"
                                                 : "three times (the range scan, finite counts, "
                                                   "the statistics)",
                         total > 0.0 ? samples / total : 0.0, total);
        }
    }

    const BuildFlags& f_;
    BuildOptions opt_;
    MemoryLimit limit_;
    int forcedSlab_;
    bool bricks_, partitioned_, skipNan_;
    std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
    ModelVolume model_;
    BuildReport rep_;
    std::string what_, notes_, writtenText_;
    double readSeconds_ = 0.0, writeSeconds_ = 0.0;
    bool written_ = false;  // by the out-of-core build, slab by slab
    SlabBars bars_;
};

}  // namespace

void runLocalBuild(const BuildFlags& f, BuildOptions opt, MemoryLimit limit) {
    LocalBuild(f, std::move(opt), std::move(limit)).run();
}

}  // namespace udvr::cmd
