// fiber and fiber-isabel (Athawale et al. 2021, Fig. 11): fuzzy fiber surfaces of bivariate
// fields reduced by bricks (SPEC §9 `--second`). A 2D TF that is a band around a segment of the
// range space (field 1 × field 2) shows the fiber surface, the preimage of the segment; at full
// resolution it is the ground truth, and the reduced volume's mean field is compared with the
// statistical models of the same bricks: RMSE against the truth, and whether the surface stays
// in one piece (connected pieces of the rendered α > 0.1 mask).
#include <cmath>
#include <nlohmann/json.hpp>

#include "udvr/eval/experiment_run.h"
#include "udvr/eval/tf2_plot.h"
#include "udvr/io/field_io.h"
#include "udvr/io/transfer_function_2d_io.h"

namespace udvr::experiment_detail {
namespace {

/// Opacity threshold of the connectivity count.
constexpr float kMaskAlpha = 0.1f;

/// A band widget around the range-space polyline a → b (SPEC §9 widgets), its JSON text.
std::string bandTf2Json(const std::string& comment, const std::array<double, 4>& domain,
                        int resolution, std::array<double, 2> a, std::array<double, 2> b,
                        std::array<double, 2> halfWidth, const std::array<double, 4>& rgba) {
    nlohmann::json j;
    j["comment"] = comment;
    j["domain"] = domain;
    j["resolution"] = {resolution, resolution};
    j["widgets"] = {
        {{"type", "band"}, {"points", {a, b}}, {"half_width", halfWidth}, {"rgba", rgba}}};
    return j.dump(2);
}

/// The statistical models compared with the mean field (all of them have bivariate kernels).
constexpr ModelKind kFiberModels[] = {ModelKind::Mean, ModelKind::Uniform, ModelKind::Gaussian,
                                      ModelKind::QuantileRange, ModelKind::QuantileMean};

std::string componentsText(const MaskComponents& c) {
    if (c.pixels == 0) return "empty mask";
    return std::to_string(c.count) + (c.count == 1 ? " piece" : " pieces") + " (the largest " +
           fmt("%.1f", 100.0 * static_cast<double>(c.largest) / static_cast<double>(c.pixels)) +
           " % of " + std::to_string(c.pixels) + " px), " + std::to_string(c.holes) +
           (c.holes == 1 ? " hole" : " holes");
}

/// Everything both fiber experiments share once their fields and TF2 are made: render the truth
/// and each model of the reduced pair, count the mask's pieces, check the two claims.
ExperimentResult runFiberPair(Run& run, const ScalarField& first, const ScalarField& second,
                              int brick, double elevation, double zoom, double step,
                              const std::string& title, std::vector<std::string> setup) {
    const Sizes& s = run.sizes();
    ModelVolume reducedFirst = run.buildBricks(first, brick, 8, 0);
    ModelVolume reducedSecond = run.buildBricks(second, brick, 8, 0);
    run.pairSecond(reducedFirst, reducedSecond);
    const int samples = brick * brick * brick;
    std::vector<std::pair<std::string, MaskComponents>> pieces;
    {
        const ModelVolume truthFirst = modelFromField(first), truthSecond = modelFromField(second);
        run.pairSecond(truthFirst, truthSecond);
        run.setView(truthFirst.bounds, 30.0, elevation, zoom);
        run.setStep(step);
        run.renderTruth(truthFirst, 1, samples);
        pieces.emplace_back("ground truth", opaqueComponents(run.truth(), kMaskAlpha));
    }
    std::vector<ResultRow> rows;
    for (ModelKind k : kFiberModels) {
        rows.push_back(run.add(reducedFirst, k, samples));
        pieces.emplace_back(rows.back().label,
                            opaqueComponents(run.items().back().image, kMaskAlpha));
        run.log(rows.back().label + ": " + componentsText(pieces.back().second));
    }
    {
        // The band over the joint histogram of the full-resolution pairs (Fig. 11's range space).
        const TransferFunction2D& t = run.tf2();
        const JointHistogram hist =
            jointHistogram(first.values, second.values, 128, 128, {t.x0, t.x1, t.y0, t.y1});
        Tf2PlotOptions po;
        po.width = po.height = kThumbMax;
        po.logScale = true;
        po.xLabel = first.name.empty() ? "field 1" : first.name;
        po.yLabel = second.name.empty() ? "field 2" : second.name;
        ImageRgba plot = renderTf2Plot(t, &hist, po);
        run.writeImage("tf2.png", plot);
        run.addPanelItem({"2D TF", {"2D TF over the joint histogram"}, std::move(plot), {}, {}});
    }
    const double scale = run.writeDifferenceImages();
    run.writeFigure("figure.png", renderPanel(makePanel(title, run.items(), 4)));

    // Claim 1: the statistical models recover the full-resolution image better than the mean.
    const ResultRow& mean = rows.front();
    std::string detail = "RMSE: mean " + fmt("%.4f", mean.rmse);
    bool better = true;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        detail += ", " + rows[i].label + " " + fmt("%.4f", rows[i].rmse);
        better = better && rows[i].rmse < mean.rmse;
    }
    run.addClaim(
        {"The statistical models' fuzzy fiber surface is closer to the full-resolution "
         "one than the mean field's (lower RMSE; Fig. 11)",
         better ? "holds" : "does not hold", detail});
    // Claim 2: connectivity.
    const MaskComponents& truth = pieces.front().second;
    const MaskComponents& meanPieces = pieces[1].second;
    bool connected = true;
    std::string cdetail;
    for (const auto& [label, c] : pieces) {
        cdetail += (cdetail.empty() ? "" : "; ") + label + ": " + componentsText(c);
        if (label != "ground truth" && label != "mean")
            connected =
                connected && c.pixels > 0 && c.count <= truth.count && c.holes <= truth.holes;
    }
    const bool meanBreaks = meanPieces.count > truth.count || meanPieces.holes > truth.holes;
    run.addClaim(
        {"The mean field's fiber surface breaks up (more pieces or holes in the rendered "
         "α > 0.1 mask than the full resolution's) while every statistical model's keeps "
         "it whole (no more pieces or holes than the full resolution's; Fig. 11)",
         meanBreaks && connected ? "holds" : "does not hold", cdetail});
    setup.push_back("Connected pieces of the rendered α > 0.1 mask (8-neighbourhood): " + cdetail +
                    ".");
    setup.push_back(
        "Difference images: per-pixel |Δ mean RGB| against the ground truth, blue (0) "
        "to yellow (" +
        fmt("%.3f", scale) + ").");
    setup.push_back("Reduced by " + std::to_string(brick) + "³ bricks to " +
                    std::to_string(reducedFirst.grid.dims[0]) + "×" +
                    std::to_string(reducedFirst.grid.dims[1]) + "×" +
                    std::to_string(reducedFirst.grid.dims[2]) + " voxels of " +
                    std::to_string(samples) +
                    " samples per field (SPEC §2); quantiles q = 8; the two fields independent "
                    "(SPEC §9). Images " +
                    std::to_string(s.image) + "².");
    return run.finish(title, setup, {"figure.png"});
}

}  // namespace

