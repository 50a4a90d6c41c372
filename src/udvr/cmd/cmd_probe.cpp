// udvr probe {model.vti | field | ensemble --model members} {--point i,j,k | --world x,y,z}
//   --model NAME [--tf tf.json|PRESET] [--json] [--plot out.png]
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "udvr/classify/probe.h"
#include "udvr/cmd/commands.h"
#include "udvr/cmd/option_flags.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/eval/probe_plot.h"
#include "udvr/io/field_io.h"
#include "udvr/io/image.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/util/check.h"

namespace udvr::cmd {

void addProbeCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "probe", "the distribution and expected TF (E[a*c], E[a]) at one index-space point");
    struct Opts {
        std::vector<std::string> inputs;  // one model or field; an ensemble for --model members
        std::string point, world, kind = "mean", plot, var;
        RenderOptions options;  // --uniform-width, --second, --force (render/render_options.h)
        EnsembleFlags ensemble;
        TfFlags tf;
        Tf2Flags tf2;
        RawLayoutFlags raw;
        bool json = false;
    };
    auto o = std::make_shared<Opts>();
    sub->add_option(
           "model", o->inputs,
           "model (.vti or .pvti from `udvr build`) or a plain field (.vti .nc .nrrd .nhdr .raw); "
           "with --model members an ensemble (.nc, member files or a quoted glob)")
        ->required();
    sub->add_option("--point", o->point,
                    "index coordinates i,j,k on the input's own grid (a downsampled model's "
                    "reduced grid)");
    sub->add_option("--world", o->world, "world coordinates x,y,z instead of --point");
    sub->add_option("--model", o->kind, "noise model (default mean): " + modelHelp());
    addTfOptions(sub, o->tf);
    addTf2Options(sub, o->tf2);
    addOptionFlags(sub, bivariateOptionSpecs(), o->options);
    sub->add_flag("--json", o->json, "print one JSON object");
    addOptionFlags(sub, forceOptionSpecs(), o->options);
    sub->add_option("--plot", o->plot, "write the PDF at the point over the TF as a PNG");
    addOptionFlags(sub, classificationOptionSpecs(), o->options);
    sub->add_option("--var", o->var, "array/variable name in the input");
    addRawLayoutOptions(sub, o->raw);
    addEnsembleOptions(sub, o->ensemble);
    sub->callback([o] {
        o->inputs = withOneMatchResolved(o->inputs);  // a quoted glob of one file is that file
        const ModelKind kind = parseModelKind(o->kind);
        const bool members = readsMembers(kind);
        if (!members && o->inputs.size() != 1)
            UDVR_FAIL("probe takes one model or field, got "
                      << o->inputs.size()
                      << " inputs (member files are an ensemble: --model members probes them)");
        if (o->point.empty() == o->world.empty())
            UDVR_FAIL("give the point as --point i,j,k (index) or --world x,y,z, one of them");
        const ClassifyOptions options = classifyOptionsFrom(o->options);
        if (!o->plot.empty()) {
            const std::string& plot = o->plot;
            const bool png = plot.size() > 4 && (plot.compare(plot.size() - 4, 4, ".png") == 0 ||
                                                 plot.compare(plot.size() - 4, 4, ".PNG") == 0);
            if (!png) UDVR_FAIL("--plot must name a .png file, got '" << plot << "'");
        }
        {
            std::vector<std::string> inputs = o->inputs;
            inputs.insert(inputs.end(), {o->options.second, o->tf.tf, o->tf2.file});
            requireOutputsNotInputs({{"--plot", o->plot}}, inputs);
        }
        requireOneTf(o->tf.tf, o->tf2);
        const bool twoD = !o->tf2.file.empty();
        requireSecondForMembersTf2(o->options, members, twoD);
        if (twoD && !o->plot.empty())
            UDVR_FAIL("--plot draws the distribution over a 1D TF; with --tf2 use --json");
        checkBivariateOptions(o->options, twoD);
        checkTfFlags(o->tf, twoD);
        const bool tfFile = !twoD && !tfIsPreset(o->tf);
        const Tf2ReadOptions tf2Options = toTf2ReadOptions(o->tf2, o->options.force);
        TfChoice tfChoice;
        if (tfFile) tfChoice.tf = readTransferFunctionFile(o->tf);  // before the volume: cheap
        const ModelVolume model = members ? readMembersModel(o->inputs, o->var, o->raw, o->ensemble)
                                          : readModelOrField(o->inputs.front(), o->var, o->raw);
        if (!twoD && !tfFile) tfChoice = chooseTransferFunction(o->tf, model, "probe");
        const TransferFunction1D& tf = tfChoice.tf;
        const Grid3& g = model.grid;
        const std::array<double, 3> p =
            o->world.empty()
                ? parseVec3(o->point, "--point")
                : indexFromWorld(g, parseVec3(o->world, "--world"), "--world " + o->world);
        const std::array<double, 3> world = worldFromIndex(g, p);
        const ProbeResult r =
            !o->options.second.empty()
                ? probeBivariate(model,
                                 readSecondInput(o->options, o->var, o->raw, o->ensemble, members),
                                 kind, readTransferFunction2D(o->tf2.file, tf2Options), p, options)
            : twoD ? probeModel(model, kind, readTransferFunction2D(o->tf2.file, tf2Options), p,
                                options)
                   : probeModel(model, kind, tf, p, options);
        finishTransferFunction(o->tf, tfChoice);  // --save-tf first: a bad one leaves no plot
        if (!o->plot.empty()) writePng(o->plot, renderProbePlot(r, tf));
        if (o->json) {
            std::cout << r.json.dump(2) << "\n";
            return;
        }
        const std::string reduced =
            model.downsample > 0 ? " (reduced by " + std::to_string(model.downsample) + "^3 bricks)"
                                 : std::string();
        std::printf(
            "model %s at index (%g, %g, %g) of the input's %dx%dx%d grid%s = world (%g, "
            "%g, %g)\n",
            std::string(modelName(kind)).c_str(), p[0], p[1], p[2], g.dims[0], g.dims[1], g.dims[2],
            reduced.c_str(), world[0], world[1], world[2]);
        for (const char* key : {"members", "value", "mean", "stddev", "low", "high", "min", "max"})
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
