#pragma once
// Parsers for option values as users type them ("64", "64,64,32", "1.5,2,3", "512x512"), shared
// by every front end (CLI flags, `udvr serve` query keys, Python keywords); throw UdvrError
// naming the option (`flag`: "--size", or a query key).
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace udvr {

/// Largest image side any front end accepts (pixels); `udvr serve` has its own, lower cap.
inline constexpr int kMaxImageSideAnywhere = 16384;

/// "N" → {N,N,N}; "X,Y,Z" → {X,Y,Z}; each in [1, 65536].
std::array<int, 3> parseDims(const std::string& text, const std::string& flag);
/// "x,y,z" → three finite doubles.
std::array<double, 3> parseVec3(const std::string& text, const std::string& flag);
/// "WxH" (or "N" for N×N) → {W,H}, each in [1, maxSide] (the error names maxSide).
std::array<int, 2> parseSize(const std::string& text, const std::string& flag,
                             int maxSide = kMaxImageSideAnywhere);
/// Comma-separated finite doubles.
std::vector<double> parseDoubleList(const std::string& text, const std::string& flag);
/// The whole text as one finite double.
double parseReal(const std::string& text, const std::string& flag);
/// The whole text as one whole number in [lo, hi] (no sign for lo ≥ 0, no fraction, no
/// exponent; "-1" is not 2⁶⁴ − 1).
std::uint64_t parseWhole(const std::string& text, const std::string& flag, std::uint64_t lo,
                         std::uint64_t hi);
/// "1", "true", "yes", "on" → true; "0", "false", "no", "off" → false.
bool parseBool(const std::string& text, const std::string& flag);
/// `text` cut to 64 characters for an error message (a hostile value may be megabytes).
std::string clipForMessage(std::string_view text);

/// The name in `names` nearest to `given` for a "did you mean" hint: case, '_' and '-' are
/// ignored, then the fewest single-character edits (insert, delete, replace, swap of two
/// neighbours); empty when the nearest needs more than a third of its length in edits (nothing
/// is near). Ties go to the earlier name.
std::string nearestName(std::string_view given, const std::vector<std::string>& names);
/// " (did you mean 'NAME'?)" for nearestName, or "" when nothing is near.
std::string didYouMean(std::string_view given, const std::vector<std::string>& names);

}  // namespace udvr
