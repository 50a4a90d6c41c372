// Renders an in-memory model with every model family, linking only udvr_core (no VTK, NetCDF,
// HDF5, PNG or Cairo): the library a host with its own VTK (a ParaView plugin) links.
// Closed form (Beer–Lambert, SPEC §5): a TF of constant colour c and opacity a per unit
// distance makes E[α] = a and E[α·c] = a·c under every distribution, so an orthographic ray
// through L world units of volume at step Δ (N = L/Δ samples) accumulates
// α = 1 − (1 − a)^(N·Δ/u), and the pixel is α·c + (1 − α)·background.
#include <cmath>
#include <cstdio>
#include <exception>

#include "udvr/classify/model_families.h"
#include "udvr/render/render.h"

namespace {

udvr::ModelVolume constantModel() {
    udvr::ModelVolume m;
    m.grid.dims = {11, 11, 11};  // world box [0, 10]³, spacing 1
    const std::size_t n = m.voxelCount();
    m.mean.assign(n, 1.0f);
    m.stddev.assign(n, 0.3f);
    m.min.assign(n, 0.5f);
    m.max.assign(n, 1.5f);
    m.quantileCount = 4;
    m.gmmComponents = 2;
    m.memberCount = 3;
    for (std::size_t v = 0; v < n; ++v) {
        m.quantiles.insert(m.quantiles.end(), {0.4f, 0.8f, 1.0f, 1.3f, 1.9f});
        m.iqr.insert(m.iqr.end(), {0.8f, 1.3f});
        m.gmm.insert(m.gmm.end(), {0.5f, 0.5f, 0.8f, 1.2f, 0.1f, 0.2f});
        m.members.insert(m.members.end(), {0.9f, 1.0f, 1.1f});
    }
    m.samplesPerVoxel = 3;
    m.bounds = {0, 10, 0, 10, 0, 10};
    m.fullResMinSpacing = 1.0;
    m.source = "core_only_render";
    return m;
}

}  // namespace

int main() try {
    const double a = 0.05, c[3] = {0.2, 0.6, 0.9};
    udvr::TransferFunction1D tf;
    tf.colorX = {-100.0, 100.0};
    tf.color = {{c[0], c[1], c[2]}, {c[0], c[1], c[2]}};
    tf.opacityX = {-100.0, 100.0};
    tf.opacity = {a, a};

    udvr::RenderSettings s;
    s.width = 8;
    s.height = 6;
    s.camera.position = {5, 5, 40};
    s.camera.focalPoint = {5, 5, 5};
    s.camera.viewUp = {0, 1, 0};
    s.camera.parallel = true;
    s.camera.parallelScale = 2.0;  // every ray crosses the whole box along z
    s.realizations = 4;
    // Δ = 0.5 (half the spacing), u = 1: samples at (k + ½)Δ ≤ 10, N = 20, N·Δ/u = 10.
    const double alpha = 1.0 - std::pow(1.0 - a, 10.0);

    const udvr::ModelVolume model = constantModel();
    int failures = 0, rendered = 0;
    for (const udvr::ModelFamily& family : udvr::modelFamilies()) {
        const udvr::ImageRgba image = udvr::renderVolume(model, family.kind, tf, s);
        double worst = 0.0;
        for (int y = 0; y < image.height; ++y)
            for (int x = 0; x < image.width; ++x) {
                const float* p = image.pixel(x, y);
                for (int k = 0; k < 3; ++k)
                    worst = std::fmax(worst, std::fabs(p[k] - (alpha * c[k] + 1.0 - alpha)));
                worst = std::fmax(worst, std::fabs(p[3] - alpha));
            }
        // float lanes and the opacity correction's 1e−6 relative error
        const bool ok = worst <= 5e-6;
        std::printf("%-20.*s max |pixel - closed form| %.2e %s\n",
                    static_cast<int>(family.name.size()), family.name.data(), worst,
                    ok ? "ok" : "FAILED");
        failures += !ok;
        ++rendered;
    }
    std::printf("%d passed, %d failed\n", rendered - failures, failures);
    return failures == 0 && rendered >= 14 ? 0 : 1;
} catch (const std::exception& e) {
    std::fprintf(stderr, "core_only_render: %s\n", e.what());
    return 1;
}
