#include "udvr/cmd/option_flags.h"

#include <string>
#include <type_traits>

namespace udvr::cmd {

void addOptionFlags(CLI::App* sub, std::span<const OptionSpec> specs, RenderOptions& options) {
    for (const OptionSpec& spec : specs) {
        const std::string flag = std::string("--") + spec.name;
        RenderOptions* o = &options;
        const OptionSpec* s = &spec;
        if (std::holds_alternative<bool RenderOptions::*>(spec.field)) {
            sub->add_flag_callback(
                flag, [o, s] { setOption(*o, *s, "1", ""); }, optionHelp(spec));
        } else {
            sub->add_option_function<std::string>(
                   flag, [o, s, flag](const std::string& v) { setOption(*o, *s, v, flag); },
                   optionHelp(spec))
                ->type_name(std::holds_alternative<std::string RenderOptions::*>(spec.field)
                                ? "TEXT"
                            : std::holds_alternative<double RenderOptions::*>(spec.field) ? "FLOAT"
                                                                                          : "UINT");
        }
    }
}

}  // namespace udvr::cmd
