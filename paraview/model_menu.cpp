// udvr_paraview_menu TEMPLATE OUTPUT: writes the plugin's server-manager XML (udvr.xml) from its
// template, the model menu generated from the model table (model_rows.h, issue 31 point 2):
//   @UDVR_MODEL_ENTRIES@  one <Entry text="NAME" value="ModelKind" /> per row ParaView renders
//                         (every row but those reading an ensemble's members, which a model
//                         file does not hold), in row order;
//   @UDVR_MODEL_HELP@     "NAME: help" per such row, as the CLI's --model help says it.
// The values are the rows' ModelKind integers, which ParaView stores in state files. Written to
// OUTPUT.tmp and renamed; exit 1 with one line on stderr on failure.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "udvr/classify/model_families.h"

namespace {

std::string xmlEscaped(std::string_view text) {
    std::string out;
    for (char c : text) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

bool replaceOnce(std::string& text, const std::string& marker, const std::string& with) {
    const std::size_t at = text.find(marker);
    if (at == std::string::npos || text.find(marker, at + 1) != std::string::npos) return false;
    text.replace(at, marker.size(), with);
    return true;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::cerr << "usage: udvr_paraview_menu TEMPLATE OUTPUT\n";
        return 1;
    }
    std::ifstream in(argv[1], std::ios::binary);
    if (!in) {
        std::cerr << "udvr_paraview_menu: cannot read " << argv[1] << "\n";
        return 1;
    }
    std::ostringstream text;
    text << in.rdbuf();
    std::string xml = text.str();
    std::string entries, help;
    for (const udvr::ModelFamily& row : udvr::modelFamilies()) {
        if (row.arrays & udvr::kArrayMembers) continue;
        const std::string name = xmlEscaped(row.name);
        entries += (entries.empty() ? "" : "\n") + std::string(10, ' ') + "<Entry text=\"" + name +
                   "\" value=\"" + std::to_string(static_cast<int>(row.kind)) + "\" />";
        help += (help.empty() ? "" : "\n") + std::string(10, ' ') + name + ": " +
                xmlEscaped(row.help) + ".";
    }
    if (!replaceOnce(xml, "@UDVR_MODEL_ENTRIES@", entries) ||
        !replaceOnce(xml, "@UDVR_MODEL_HELP@", help)) {
        std::cerr << "udvr_paraview_menu: " << argv[1]
                  << " must hold @UDVR_MODEL_ENTRIES@ and @UDVR_MODEL_HELP@ once each\n";
        return 1;
    }
    const std::filesystem::path out = argv[2], tmp = out.string() + ".tmp";
    std::error_code ec;
    {
        std::ofstream file(tmp, std::ios::binary);
        file << xml;
        file.close();
        if (file.fail()) {
            std::filesystem::remove(tmp, ec);
            std::cerr << "udvr_paraview_menu: cannot write " << tmp.string() << "\n";
            return 1;
        }
    }
    std::filesystem::rename(tmp, out, ec);
    if (ec) {
        std::cerr << "udvr_paraview_menu: cannot rename to " << out.string() << ": " << ec.message()
                  << "\n";
        std::filesystem::remove(tmp, ec);
        return 1;
    }
    return 0;
}
