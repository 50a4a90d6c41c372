#pragma once
// Outputs that would replace an input (issue 34, item 10). Every output is written beside its
// destination and renamed onto it (util/atomic_file.h), so `build t.vti … -o t.vti` would read
// t.vti whole and then replace it: the input is lost although every write succeeded. Each
// command that writes checks its outputs against its inputs before any work.
#include <string>
#include <utility>
#include <vector>

namespace udvr {

/// An output of a command: the flag that names it ("-o", "--png") and its path ("" = none).
struct OutputPath {
    std::string flag;
    std::string path;
};

/// Throws UdvrError "-o t.vti is also an input (t.vti): writing it would replace the input; choose
/// another output path" when an output resolves to any of `inputs` (empty ones are skipped):
/// the same file after symlinks and hard links (std::filesystem::equivalent) where both exist,
/// else the same weakly_canonical path. Inputs that are glob patterns (and not themselves a file)
/// stand for the files they match. A .pvti also stands for the folder of its pieces
/// (<stem>/<stem>_<i>.vti beside it): an output .vti in an input .pvti's piece folder, or an
/// input .vti in an output .pvti's, is refused too. Called before any input is read; reads no
/// file's content.
void requireOutputsNotInputs(const std::vector<OutputPath>& outputs,
                             const std::vector<std::string>& inputs);

}  // namespace udvr
