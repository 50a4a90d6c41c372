#pragma once
// The CLI's shared flag groups (raw layout, ensembles, TFs) and input readers; the value
// parsers all front ends share are util/text_parse.h.
#include <CLI/CLI.hpp>
#include <array>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "udvr/classify/tf_presets.h"
#include "udvr/classify/transfer_function.h"
#include "udvr/io/field_io.h"
#include "udvr/io/file_info.h"
#include "udvr/io/output_path.h"
#include "udvr/io/transfer_function_2d_io.h"
#include "udvr/render/render_options.h"
#include "udvr/stats/model_volume.h"
#include "udvr/util/text_parse.h"

namespace udvr::cmd {

/// Raw-file layout flags as typed (--dims --type --big-endian --spacing --origin).
struct RawLayoutFlags {
    std::string dims, type = "float32", spacing, origin;
    bool bigEndian = false;
};
/// Register the raw-layout flags on a subcommand (for headerless .raw inputs).
void addRawLayoutOptions(CLI::App* sub, RawLayoutFlags& flags);
/// The RawLayout the flags describe (not given() when --dims is absent).
RawLayout toRawLayout(const RawLayoutFlags& flags);

/// Fail unless the folder that will hold `path` exists and is writable (checked before long work
/// starts, so a bad output path costs nothing and leaves nothing behind).
void requireOutputDirectory(const std::string& path, const std::string& flag);
/// Fail unless `path` ends in one of `extensions` (lower case, with the dot; compared case-
/// insensitively): "-o must name a .nc file (what), got 'p.vti'". Checked before any input is
/// read, so a wrong extension costs nothing; `what` (may be empty) says what the command writes.
void requireOutputExtension(const std::string& path, const std::string& flag,
                            const std::vector<std::string>& extensions, const std::string& what);

/// A CLI11 check: a whole number in [lo, hi]. CLI11's own Range prints the bounds as doubles
/// and accepts "-1" for unsigned options (strtoull wraps it), so counts and seeds use this.
CLI::Validator wholeNumberIn(long long lo, long long hi);

/// The file extension of `path`, lower case, with the dot ("" when none).
std::string lowerExtension(const std::string& path);

/// A model .vti (one with a `mean` array) or any scalar field, which becomes a mean-only model;
/// `var` names the field's array/variable, `raw` the layout of a headerless .raw file.
ModelVolume readModelOrField(const std::string& path, const std::string& var,
                             const RawLayoutFlags& raw);

/// Whether a NetCDF file whose variables are `arrays` (listArrays) holds an ensemble: the
/// variable `var` (or, empty, any) has 4 dims (a member dimension and 3 grid dims).
bool netcdfHoldsEnsemble(const std::vector<ArrayInfo>& arrays, const std::string& var);
/// Whether `inputs` name an ensemble rather than one field or model (`udvr build`'s inputs): 2
/// or more files, a glob that is not itself a file, or a NetCDF ensemble (its header only).
bool isEnsembleInput(const std::vector<std::string>& inputs, const std::string& var,
                     const RawLayoutFlags& raw);

/// How `--model members` reads an ensemble: --member-dim and --memory-cap.
struct EnsembleFlags {
    std::string memberDim;
    double memoryCapGiB = 8.0;  // the members' n·voxels·4 bytes may not pass this
};
/// Register --member-dim and --memory-cap.
void addEnsembleOptions(CLI::App* sub, EnsembleFlags& flags);
/// The ensemble `inputs` as the `members` reference (membersModel), read voxel-major under the
/// memory cap (refused, saying the size needed, before any value is allocated). Fails for
/// inputs that are not an ensemble: a model file or a single field.
ModelVolume readMembersModel(const std::vector<std::string>& inputs, const std::string& var,
                             const RawLayoutFlags& raw, const EnsembleFlags& flags);
/// The --second input of render and probe (SPEC §9): with --model members an ensemble
/// (readMembersModel, the same --member-dim and cap), else a model or field (readModelOrField);
/// its array is secondFieldVar's. Refuses --model members with --tf2 but no --second (members
/// has a bivariate kernel, not a value × gradient one).
ModelVolume readSecondInput(const RenderOptions& options, const std::string& var,
                            const RawLayoutFlags& raw, const EnsembleFlags& flags, bool members);
void requireSecondForMembersTf2(const RenderOptions& options, bool members, bool twoD);

/// 2D TF flags as typed: --tf2 FILE, --tf2-domain x0,x1,y0,y1, --tf2-resolution WxH.
struct Tf2Flags {
    std::string file, domain, resolution;
};
/// Register --tf2 FILE with --tf2-domain and --tf2-resolution.
void addTf2Options(CLI::App* sub, Tf2Flags& flags);
/// Register --tf2-domain and --tf2-resolution (the file option is the caller's: a positional or
/// --tf2).
void addTf2FormOptions(CLI::App* sub, Tf2Flags& flags);
/// The read options the flags give (domain, widget resolution); `force`: rasterise widgets past
/// kMaxTf2WidgetWorkWithoutForce (the command's --force).
Tf2ReadOptions toTf2ReadOptions(const Tf2Flags& flags, bool force = false);
/// Fail when both --tf and --tf2 were given (neither: the default preset of
/// chooseTransferFunction).
void requireOneTf(const std::string& tf, const Tf2Flags& tf2);

/// The 1D TF flags as typed: --tf FILE|PRESET, --tf-range lo,hi, --save-tf FILE.
struct TfFlags {
    std::string tf, range, save;
};
/// Register --tf, --tf-range and --save-tf.
void addTfOptions(CLI::App* sub, TfFlags& flags);
/// Fail early on flags that need no data: --save-tf's extension and folder, --tf-range's form,
/// either of them with a 2D TF.
void checkTfFlags(const TfFlags& flags, bool twoD = false);
/// Whether --tf names a preset (or is absent): the TF then depends on the data.
bool tfIsPreset(const TfFlags& flags);

/// --tf as a file (not a preset): a name that is neither an existing file nor a .json path is
/// refused with the list of presets.
TransferFunction1D readTransferFunctionFile(const TfFlags& flags);
/// The 1D TF the flags ask for: a ParaView JSON file, or a preset (named, or the default when
/// --tf is absent) spread over --tf-range or else over the default-TF basis `basisOf()` (called
/// only for a preset: the values' robust range, and the boundary-emphasis opacity of
/// defaultTfBasis). `note` says which preset over what range (empty for a file).
struct TfChoice {
    TransferFunction1D tf;
    std::string note;
};
TfChoice chooseTransferFunction(const TfFlags& flags,
                                const std::function<DefaultTfBasis()>& basisOf,
                                const std::string& command);
/// The same over a model: its default-TF basis (defaultTfBasisOf: the full-resolution field's
/// for a downsampled model), so a model and its ground truth get the same default TF.
TfChoice chooseTransferFunction(const TfFlags& flags, const ModelVolume& model,
                                const std::string& command);
/// After the command's work succeeded: write --save-tf (atomically) and print the note, so a
/// failing command prints only its error line.
void finishTransferFunction(const TfFlags& flags, const TfChoice& choice);

}  // namespace udvr::cmd
