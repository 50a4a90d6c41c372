// `mpirun -np N udvr build … -o m.pvti`: one MPI rank's share of a partitioned build
// (build_steps.h, mpi_job.h).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "udvr/cmd/build_steps.h"
#include "udvr/cmd/mpi_job.h"
#include "udvr/io/model_io.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/check.h"
#include "udvr/util/memory.h"
#include "udvr/util/parallel.h"

namespace udvr::cmd {

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

}  // namespace udvr::cmd
