#pragma once
// The page of `udvr serve` (web/: HTML, ES modules, CSS), embedded in the binary at build time
// (cmake/embed_web.cmake), so a request names an entry of this table, never a file.
#include <span>
#include <string_view>

namespace udvr::serve {

struct WebAsset {
    std::string_view path;  // URL path, "/index.html"
    std::string_view mime;  // Content-Type
    std::span<const unsigned char> data;
};

/// Every embedded file of web/.
std::span<const WebAsset> webAssets();

}  // namespace udvr::serve
