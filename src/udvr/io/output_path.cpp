// Outputs that would replace an input (output_path.h).
#include "udvr/io/output_path.h"

#include <filesystem>
#include <system_error>

#include "udvr/io/io_detail.h"
#include "udvr/util/check.h"

namespace udvr {
namespace fs = std::filesystem;

namespace {

/// Whether a and b name the same file: after symlinks and hard links where both exist, else by
/// their weakly canonical paths (an output that does not exist yet, an input that is missing).
bool samePath(const fs::path& a, const fs::path& b) {
    std::error_code ec;
    if (fs::exists(a, ec) && fs::exists(b, ec)) {
        const bool same = fs::equivalent(a, b, ec);
        if (!ec) return same;
    }
    std::error_code ea, eb;
    const fs::path ca = fs::weakly_canonical(a, ea), cb = fs::weakly_canonical(b, eb);
    return !ea && !eb && ca == cb;
}

/// The folder of a .pvti's pieces (<dir>/<stem>); empty for other paths.
fs::path pieceFolder(const fs::path& p) {
    if (detail::lowerExtension(p) != ".pvti") return {};
    return p.parent_path() / p.stem();
}

/// Whether `file` is a .vti directly in `folder` (where a .pvti's pieces lie).
bool pieceIn(const fs::path& file, const fs::path& folder) {
    if (folder.empty() || detail::lowerExtension(file) != ".vti") return false;
    const fs::path parent = file.parent_path().empty() ? fs::path(".") : file.parent_path();
    return samePath(parent, folder);
}

}  // namespace

void requireOutputsNotInputs(const std::vector<OutputPath>& outputs,
                             const std::vector<std::string>& inputs) {
    struct Input {
        std::string path, pattern;  // pattern: the glob that matched it ("" = given as is)
    };
    std::vector<Input> files;
    for (const std::string& in : inputs) {
        if (in.empty()) continue;
        std::error_code ec;
        if (detail::isGlobPattern(in) && !fs::exists(in, ec)) {
            try {
                for (std::string& f : detail::expandGlob(in)) files.push_back({std::move(f), in});
            } catch (const UdvrError&) {  // matches nothing: the read says so
            }
        } else {
            files.push_back({in, ""});
        }
    }
    for (const OutputPath& out : outputs) {
        if (out.path.empty()) continue;
        for (const Input& in : files) {
            const bool same = samePath(out.path, in.path);
            if (!same && !pieceIn(out.path, pieceFolder(in.path)) &&
                !pieceIn(in.path, pieceFolder(out.path)))
                continue;
            const std::string what =
                in.path + (in.pattern.empty() ? "" : ", matched by '" + in.pattern + "'");
            if (same)
                UDVR_FAIL(out.flag << " " << out.path << " is also an input (" << what
                                   << "): writing it would replace the input; choose another "
                                      "output path");
            UDVR_FAIL(out.flag << " " << out.path << " and the input " << what
                               << " share a .pvti's piece folder: writing it would replace an "
                                  "input's piece; choose another output path");
        }
    }
}

}  // namespace udvr
