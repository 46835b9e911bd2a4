#include "nfex/context.hpp"

#include <stdexcept>

namespace nfex {

namespace {

std::string trim(const std::string& s) {
    const char* space = " \t\r\n";
    auto first = s.find_first_not_of(space);
    if (first == std::string::npos) return {};
    return s.substr(first, s.find_last_not_of(space) - first + 1);
}

}  // namespace

Context parse_context(const std::string& text) {
    Context out;
    std::size_t start = 0;
    while (start <= text.size()) {
        auto comma = text.find(',', start);
        std::string item = trim(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
        start = comma == std::string::npos ? text.size() + 1 : comma + 1;
        if (item.empty()) continue;
        auto eq = item.find('=');
        std::string name = eq == std::string::npos ? std::string() : trim(item.substr(0, eq));
        std::string value = eq == std::string::npos ? std::string() : trim(item.substr(eq + 1));
        if (name.empty() || value.empty())
            throw std::invalid_argument("context item '" + item + "' is not name=value (e.g. agent=car,scene=outdoor)");
        out[name] = value;
    }
    return out;
}

}  // namespace nfex
