// udvr probe model.vti --point i,j,k --model NAME --tf tf.json [--json] [--plot out.png]
#include <cstdio>
#include <iostream>
#include <string>

#include "udvr/classify/probe.h"
#include "udvr/cmd/commands.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/eval/probe_plot.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/util/check.h"

namespace udvr::cmd {

void addProbeCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "probe", "the distribution and expected TF (E[a*c], E[a]) at one index-space point");
    struct Opts {
        std::string model, point, kind, tf, plot, uniformWidth = "variance", second;
        Tf2Flags tf2;
        bool json = false;
    };
    auto o = std::make_shared<Opts>();
    sub->add_option("model", o->model, "model file (.vti from `udvr build`)")->required();
    sub->add_option("--point", o->point, "index coordinates i,j,k")->required();
    sub->add_option("--model", o->kind,
                    "noise model (mean, uniform, gaussian, gmm-ordered, "
                    "quantile-range, ...)")
        ->required();
    sub->add_option("--tf", o->tf, "transfer function (ParaView JSON)");
    sub->add_option("--tf2", o->tf2.file,
                    "2D transfer function over value x gradient magnitude (.vti, .npy, widget "
                    ".json; SPEC 9)");
    addTf2FormOptions(sub, o->tf2);
    sub->add_option("--second", o->second,
                    "bivariate fields: the model giving the TF2's y (same grid; SPEC 9)");
    sub->add_flag("--json", o->json, "print one JSON object");
    sub->add_option("--plot", o->plot, "write the PDF at the point over the TF as a PNG");
    sub->add_option("--uniform-width", o->uniformWidth,
                    "uniform model: variance (alias std; mu +- sqrt(3) sigma, default) or minmax");
    sub->callback([o] {
        const ModelKind kind = parseModelKind(o->kind);
        const auto p = parseVec3(o->point, "--point");
        ClassifyOptions options;
        options.uniformMinMax = parseUniformWidthMinMax(o->uniformWidth);
        if (!o->plot.empty()) {
            const std::string& plot = o->plot;
            const bool png = plot.size() > 4 && (plot.compare(plot.size() - 4, 4, ".png") == 0 ||
                                                 plot.compare(plot.size() - 4, 4, ".PNG") == 0);
            if (!png) UDVR_FAIL("--plot must name a .png file, got '" << plot << "'");
        }
        requireOneTf(o->tf, o->tf2);
        const bool twoD = !o->tf2.file.empty();
        if (twoD && !o->plot.empty())
            UDVR_FAIL("--plot draws the distribution over a 1D TF; with --tf2 use --json");
        if (!o->second.empty() && !twoD)
            UDVR_FAIL("--second gives the y of a 2D transfer function: it needs --tf2");
        const TransferFunction1D tf = twoD ? TransferFunction1D{} : readTransferFunction(o->tf);
        const ModelVolume model = readModelVti(o->model);
        const ProbeResult r =
            !o->second.empty()
                ? probeBivariate(model, readModelVti(o->second), kind,
                                 readTransferFunction2D(o->tf2.file, toTf2ReadOptions(o->tf2)), p,
                                 options)
            : twoD ? probeModel(model, kind,
                                readTransferFunction2D(o->tf2.file, toTf2ReadOptions(o->tf2)), p,
                                options)
                   : probeModel(model, kind, tf, p, options);
        if (!o->plot.empty()) writePng(o->plot, renderProbePlot(r, tf));
        if (o->json) {
            std::cout << r.json.dump(2) << "\n";
            return;
        }
        std::printf("model %s at (%g, %g, %g)\n", std::string(modelName(kind)).c_str(), p[0], p[1],
                    p[2]);
        for (const char* key : {"value", "mean", "stddev", "low", "high"})
            if (r.json.contains(key)) std::printf("  %-8s %.6g\n", key, r.json[key].get<double>());
        for (const char* key : {"boundaries", "weights", "means", "sigmas", "population"})
            if (r.json.contains(key)) std::printf("  %-8s %s\n", key, r.json[key].dump().c_str());
        std::printf("  E[a*r], E[a*g], E[a*b], E[a] = %.6f %.6f %.6f %.6f\n", r.expected.r,
                    r.expected.g, r.expected.b, r.expected.a);
        if (!o->plot.empty())
            std::printf("  plot %s: x from %.6g to %.6g\n", o->plot.c_str(), r.distribution.lo,
                        r.distribution.hi);
    });
}

}  // namespace udvr::cmd
