// udvr build {ensemble.nc | member files… | 'glob*' | field --downsample K} [--quantiles 8]
//   [--gmm 4] [--density empirical|kde|dequantized] [--bandwidth silverman|scott|H]
//   [--tail-eps E] [--var NAME] [--member-dim NAME] [--nan error|skip]
//   [--memory-limit BYTES|auto] [--slab-height N] -o model.vti          (SPEC §2, §7, §8; issue 15)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "udvr/classify/tf_presets.h"
#include "udvr/cmd/commands.h"
#include "udvr/cmd/mpi_job.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"
#include "udvr/io/model_io.h"
#include "udvr/stats/build_model.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/check.h"
#include "udvr/util/memory.h"
#include "udvr/util/parallel.h"
#include "udvr/util/progress.h"

namespace udvr::cmd {
namespace {

double secondsSince(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

std::string shortNumber(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

/// Fit the options to n samples per voxel (the library's rule); what was fitted is added to
/// `notes` for stderr (said once the input has been checked, so that an error stays the one line).
void fitOptionsToSamples(BuildOptions& opt, long long samples, bool gmmGiven, bool quantilesGiven,
                         std::string& notes) {
    const BuildFitNotes fit = fitBuildOptionsToSamples(opt, samples, gmmGiven, quantilesGiven);
    for (const std::string& w : fit.warnings) notes += "udvr: warning: " + w + "\n";
    if (!fit.info.empty())
        notes += "build: " + std::to_string(std::min<long long>(samples, 1 << 30)) +
                 " samples per voxel: " + fit.info + "\n";
}

/// How much an out-of-core build may hold (--memory-limit), and why, for the plan's line.
struct MemoryLimit {
    std::size_t bytes = 0;
    std::string text;
};

MemoryLimit parseMemoryLimit(const std::string& value) {
    MemoryLimit m;
    if (value == "auto") {
        const MemoryHeadroom h = memoryHeadroom();
        // Half: room for the page cache the reads go through, and for other processes.
        m.bytes = h.bytes > 0 ? h.bytes / 2 : std::numeric_limits<std::size_t>::max() / 4;
        m.text = byteSizeText(m.bytes) + " (auto: half of " +
                 (h.bytes > 0 ? byteSizeText(h.bytes) + " of " + h.source : "unknown memory") + ")";
    } else {
        m.bytes = parseByteSize(value, "--memory-limit");
        m.text = value;
    }
    return m;
}

/// The slab height in model z-planes: --slab-height (input planes, a multiple of K), or the
/// most that fit the limit; 0 where the whole volume fits (the in-memory build).
int planSlabs(const BuildMemory& mem, const MemoryLimit& limit, int modelZ, int k, int forced,
              const std::string& what) {
    if (forced > 0) return std::max(forced / std::max(k, 1), 1);
    const int planes = mem.planesWithin(limit.bytes);
    if (planes >= modelZ) return 0;
    if (planes == 0)
        UDVR_FAIL("--memory-limit " << limit.text << " is too small for this build: a slab of "
                                    << (k > 1 ? std::to_string(k) + " z-planes (one brick)"
                                              : std::string("one z-plane"))
                                    << " of " << what << " needs about "
                                    << byteSizeText(mem.fixed + mem.perPlane)
                                    << "; give at least that (more for fewer, thicker slabs)");
    return planes;
}

/// One progress bar per slab and pass.
struct SlabBars {
    std::unique_ptr<ProgressBar> bar;
    ProgressBar* next(const char* pass, int slab, int slabs, std::size_t voxels) {
        bar.reset();
        bar = std::make_unique<ProgressBar>(std::string("build ") + pass + " slab " +
                                                std::to_string(slab + 1) + "/" +
                                                std::to_string(slabs),
                                            voxels);
        return bar.get();
    }
};

/// What the streamed builds read from an opened input.
SlabInput slabInputOf(const SlabReader& r) {
    return SlabInput{r.grid, r.members, r.valueStep, r.valueType, r.read};
}

/// The one field that --downsample K reduces, as slabs; an ensemble file is a one-line error.
SlabReader openBrickedField(const std::vector<std::string>& inputs, const FieldReadOptions& ro) {
    if (inputs.size() != 1)
        UDVR_FAIL("--downsample takes one field, got " << inputs.size() << " inputs");
    try {
        return openFieldSlabs(inputs[0], ro);
    } catch (const EnsembleNotFieldError& e) {
        UDVR_FAIL(e.file << " holds a " << e.members << "-member ensemble (variable '" << e.var
                         << "', dims " << e.dims
                         << "): --downsample reduces one field; drop --downsample to build the "
                            "model from the "
                         << e.members << " members");
    }
}

/// Ensemble inputs: one field without --downsample is a one-line error.
void requireEnsembleInputs(const std::vector<std::string>& inputs) {
    const std::string& first = inputs[0];
    if (inputs.size() == 1 && first.find_first_of("*?[") == std::string::npos &&
        lowerExtension(first) != ".nc")
        UDVR_FAIL(first << " is one field: --downsample K models its K^3 bricks; an ensemble is "
                           "a NetCDF variable with a member dimension or 2+ member files");
}

/// `mpirun -np N udvr build … -o m.pvti` (mpi_job.h; docs/formats.md, "Partitioned models"):
/// the model's z-planes split into N pieces (pvtiPieceBoundaries: neighbours share a plane).
/// Rank r streams piece r's planes (BuildOptions::modelPlanes: every rank scans the whole input,
/// so the range, the NaN/Inf checks and every voxel are the single build's, bit for bit) and
/// writes its piece; rank 0 writes the header once every piece is written. k: --downsample K, or
/// 0 for an ensemble. An error of any rank is said once, by rank 0 (agreeOrThrow).
void buildOnRanks(const std::vector<std::string>& inputs, const std::string& out, int k,
                  const EnsembleReadOptions& ro, BuildOptions opt, const MemoryLimit& limit,
                  int forcedSlab, bool gmmGiven, bool quantilesGiven) {
    const MpiJob& job = mpiJob();
    const auto t0 = std::chrono::steady_clock::now();
    std::string error, notes, what;
    Grid3 modelGrid;
    std::vector<int> bounds;
    ModelVolume piece;  // this rank's planes, its grid the whole grid's
    BuildReport rep;
    try {
        if (job.rank == 0) {  // a stopped write leaves no header naming old pieces
            std::error_code ec;
            std::filesystem::remove(out, ec);
        }
        SlabReader r;
        if (k > 0) {
            FieldReadOptions fo;
            fo.var = ro.var;
            fo.raw = ro.raw;
            fo.allowMissing = ro.allowMissing;
            r = openBrickedField(inputs, fo);
            checkDensityForInput(opt.density, r.valueStep, r.valueType);
            modelGrid = downsampledGrid(r.grid, k);
            fitOptionsToSamples(opt, static_cast<long long>(k) * k * k, gmmGiven, quantilesGiven,
                                notes);
            what = std::to_string(r.grid.dims[0]) + "x" + std::to_string(r.grid.dims[1]) + "x" +
                   std::to_string(r.grid.dims[2]) + " field in " + std::to_string(k) + "^3 bricks";
        } else {
            requireEnsembleInputs(inputs);
            r = openEnsembleSlabs(inputs, ro);
            checkDensityForInput(opt.density, r.valueStep, r.valueType);
            fitOptionsToSamples(opt, r.members, gmmGiven, quantilesGiven, notes);
            modelGrid = r.grid;
            what = std::to_string(r.members) + "-member ensemble";
        }
        if (!r.note.empty()) notes = r.note + "\n" + notes;
        bounds = pvtiPieceBoundaries(modelGrid.dims[2], job.size);
        if (job.rank + 1 < static_cast<int>(bounds.size())) {  // else more ranks than pieces
            const int k0 = bounds[static_cast<std::size_t>(job.rank)];
            const int k1 = bounds[static_cast<std::size_t>(job.rank) + 1];
            const int kk = std::max(k, 1);
            opt.modelPlanes = {k0, k1 + 1};
            BuildMemory mem =
                buildMemory(r.grid, r.members, kk, opt, r.scratchPerPlane, r.scratchFixed);
            mem.fixed += residentBytes();
            int planes = planSlabs(mem, limit, k1 - k0 + 1, kk, forcedSlab, "the input");
            if (planes == 0) planes = k1 - k0 + 1;  // the piece fits: one slab
            const SlabInput in = slabInputOf(r);
            auto sink = [&](const ModelVolume& slab, std::size_t) {
                for (const ModelFileArray& a : kModelFileArrays)
                    (piece.*a.values)
                        .insert((piece.*a.values).end(), (slab.*a.values).begin(),
                                (slab.*a.values).end());
            };
            SlabBars bars;  // rank 0's only
            SlabProgress progress;
            if (job.rank == 0)
                progress = [&](const char* pass, int slab, int slabs, std::size_t voxels) {
                    return bars.next(pass, slab, slabs, voxels);
                };
            ModelVolume m =
                k > 0 ? buildModelDownsampledStreamed(in, k, planes, opt, sink, progress, &rep)
                      : buildModelStreamed(in, planes, opt, sink, progress, &rep);
            bars.bar.reset();
            for (const ModelFileArray& a : kModelFileArrays)
                m.*a.values = std::move(piece.*a.values);
            m.grid = modelGrid;
            m.grid.dims[2] = k1 - k0 + 1;
            m.grid.origin[2] = modelGrid.origin[2] + k0 * modelGrid.spacing[2];
            writeModelPvtiPiece(out, m, job.rank, k0, k1, k0);
            piece = std::move(m);
        }
    } catch (const UdvrError& e) {
        error = e.what();
    } catch (const std::bad_alloc&) {
        error = "out of memory";
    } catch (const std::exception& e) {
        error = std::string("internal error: ") + e.what();
    }
    agreeOrThrow(error);
    if (job.rank != 0) return;
    std::fputs(notes.c_str(), stderr);
    piece.grid = modelGrid;  // the header: the whole grid, and the arrays every piece has
    writeModelPvtiHeader(out, piece, bounds);
    const int pieces = static_cast<int>(bounds.size()) - 1;
    std::fprintf(stderr,
                 "build: %d ranks, one z-piece each: %s -> %dx%dx%d voxels x %d samples; q=%d, "
                 "GMM K=%d; rank 0: statistics %.2f s (read %.2f s), %d threads; %.2f s in all "
                 "-> %s (%d piece%s)\n",
                 job.size, what.c_str(), modelGrid.dims[0], modelGrid.dims[1], modelGrid.dims[2],
                 rep.samplesPerVoxel, opt.quantiles, opt.gmmComponents, rep.seconds,
                 rep.readSeconds, threadCount(), secondsSince(t0), out.c_str(), pieces,
                 pieces == 1 ? "" : "s");
}

/// The flags of `udvr build`.
struct BuildFlags {
    std::vector<std::string> inputs;
    std::string out, density, bandwidth = "silverman", var, memberDim, levels, nan = "error";
    int quantiles = 8, gmm = 4, downsample = 0, pieces = 0;
    double tailEps = 0.0;
    CLI::Option* downsampleOpt = nullptr;
    CLI::Option* tailEpsOpt = nullptr;
    CLI::Option* gmmOpt = nullptr;
    CLI::Option* quantilesOpt = nullptr;
    std::string memoryLimit = "auto";
    int slabHeight = 0;
    CLI::Option* slabHeightOpt = nullptr;
    RawLayoutFlags raw;  // headerless .raw inputs
    bool noCompress = false;
};

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

/// BuildOptions from the flags, with every check that needs no input.
BuildOptions buildOptionsOf(const BuildFlags& f) {
    BuildOptions opt;
    opt.quantiles = f.quantiles;
    if (!f.levels.empty()) {
        opt.quantileLevels = parseDoubleList(f.levels, "--quantile-levels");
        const int q = static_cast<int>(opt.quantileLevels.size()) - 1;
        if (f.quantilesOpt->count() > 0 && f.quantiles != q)
            UDVR_FAIL("--quantiles " << f.quantiles << " disagrees with the " << q + 1
                                     << " values of --quantile-levels (q + 1 boundaries)");
        opt.quantiles = q;
    }
    opt.gmmComponents = f.gmm;
    opt.nan = parseNanPolicy(f.nan);
    const bool bricks = f.downsampleOpt->count() > 0;
    opt.density = f.density.empty() ? defaultDensity(bricks) : parseDensityEstimate(f.density);
    opt.bandwidthText = f.bandwidth;
    if (opt.density == DensityEstimate::Kde) opt.bandwidth = parseBandwidth(f.bandwidth);
    if (f.tailEpsOpt->count() > 0) {
        if (!(f.tailEps > 0.0))
            UDVR_FAIL("--tail-eps " << f.tailEps << " is out of range; expected 0 < E < 0.5");
        opt.tailEps = f.tailEps;
    }
    // What does not depend on the input is checked before it is read (the sample count
    // is then assumed large enough; fitOptionsToSamples checks against the real one).
    validateBuildOptions(opt, std::numeric_limits<int>::max());
    if (f.slabHeightOpt->count() > 0 && f.slabHeight < 1)
        UDVR_FAIL("--slab-height " << f.slabHeight
                                   << " is out of range; expected a number of z-planes >= 1");
    if (f.slabHeightOpt->count() > 0 && bricks && f.downsample >= 2 &&
        f.slabHeight % f.downsample != 0)
        UDVR_FAIL("--slab-height " << f.slabHeight << " is not a multiple of --downsample "
                                   << f.downsample
                                   << "; bricks need whole K-plane slabs, e.g. --slab-height "
                                   << std::max(f.slabHeight / f.downsample, 1) * f.downsample);
    for (const std::string& in : f.inputs) opt.source += (opt.source.empty() ? "" : " ") + in;
    if (bricks) opt.source += " --downsample " + std::to_string(f.downsample);
    return opt;
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

void addBuildCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "build",
        "per-voxel distribution models (moments, quantiles, IQR, GMM) from an ensemble "
        "or from K^3 bricks of one field, written as a .vti model");
    auto o = std::make_shared<BuildFlags>();
    sub->add_option("inputs", o->inputs,
                    "ensemble .nc, member files or quoted globs ('m_*.vti'), or one field with "
                    "--downsample")
        ->required();
    o->downsampleOpt = sub->add_option(
        "--downsample", o->downsample,
        "K: model one field's K^3 bricks (reduced grid floor(N/K) per axis, at brick centres)");
    o->quantilesOpt = sub->add_option("--quantiles", o->quantiles,
                                      "q quantiles, q+1 boundaries (default 8; 0 skips)");
    sub->add_option("--quantile-levels", o->levels,
                    "t_0,t_1,...,t_q: uneven quantile levels, increasing from 0 to 1 (q from "
                    "their count; default j/q)");
    o->gmmOpt = sub->add_option("--gmm", o->gmm,
                                "GMM components K (default 4, lowered to the samples per voxel "
                                "when there are fewer; 0 skips)");
    sub->add_option("--density", o->density,
                    "empirical | kde | dequantized (integer-typed input: each value spread over "
                    "its quantisation step) (default: kde with --downsample, else empirical)");
    sub->add_option("--bandwidth", o->bandwidth,
                    "kde bandwidth: silverman | scott | H in data units (default silverman)");
    o->tailEpsOpt = sub->add_option("--tail-eps", o->tailEps,
                                    "kde tail probability of b_0 and b_q (default 1/(2n))");
    sub->add_option("--var", o->var, "variable/array to read");
    sub->add_option("--member-dim", o->memberDim, "NetCDF member dimension name");
    sub->add_option("--nan", o->nan,
                    "NaN/Inf samples (and NetCDF fill values): error (default; names the first "
                    "voxel and member) | skip (each voxel from its finite samples, at least 2)");
    sub->add_option("--memory-limit", o->memoryLimit,
                    "BYTES (512M, 4G, ...) or auto (default: half of the available memory): "
                    "an input and model larger than this are built out of core, a slab of "
                    "z-planes at a time (the same model, bit for bit)");
    o->slabHeightOpt = sub->add_option(
        "--slab-height", o->slabHeight,
        "N: build out of core in slabs of N input z-planes (a multiple of K with --downsample) "
        "whatever the memory (for tests)");
    sub->add_flag("--no-compress", o->noCompress,
                  "write the model's arrays raw (.vti, built in memory); default: LZ4-compressed, "
                  "as ParaView writes and reads");
    sub->add_option("-o,--output", o->out,
                    "output model: .vti, or .pvti (VTK's parallel ImageData: the model in "
                    "z-pieces <stem>/<stem>_<i>.vti, which ParaView opens in parallel)")
        ->required();
    sub->add_option("--pieces", o->pieces,
                    "with -o .pvti: how many z-pieces (default: one per thread; at most one per "
                    "cell layer)");
    addRawLayoutOptions(sub, o->raw);

    sub->callback([o] {
        o->inputs = withOneMatchResolved(o->inputs);  // a quoted glob of one file is that file
        requireOutputExtension(o->out, "-o", {".vti", ".pvti"},
                               "build writes a model as VTK ImageData");
        const bool partitioned = lowerExtension(o->out) == ".pvti";
        if (o->pieces != 0 && !partitioned)
            UDVR_FAIL("--pieces " << o->pieces << " needs -o with a .pvti (partitioned) model");
        if (o->pieces < 0 || o->pieces > 65536)
            UDVR_FAIL("--pieces " << o->pieces << " is out of range; expected 1 to 65536");
        const BuildOptions opt = buildOptionsOf(*o);
        const MemoryLimit limit = parseMemoryLimit(o->memoryLimit);
        const int forcedSlab = o->slabHeightOpt->count() > 0 ? o->slabHeight : 0;
        const bool bricks = o->downsampleOpt->count() > 0;
        const bool skipNan = opt.nan == NanPolicy::Skip;
        requireOutputsNotInputs({{"-o", o->out}}, o->inputs);
        if (o->noCompress && partitioned)
            UDVR_FAIL("--no-compress writes a .vti; a .pvti's pieces are LZ4-compressed");
        requireOutputDirectory(o->out, "-o");
        const MpiJob& job = mpiJob();
        if (job.launchedWithoutMpi)
            UDVR_FAIL(
                "started by an MPI launcher, but this udvr was built without MPI "
                "(-DUDVR_MPI=ON): every copy would build the whole model into the same file");
        if (job.active) {
            if (!partitioned)
                UDVR_FAIL(
                    "under mpirun, build writes one z-piece per rank: -o needs a .pvti "
                    "(partitioned) model, got "
                    << o->out);
            if (o->pieces != 0 && o->pieces != job.size)
                UDVR_FAIL("--pieces " << o->pieces << " under mpirun: the pieces are the "
                                      << job.size << " ranks");
            EnsembleReadOptions ro;
            ro.var = o->var;
            ro.memberDim = o->memberDim;
            ro.raw = toRawLayout(o->raw);
            ro.allowMissing = skipNan;
            buildOnRanks(o->inputs, o->out, bricks ? o->downsample : 0, ro, opt, limit, forcedSlab,
                         o->gmmOpt->count() > 0, o->quantilesOpt->count() > 0);
            return;
        }
        LocalBuild(*o, opt, limit).run();
    });
}

}  // namespace udvr::cmd
