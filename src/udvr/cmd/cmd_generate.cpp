// udvr generate {tangle|teardrop|spheres|marschner-lobb} --dims N[,N,N] -o field.vti
#include <cstdio>
#include <string>
#include <vector>

#include "udvr/cmd/commands.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/data/synthetic.h"
#include "udvr/io/field_io.h"

namespace udvr::cmd {

void addGenerateCommand(CLI::App& app) {
    auto* sub = app.add_subcommand("generate",
                                   "write a synthetic field (tangle, teardrop, "
                                   "spheres, marschner-lobb) as .vti or .nc");
    struct Opts {
        std::string name, dims = "64", out;
    };
    auto o = std::make_shared<Opts>();
    sub->add_option("field", o->name, "tangle | teardrop | spheres | marschner-lobb")->required();
    sub->add_option("--dims", o->dims, "grid points: N or X,Y,Z (default 64)");
    sub->add_option("-o,--output", o->out, "output .vti or .nc")->required();
    sub->callback([o] {
        requireOutputExtension(o->out, "-o", {".vti", ".nc"}, "");
        requireOutputDirectory(o->out, "-o");
        const auto d = parseDims(o->dims, "--dims");
        ScalarField f = makeSyntheticField(o->name, d[0], d[1], d[2]);
        writeField(o->out, f);
        std::fprintf(stderr, "generate: %s %dx%dx%d -> %s\n", o->name.c_str(), d[0], d[1], d[2],
                     o->out.c_str());
    });
}

}  // namespace udvr::cmd
