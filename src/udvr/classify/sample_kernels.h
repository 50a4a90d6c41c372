#pragma once
// Per-sample classification kernels: reconstruct (SPEC §3) and classify (SPEC §4) at an
// index-space point. The renderer is templated on the kernel type so the per-sample work inlines
// into the ray loop; withKernel() does the one switch per frame.
//
// Every kernel type K provides
//   UDVR_CPU_GPU Rgba classifyAt(float x, float y, float z) const;
//       index-space point (clamped into the grid); returns (E[α·r], E[α·g], E[α·b], E[α]),
//       before opacity correction.
//   UDVR_CPU_GPU void voxelSupport(std::size_t voxel, float& lo, float& hi) const;
//       a value interval outside which the voxel's distribution has no (or negligible) mass;
//       used to build empty-space-skipping tables.
// Kernels are plain structs of sizes and raw pointers into storage that outlives them (a
// ModelVolume and a KernelTables), so the same code can later be compiled for CUDA.
#include <memory>
#include <utility>

#include "udvr/classify/model_kind.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/reconstruct/trilinear.h"
#include "udvr/stats/model_volume.h"

namespace udvr {

/// Mean field: TF(Σ w_c μ_c).
struct MeanKernel {
    int dims[3];
    const float* mean;
    const TransferFunction1D* tf;  // host only for now; a table replaces it in the fast path

    Rgba classifyAt(float x, float y, float z) const {
        TrilinearCell cell = trilinearCell(dims, x, y, z);
        float v = 0.f;
        for (int c = 0; c < 8; ++c) v += cell.weight[c] * mean[cell.corner[c]];
        return tf->classify(v);
    }
    void voxelSupport(std::size_t voxel, float& lo, float& hi) const { lo = hi = mean[voxel]; }
};

/// Options that change classification but are not part of the model file.
struct ClassifyOptions {
    int quartileDivisor = 4;  // quartile views need q divisible by this
};

/// Call f(kernel) with the kernel for `kind` built over `model` and `tf`. Throws UdvrError when
/// the model file lacks an array the kind needs. gmm-mc has no per-sample kernel (render only).
template <class F>
void withKernel(const ModelVolume& model, ModelKind kind, const TransferFunction1D& tf, F&& f) {
    switch (kind) {
        case ModelKind::Mean: {
            if (model.mean.empty()) UDVR_FAIL("model has no 'mean' array, needed by model 'mean'");
            MeanKernel k{{model.grid.dims[0], model.grid.dims[1], model.grid.dims[2]},
                         model.mean.data(),
                         &tf};
            f(k);
            return;
        }
        default:
            UDVR_FAIL("model '" << modelName(kind) << "' is not implemented yet");
    }
}

}  // namespace udvr
