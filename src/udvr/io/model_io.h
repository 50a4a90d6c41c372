#pragma once
// Model volumes as VTK XML ImageData (SPEC §7): point arrays mean, stddev, min, max,
// quantiles (q+1 comps), iqr (2), gmm (3K) and the field data listed in SPEC §7.
#include <filesystem>
#include <memory>
#include <vector>

#include "udvr/io/field_io.h"
#include "udvr/stats/model_volume.h"

namespace udvr {

/// Write atomically; only non-empty arrays are written, LZ4-compressed (ParaView reads it) or,
/// with compress = false, raw (`build --no-compress`).
void writeModelVti(const std::filesystem::path& path, const ModelVolume& model,
                   bool compress = true);
/// The bytes the model's arrays take uncompressed (what `build` announces before writing):
/// voxels × (4 + (q + 1) + 2 + 3K) floats for a built model, 4 bytes each.
std::size_t modelArrayBytes(const Grid3& grid, int quantileCount, int gmmComponents);
/// A model partitioned along z as VTK's parallel ImageData, which ParaView opens in parallel:
/// `path` (.pvti) names `pieces` piece files <stem>/<stem>_<i>.vti beside it; neighbouring
/// pieces share their boundary plane (every cell lies in one piece, so trilinear reconstruction
/// needs nothing from a neighbour). The old header is removed first, each piece and then the
/// header are written atomically, and pieces of an earlier write that the header no longer
/// names are removed. readModelVti and readModelOrField read it back as one model.
void writeModelPvti(const std::filesystem::path& path, const ModelVolume& model, int pieces);
/// The first plane of each of (at most) `pieces` z-pieces of a grid of `planes` planes, and the
/// last plane: piece i holds planes b[i] … b[i+1].
std::vector<int> pvtiPieceBoundaries(int planes, int pieces);
/// writeModelPvti in parts, for processes that each write their own piece (`mpirun … build`):
/// piece `piece` holds planes k0 … k1 of the whole grid; `model` holds the whole grid's planes
/// from modelFirstPlane on (its grid: those planes, origin at plane modelFirstPlane). The header,
/// written last, names the pieces of `boundaries`.
void writeModelPvtiPiece(const std::filesystem::path& path, const ModelVolume& model, int piece,
                         int k0, int k1, int modelFirstPlane = 0);
void writeModelPvtiHeader(const std::filesystem::path& path, const ModelVolume& model,
                          const std::vector<int>& boundaries);
/// Read a model written by writeModelVti or writeModelPvti (or any .vti/.pvti with those array
/// names).
ModelVolume readModelVti(const std::filesystem::path& path);
/// A model .vti (one with a `mean` array) or any scalar field, which becomes a mean-only model
/// (modelFromField); `options` name the field's array/variable and a headerless .raw's layout.
/// What `render` and `probe` read.
ModelVolume readModelOrField(const std::filesystem::path& path,
                             const FieldReadOptions& options = {});

/// writeModelVti a slab of voxels at a time (the out-of-core `build`): the same file, byte for
/// byte, holding one compression block per array in memory. Each array's compressed blocks wait
/// in an unnamed temporary file beside `path` (gone when closed, also after kill -9) until
/// finish() writes the file atomically, so the disk holds the compressed model twice for a
/// moment.
class ModelVtiStreamWriter {
  public:
    /// The arrays of a built model (mean, stddev, min, max, iqr; quantiles for q > 0, gmm for
    /// K > 0) over `grid`'s voxels. Throws FileError where the directory is not writable.
    ModelVtiStreamWriter(const std::filesystem::path& path, const Grid3& grid, int quantileCount,
                         int gmmComponents);
    ~ModelVtiStreamWriter();
    ModelVtiStreamWriter(const ModelVtiStreamWriter&) = delete;
    ModelVtiStreamWriter& operator=(const ModelVtiStreamWriter&) = delete;
    /// The next voxels, in order: the slab's arrays, all for the same count of voxels.
    void append(const ModelVolume& slab);
    /// The field data from `model` (its arrays are not used); writes the file. Every voxel of
    /// the grid must have been appended.
    void finish(const ModelVolume& model);

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace udvr
