#include "udvr/cmd/parse_util.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <optional>

#include "udvr/classify/tf_presets.h"
#include "udvr/io/ensemble_io.h"
#include "udvr/io/model_io.h"
#include "udvr/io/transfer_function_io.h"
#include "udvr/util/atomic_file.h"
#include "udvr/util/check.h"

namespace udvr::cmd {
CLI::Validator wholeNumberIn(long long lo, long long hi) {
    const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return CLI::Validator(
        [lo, hi, range](std::string& input) -> std::string {
            errno = 0;
            char* end = nullptr;
            const long long v = std::strtoll(input.c_str(), &end, 10);
            if (input.empty() || end == input.c_str() || *end != '\0' || errno == ERANGE ||
                v < lo || v > hi)
                return "'" + input + "' is not a whole number in " + range;
            return {};
        },
        "INT in " + range);
}

void addRawLayoutOptions(CLI::App* sub, RawLayoutFlags& flags) {
    sub->add_option("--dims", flags.dims, "raw input: X,Y,Z (or N)");
    sub->add_option("--type", flags.type,
                    "raw input: uint8 int8 uint16 int16 uint32 int32 float32 float64 "
                    "(default float32)");
    sub->add_flag("--big-endian", flags.bigEndian, "raw input: big-endian values");
    sub->add_option("--spacing", flags.spacing, "raw input: spacing S or SX,SY,SZ (default 1)");
    sub->add_option("--origin", flags.origin, "raw input: origin x,y,z (default 0,0,0)");
}

RawLayout toRawLayout(const RawLayoutFlags& flags) {
    RawLayout raw;
    if (flags.dims.empty()) {
        if (!flags.spacing.empty() || !flags.origin.empty() || flags.bigEndian)
            UDVR_FAIL("--spacing/--origin/--big-endian describe a raw file and need --dims");
        return raw;
    }
    raw.dims = parseDims(flags.dims, "--dims");
    raw.type = flags.type;
    raw.bigEndian = flags.bigEndian;
    if (!flags.spacing.empty()) {
        const auto s = parseDoubleList(flags.spacing, "--spacing");
        if (s.size() != 1 && s.size() != 3)
            UDVR_FAIL("--spacing expects S or SX,SY,SZ, got '" << flags.spacing << "'");
        for (std::size_t a = 0; a < 3; ++a) {
            raw.spacing[a] = s[s.size() == 1 ? 0 : a];
            if (!(raw.spacing[a] > 0))
                UDVR_FAIL("--spacing must be positive, got '" << flags.spacing << "'");
        }
    }
    if (!flags.origin.empty()) raw.origin = parseVec3(flags.origin, "--origin");
    return raw;
}

void requireOutputDirectory(const std::string& path, const std::string& flag) {
    // Before any work: a build that would fail only at its write is told at once.
    try {
        requireWritableDirectory(path);
    } catch (const FileError& e) {
        UDVR_FAIL(flag << ": " << e.what());
    }
}

void requireOutputExtension(const std::string& path, const std::string& flag,
                            const std::vector<std::string>& extensions, const std::string& what) {
    const std::string ext = lowerExtension(path);
    for (const std::string& e : extensions)
        if (ext == e) return;
    std::string names;
    for (std::size_t i = 0; i < extensions.size(); ++i)
        names += (i == 0 ? "" : i + 1 == extensions.size() ? " or " : ", ") + extensions[i];
    UDVR_FAIL(flag << " must name a " << names << " file" << (what.empty() ? "" : " (" + what + ")")
                   << ", got '" << path << "'");
}

std::string lowerExtension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

ModelVolume readModelOrField(const std::string& path, const std::string& var,
                             const RawLayoutFlags& raw) {
    FieldReadOptions fo;
    fo.var = var;
    fo.raw = toRawLayout(raw);
    return udvr::readModelOrField(path, fo);
}

bool netcdfHoldsEnsemble(const std::vector<ArrayInfo>& arrays, const std::string& var) {
    for (const ArrayInfo& a : arrays)
        if (a.dimNames.size() == 4 && (var.empty() || a.name == var)) return true;
    return false;
}

bool isEnsembleInput(const std::vector<std::string>& inputs, const std::string& var,
                     const RawLayoutFlags& raw) {
    if (inputs.size() != 1) return inputs.size() > 1;
    const std::string& path = inputs.front();
    if (path.find_first_of("*?[") != std::string::npos && !std::filesystem::exists(path))
        return true;
    return lowerExtension(path) == ".nc" &&
           netcdfHoldsEnsemble(listArrays(path, toRawLayout(raw)), var);
}

void addEnsembleOptions(CLI::App* sub, EnsembleFlags& flags) {
    sub->add_option("--member-dim", flags.memberDim,
                    "--model members: the NetCDF member dimension's name");
    sub->add_option("--memory-cap", flags.memoryCapGiB,
                    "--model members: the most GiB the members may take in memory (n x voxels x "
                    "4 bytes; default 8)");
}

ModelVolume readMembersModel(const std::vector<std::string>& inputs, const std::string& var,
                             const RawLayoutFlags& raw, const EnsembleFlags& flags) {
    if (!(flags.memoryCapGiB > 0.0) || !std::isfinite(flags.memoryCapGiB))
        UDVR_FAIL("--memory-cap must be a positive number of GiB, got " << flags.memoryCapGiB);
    if (!isEnsembleInput(inputs, var, raw)) {
        const std::string& path = inputs.front();
        bool model = false;
        if ((lowerExtension(path) == ".vti" || lowerExtension(path) == ".pvti") && var.empty())
            for (const ArrayInfo& a : listArrays(path, toRawLayout(raw)))
                model = model || a.name == "mean";
        UDVR_FAIL(
            "--model members needs an ensemble (a .nc with a member dimension, 2+ member "
            "files or a quoted glob), but "
            << path << " is " << (model ? "a model file" : "a single field")
            << ": it averages the TF over the members themselves");
    }
    EnsembleReadOptions ro;
    ro.var = var;
    ro.memberDim = flags.memberDim;
    ro.raw = toRawLayout(raw);
    ro.voxelMajor = true;
    ro.checkSize = [&](int members, const Grid3& grid) {
        const double gib = static_cast<double>(members) * static_cast<double>(grid.pointCount()) *
                           sizeof(float) / (1024.0 * 1024.0 * 1024.0);
        if (gib > flags.memoryCapGiB) {
            char text[64];
            std::snprintf(text, sizeof text, "%.3g GiB", gib);
            UDVR_FAIL("--model members holds the "
                      << members << " members of " << grid.dims[0] << "x" << grid.dims[1] << "x"
                      << grid.dims[2] << " points in memory: " << text << ", over the cap of "
                      << flags.memoryCapGiB
                      << " GiB (raise it with --memory-cap GIB, or "
                         "render a model built with `udvr build`)");
        }
    };
    return membersModel(readEnsemble(inputs, ro));
}

ModelVolume readSecondInput(const RenderOptions& options, const std::string& var,
                            const RawLayoutFlags& raw, const EnsembleFlags& flags, bool members) {
    const std::string& secondVar = secondFieldVar(options, var);
    return members ? readMembersModel({options.second}, secondVar, raw, flags)
                   : readModelOrField(options.second, secondVar, raw);
}

void requireSecondForMembersTf2(const RenderOptions& options, bool members, bool twoD) {
    if (members && twoD && options.second.empty())
        UDVR_FAIL(
            "--model members classifies with a 1D transfer function (--tf), or a 2D one "
            "over two ensembles with --second, not --tf2 alone");
}

void addTf2Options(CLI::App* sub, Tf2Flags& flags) {
    sub->add_option("--tf2", flags.file,
                    "2D transfer function over value x gradient magnitude (.vti, .npy, widget "
                    ".json; SPEC 9)");
    addTf2FormOptions(sub, flags);
}

void addTf2FormOptions(CLI::App* sub, Tf2Flags& flags) {
    sub->add_option("--tf2-domain", flags.domain,
                    "x0,x1,y0,y1: the domain of a .npy 2D TF (required there); overrides a "
                    "widget file's");
    sub->add_option("--tf2-resolution", flags.resolution,
                    "WxH points a widget 2D TF is rasterised onto (default: the file's, else "
                    "256x256)");
}

Tf2ReadOptions toTf2ReadOptions(const Tf2Flags& flags, bool force) {
    Tf2ReadOptions ro;
    ro.force = force;
    if (!flags.domain.empty()) {
        const std::vector<double> d = parseDoubleList(flags.domain, "--tf2-domain");
        if (d.size() != 4)
            UDVR_FAIL("--tf2-domain expects x0,x1,y0,y1, got '" << flags.domain << "'");
        ro.domain = std::array<double, 4>{d[0], d[1], d[2], d[3]};
    }
    if (!flags.resolution.empty()) ro.resolution = parseSize(flags.resolution, "--tf2-resolution");
    return ro;
}

void requireOneTf(const std::string& tf, const Tf2Flags& tf2) {
    if (!tf.empty() && !tf2.file.empty()) UDVR_FAIL("give either --tf or --tf2, not both");
    if (tf2.file.empty() && (!tf2.domain.empty() || !tf2.resolution.empty()))
        UDVR_FAIL("--tf2-domain and --tf2-resolution need --tf2");
}

void addTfOptions(CLI::App* sub, TfFlags& flags) {
    sub->add_option("--tf", flags.tf,
                    "1D transfer function: a ParaView JSON file, or a preset (" +
                        transferFunctionPresetList() +
                        ") over the data's 0.5-99.5th percentiles (default: " +
                        transferFunctionPresetNames().front() + ")");
    sub->add_option("--tf-range", flags.range, "lo,hi: the value range a preset spans");
    sub->add_option("--save-tf", flags.save, "write the 1D TF used as ParaView JSON, to edit");
}

void checkTfFlags(const TfFlags& flags, bool twoD) {
    if (twoD && (!flags.range.empty() || !flags.save.empty()))
        UDVR_FAIL("--tf-range and --save-tf are for 1D transfer functions, not --tf2");
    if (!flags.save.empty()) {
        if (lowerExtension(flags.save) != ".json")
            UDVR_FAIL("--save-tf must name a .json file, got '" << flags.save << "'");
        requireOutputsNotInputs({{"--save-tf", flags.save}}, {flags.tf});
        requireOutputDirectory(flags.save, "--save-tf");
        if (std::filesystem::is_directory(flags.save))
            UDVR_FAIL("--save-tf: cannot write " << flags.save << ": it is a directory");
    }
    if (!flags.range.empty()) {
        const std::vector<double> r = parseDoubleList(flags.range, "--tf-range");
        if (r.size() != 2 || !(r[0] < r[1]))
            UDVR_FAIL("--tf-range expects lo,hi with lo < hi, got '" << flags.range << "'");
        if (!tfIsPreset(flags))
            UDVR_FAIL("--tf-range spreads a preset; --tf " << flags.tf << " is a file");
    }
}

bool tfIsPreset(const TfFlags& flags) {
    if (flags.tf.empty()) return true;
    return isTransferFunctionPreset(flags.tf) && !std::filesystem::exists(flags.tf);
}

TransferFunction1D readTransferFunctionFile(const TfFlags& flags) {
    if (!std::filesystem::exists(flags.tf) && lowerExtension(flags.tf) != ".json")
        UDVR_FAIL("--tf '" << flags.tf << "' is neither a file nor a preset"
                           << didYouMean(flags.tf, transferFunctionPresetNames())
                           << " (presets: " << transferFunctionPresetList() << ")");
    return readTransferFunction(flags.tf);
}

namespace {

TfChoice chooseOverBasis(const TfFlags& flags, const std::function<DefaultTfBasis()>& basisOf,
                         const std::string& command) {
    TfChoice choice;
    if (!tfIsPreset(flags)) {
        choice.tf = readTransferFunctionFile(flags);
        return choice;
    }
    const std::string name = flags.tf.empty() ? transferFunctionPresetNames().front() : flags.tf;
    std::optional<std::array<double, 2>> given;
    const char* rangeText = "the 0.5-99.5th percentiles of the values";
    if (!flags.range.empty()) {
        const std::vector<double> r = parseDoubleList(flags.range, "--tf-range");
        given = std::array<double, 2>{r[0], r[1]};
        rangeText = "--tf-range";
    }
    const PresetOverValues preset = transferFunctionPresetOver(name, basisOf(), given);
    const std::array<double, 2>& range = preset.range;
    const bool constant = preset.constant;
    const double median = preset.rampStart;
    choice.tf = preset.tf;
    // What the opacity does, as built (the start is clamped into the range).
    char ramp[256];
    if (constant)
        std::snprintf(ramp, sizeof ramp, "the volume is constant: opacity rising over the range");
    else if (!preset.opacityRule.empty())
        std::snprintf(ramp, sizeof ramp, "opacity on %s", preset.opacityRule.c_str());
    else if (median > range[0] && median < range[1])
        std::snprintf(ramp, sizeof ramp, "opacity 0 up to the median %.6g, then rising to 0.5",
                      median);
    else
        std::snprintf(ramp, sizeof ramp, "opacity rising from 0 to 0.5 over the range");
    char note[640];
    std::snprintf(note, sizeof note, "%s: %s preset '%s' over [%.6g, %.6g] (%s), %s; %s",
                  command.c_str(), flags.tf.empty() ? "no --tf: the" : "the", name.c_str(),
                  range[0], range[1], constant ? "widened around the one value" : rangeText, ramp,
                  flags.save.empty() ? "--save-tf tf.json writes it to edit"
                                     : ("saved to " + flags.save).c_str());
    choice.note = note;
    return choice;
}

}  // namespace

TfChoice chooseTransferFunction(const TfFlags& flags,
                                const std::function<DefaultTfBasis()>& basisOf,
                                const std::string& command) {
    return chooseOverBasis(flags, basisOf, command);
}

TfChoice chooseTransferFunction(const TfFlags& flags, const ModelVolume& model,
                                const std::string& command) {
    return chooseOverBasis(
        flags, [&] { return defaultTfBasisOf(model); }, command);
}

void finishTransferFunction(const TfFlags& flags, const TfChoice& choice) {
    if (!flags.save.empty())
        writeFileAtomically(
            flags.save,
            transferFunctionToJson(
                choice.tf, flags.tf.empty() ? transferFunctionPresetNames().front() : flags.tf));
    if (!choice.note.empty()) std::fprintf(stderr, "%s\n", choice.note.c_str());
}

}  // namespace udvr::cmd
