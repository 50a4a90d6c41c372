#include "udvr/io/file_info.h"

#include "udvr/io/field_io.h"
#include "udvr/io/io_detail.h"
#include "udvr/util/check.h"

namespace udvr {

std::vector<ArrayInfo> listArrays(const std::filesystem::path& given, const RawLayout& raw) {
    const std::filesystem::path path = singleFileOf(given);
    detail::requireFile(path);
    const std::string ext = detail::lowerExtension(path);
    if (ext == ".vti" || ext == ".pvti") return detail::listArraysVti(path);
    if (ext == ".nc") return detail::listArraysNetcdf(path);
    ArrayInfo a;
    a.name = path.stem().string();
    if (ext == ".nrrd" || ext == ".nhdr") {
        a.type = detail::nrrdTypeName(path);
    } else if (ext == ".raw" || raw.given()) {
        if (!raw.given()) UDVR_FAIL(path.string() << ": a raw file needs --dims (and --type)");
        a.type = raw.type;
    } else {
        UDVR_FAIL("cannot read " << path.string() << ": unknown field format '" << ext
                                 << "' (expected .raw .nrrd .nhdr .vti .pvti .nc)");
    }
    return {a};
}

}  // namespace udvr
