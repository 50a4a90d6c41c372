// udvr_fuzz_replay: runs fuzz targets over files, without libFuzzer, so that the normal build
// (GCC, no sanitizers) replays the committed corpora and the inputs of past findings in ctest.
//   udvr_fuzz_replay TARGET PATH...   (a PATH that is a folder: every file in it, sorted)
//   udvr_fuzz_replay --list
// Exit status 0 when every input gave a result or a well-formed UdvrError; 1 when any input
// gave a finding (each is reported on stderr with its file); 2 for a usage error.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_target.h"

namespace fs = std::filesystem;
using udvr::fuzz::Finding;

int main(int argc, char** argv) {
    const auto& targets = udvr::fuzz::targets();
    if (argc == 2 && std::string(argv[1]) == "--list") {
        for (const auto& [name, fn] : targets) std::printf("%s\n", name.c_str());
        return 0;
    }
    if (argc < 3) {
        std::fprintf(stderr, "usage: udvr_fuzz_replay TARGET PATH... | --list\n");
        return 2;
    }
    const std::string name = argv[1];
    const auto it = std::find_if(targets.begin(), targets.end(),
                                 [&](const auto& t) { return t.first == name; });
    if (it == targets.end()) {
        std::fprintf(stderr, "udvr_fuzz_replay: unknown target '%s' (--list names them)\n",
                     name.c_str());
        return 2;
    }
    std::vector<fs::path> files;
    for (int i = 2; i < argc; ++i) {
        const fs::path p = argv[i];
        if (fs::is_directory(p)) {
            std::vector<fs::path> inDir;
            for (const auto& e : fs::directory_iterator(p))
                if (e.is_regular_file()) inDir.push_back(e.path());
            std::sort(inDir.begin(), inDir.end());
            files.insert(files.end(), inDir.begin(), inDir.end());
        } else if (fs::is_regular_file(p)) {
            files.push_back(p);
        } else {
            std::fprintf(stderr, "udvr_fuzz_replay: no such file or folder: %s\n", argv[i]);
            return 2;
        }
    }
    if (files.empty()) {
        std::fprintf(stderr, "udvr_fuzz_replay: no inputs for target '%s'\n", name.c_str());
        return 2;
    }
    int findings = 0;
    for (const fs::path& f : files) {
        std::ifstream in(f, std::ios::binary);
        const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                              std::istreambuf_iterator<char>());
        std::string problem;
        try {
            udvr::fuzz::Scratch::get().clear();
            it->second(bytes);
        } catch (const Finding& e) {
            problem = e.what;
        } catch (const std::exception& e) {  // the targets catch their readers' errors
            problem = std::string("exception escaped the target: ") + e.what();
        }
        if (!problem.empty()) {
            ++findings;
            std::fprintf(stderr, "FINDING %s: %s: %s\n", name.c_str(), f.string().c_str(),
                         problem.c_str());
        }
    }
    std::printf("%s: %zu inputs, %d findings\n", name.c_str(), files.size(), findings);
    return findings == 0 ? 0 : 1;
}
