#pragma once
// Small parsers for CLI values ("64", "64,64,32", "1.5,2,3", "512x512"); throw UdvrError.
#include <CLI/CLI.hpp>
#include <array>
#include <string>
#include <vector>

#include "udvr/io/field_io.h"

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

/// --uniform-width: "variance" (alias "std"; μ ± √3σ, the default) → false, "minmax" → true.
bool parseUniformWidthMinMax(const std::string& text);

/// Fail unless the folder that will hold `path` exists (checked before long work starts, so a
/// bad output path costs nothing and leaves nothing behind).
void requireOutputDirectory(const std::string& path, const std::string& flag);

/// A CLI11 check: a whole number in [lo, hi]. CLI11's own Range prints the bounds as doubles
/// and accepts "-1" for unsigned options (strtoull wraps it), so counts and seeds use this.
CLI::Validator wholeNumberIn(long long lo, long long hi);

/// "N" → {N,N,N}; "X,Y,Z" → {X,Y,Z}; each ≥ 1. `flag` names the option in errors.
std::array<int, 3> parseDims(const std::string& text, const std::string& flag);
/// "x,y,z" → three finite doubles.
std::array<double, 3> parseVec3(const std::string& text, const std::string& flag);
/// "WxH" (or "N" for N×N) → {W,H}, each in [1, 16384].
std::array<int, 2> parseSize(const std::string& text, const std::string& flag);
/// Comma-separated finite doubles.
std::vector<double> parseDoubleList(const std::string& text, const std::string& flag);

}  // namespace udvr::cmd
