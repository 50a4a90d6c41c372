// udvr perturb field --members 50 --noise bimodal [--seed S] -o ensemble.nc
#include <cstdio>
#include <limits>
#include <string>

#include "udvr/cmd/commands.h"
#include "udvr/cmd/parse_util.h"
#include "udvr/data/noise.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/field_io.h"

namespace udvr::cmd {

void addPerturbCommand(CLI::App& app) {
    auto* sub = app.add_subcommand(
        "perturb", "make an ensemble from a field: truth + i.i.d. noise per voxel (NetCDF out)");
    struct Opts {
        std::string input, out, noise = "bimodal", var;
        int members = 50;
        NoiseParams p;
        RawLayoutFlags raw;  // headerless .raw input
    };
    auto o = std::make_shared<Opts>();
    sub->add_option("field", o->input, "input field (.vti .nc .nrrd .nhdr, or .raw with --dims)")
        ->required();
    sub->add_option("--members", o->members, "ensemble size (>= 2, default 50)");
    sub->add_option("--noise", o->noise, "bimodal | gaussian | uniform (default bimodal)");
    sub->add_option("--seed", o->p.seed, "random seed (default 1)")
        ->check(wholeNumberIn(0, std::numeric_limits<long long>::max()));
    sub->add_option("--sigma", o->p.sigma,
                    "std of the main mode / gaussian noise, as a fraction of the value range "
                    "(default 0.02)");
    sub->add_option("--width", o->p.width, "uniform half-width, fraction of range (default 0.05)");
    sub->add_option("--outlier-fraction", o->p.outlierFraction,
                    "bimodal: share of outliers (default 0.2)");
    sub->add_option("--outlier-offset", o->p.outlierOffset,
                    "bimodal: outlier mode at truth + offset x range (default 0.2)");
    sub->add_option("--outlier-sigma", o->p.outlierSigma,
                    "bimodal: outlier mode std, fraction of range (default 0.04)");
    sub->add_option("--var", o->var, "variable/array of the input to read");
    sub->add_option("-o,--output", o->out, "output ensemble .nc")->required();
    addRawLayoutOptions(sub, o->raw);
    sub->callback([o] {
        requireOutputExtension(o->out, "-o", {".nc"}, "perturb writes a NetCDF ensemble");
        o->p.kind = parseNoiseKind(o->noise);
        requireOutputsNotInputs({{"-o", o->out}}, {o->input});
        requireOutputDirectory(o->out, "-o");
        FieldReadOptions ro;
        ro.var = o->var;
        ro.raw = toRawLayout(o->raw);
        ScalarField f = readField(o->input, ro);
        Ensemble e = perturbField(f, o->members, o->p);
        writeEnsembleNetcdf(o->out, e);
        std::fprintf(stderr, "perturb: %d members of %s noise (seed %llu) -> %s\n", o->members,
                     o->noise.c_str(), static_cast<unsigned long long>(o->p.seed), o->out.c_str());
    });
}

}  // namespace udvr::cmd