ExperimentResult runFiber(const fs::path& dir, const ExperimentOptions& options) {
    Run run("fiber", dir, options, resolveSizes("fiber", options));
    const int n = run.sizes().dims;
    constexpr int kBrick = 4;
    // Field 1: the height z. Field 2: a thin spherical shell, exp(−(r − R)²/(2s²)) with s one
    // full-resolution spacing, thinner than a brick: the bricks' means flatten it unevenly.
    constexpr double kRadius = 0.6, kLevel = 0.5, kHeight = 0.35, kBandY = 0.1;
    ScalarField height, shell;
    height.grid.dims = shell.grid.dims = {n, n, n};
    const double h = 2.0 / (n - 1);
    for (int a = 0; a < 3; ++a) {
        height.grid.origin[a] = shell.grid.origin[a] = -1.0;
        height.grid.spacing[a] = shell.grid.spacing[a] = h;
    }
    height.name = "height";
    shell.name = "shell";
    height.values.resize(height.grid.pointCount());
    shell.values.resize(shell.grid.pointCount());
    const double s = h;
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const double x = -1 + i * h, y = -1 + j * h, z = -1 + k * h;
                const double r = std::sqrt(x * x + y * y + z * z);
                const std::size_t v = height.grid.index(i, j, k);
                height.values[v] = static_cast<float>(z);
                shell.values[v] =
                    static_cast<float>(std::exp(-0.5 * (r - kRadius) * (r - kRadius) / (s * s)));
            }
    const std::string json = bandTf2Json(
        "fiber of the range-space segment z in [-0.35, 0.35], shell = 0.5", {-1.0, 1.0, 0.0, 1.0},
        128, {-kHeight, kLevel}, {kHeight, kLevel}, {0.01, kBandY}, {0.95, 0.55, 0.15, 1.0});
    run.setTf2(transferFunction2DFromWidgets(json, "fiber TF2"),
               "a band around the segment "
               "(−0.35, 0.5) → (0.35, 0.5), half widths 0.01 × 0.1",
               json);
    const double off = s * std::sqrt(2.0 * std::log(1.0 / kLevel));
    const std::string title =
        "Fuzzy fiber surfaces of a thin shell reduced by 4³ bricks "
        "(Athawale et al. 2021, Fig. 11)";
    return runFiberPair(
        run, height, shell, kBrick, 35.0, 1.8, 0.1 * h, title,
        {"Analytic pair on " + std::to_string(n) +
             "³ points over [−1, 1]³: field 1 = z, field 2 "
             "= exp(−(r − 0.6)²/(2s²)) with s = one grid spacing (" +
             fmt("%.4f", s) + ").",
         "Ray step 0.1 grid spacings (the fiber's layers are a third of a spacing thick at full "
         "resolution).",
         "The fiber of the segment {z ∈ [−0.35, 0.35], field 2 = 0.5} is known: two spherical "
         "zones, r = 0.6 ± " +
             fmt("%.4f", off) +
             ", |z| ≤ 0.35, each one connected piece (the "
             "outer one hides the inner)."});
}

