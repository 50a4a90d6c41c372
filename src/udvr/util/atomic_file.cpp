#include "udvr/util/atomic_file.h"

#include <unistd.h>

#include <fstream>
#include <system_error>

#include "udvr/util/check.h"

namespace udvr {

void writeAtomically(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path& tmpPath)>& write) {
    namespace fs = std::filesystem;
    fs::path dir = path.parent_path();
    if (!dir.empty() && !fs::is_directory(dir)) {
        UDVR_FILE_FAIL("cannot write " << path.string() << ": directory " << dir.string()
                                       << " does not exist");
    }
    fs::path tmp = path;
    tmp.replace_filename("." + path.stem().string() + ".tmp" + std::to_string(getpid()) +
                         path.extension().string());
    try {
        write(tmp);
    } catch (...) {
        std::error_code ec;
        fs::remove(tmp, ec);
        throw;
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) {
        const std::string why = fs::is_directory(path) ? "it is a directory" : ec.message();
        std::error_code removeError;  // ec holds the reason; do not overwrite it
        fs::remove(tmp, removeError);
        UDVR_FILE_FAIL("cannot write " << path.string() << ": " << why);
    }
}

void writeFileAtomically(const std::filesystem::path& path, const std::string& bytes) {
    writeAtomically(path, [&](const std::filesystem::path& tmp) {
        std::ofstream out(tmp, std::ios::binary);
        if (!out) UDVR_FILE_FAIL("cannot open " << tmp.string() << " for writing");
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        out.close();
        if (!out) UDVR_FILE_FAIL("write failed for " << path.string() << " (disk full?)");
    });
}

}  // namespace udvr