ExperimentResult runFiberIsabel(const fs::path& dir, const ExperimentOptions& options) {
    const fs::path p0 = isabelPath(options, 2), p1 = isabelPath(options, 3);
    if (p0.empty() || !fs::exists(p0) || !fs::exists(p1))
        UDVR_FAIL("experiment 'fiber-isabel' needs "
                  << (p0.empty() ? std::string("<shared data>/isabel-windspeed/windspeed_t02.vti")
                                 : p0.string())
                  << " and windspeed_t03.vti, which are absent; set UDVR_DATA_DIR");
    Run run("fiber-isabel", dir, options, resolveSizes("fiber-isabel", options));
    const ScalarField before = readField(p0), after = readField(p1);
    if (before.grid.dims != after.grid.dims)
        UDVR_FAIL("the two Isabel time steps have different grids");
    // The segment: wind speed that rose by Δ from a speed in [A, B] (A, B the 70th and 95th
    // percentiles of the first step, Δ the 90th percentile of those points' rises).
    std::vector<float> sorted(before.values);
    std::sort(sorted.begin(), sorted.end());
    const auto percentile = [](const std::vector<float>& v, double p) {
        return static_cast<double>(
            v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))]);
    };
    const double a = percentile(sorted, 0.7), b = percentile(sorted, 0.95);
    std::vector<float> rises;
    for (std::size_t v = 0; v < before.values.size(); ++v)
        if (before.values[v] >= a && before.values[v] <= b)
            rises.push_back(after.values[v] - before.values[v]);
    std::sort(rises.begin(), rises.end());
    const double delta = percentile(rises, 0.9);
    const double lo =
        std::min(sorted.front(), *std::min_element(after.values.begin(), after.values.end()));
    const double hi =
        std::max(sorted.back(), *std::max_element(after.values.begin(), after.values.end()));
    const double width = 0.01 * (hi - lo);
    const std::string json =
        bandTf2Json("wind speed rose by " + fmt("%.3g", delta) + " m/s from a speed between " +
                        fmt("%.3g", a) + " and " + fmt("%.3g", b) + " m/s",
                    {lo, hi, lo, hi}, 192, {a, a + delta}, {b, b + delta}, {width, width},
                    {0.15, 0.45, 0.95, 1.0});
    run.setTf2(transferFunction2DFromWidgets(json, "fiber-isabel TF2"),
               "a band around the segment (" + fmt("%.3g", a) + ", " + fmt("%.3g", a + delta) +
                   ") → (" + fmt("%.3g", b) + ", " + fmt("%.3g", b + delta) + ") m/s, half width " +
                   fmt("%.3g", width),
               json);
    const std::string title =
        "Fuzzy fiber surface of Isabel's wind speed at two time steps, reduced by 2³ bricks "
        "(Athawale et al. 2021, Fig. 11)";
    return runFiberPair(
        run, before, after, 2, 70.0, 1.3, 0.0, title,
        {"Hurricane Isabel wind speed, time steps 2 (field 1) and 3 (field 2), " +
             std::to_string(before.grid.dims[0]) + "×" + std::to_string(before.grid.dims[1]) + "×" +
             std::to_string(before.grid.dims[2]) + " from `" + p0.string() + "`.",
         "The fiber: points where the speed rose by " + fmt("%.3g", delta) +
             " m/s (the 90th percentile of the rises there) from a speed between " +
             fmt("%.3g", a) + " and " + fmt("%.3g", b) +
             " m/s (the 70th and 95th percentiles of step 2)."});
}

}  // namespace udvr::experiment_detail
