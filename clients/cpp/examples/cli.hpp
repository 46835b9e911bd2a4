// What the two examples share: --name value arguments, and one line on stderr plus the nfex CLI's exit
// codes (README: 1 invalid data, 2 bad input, 3 internal, 4 not found, 5 conflict, 6 store
// unavailable, 7 query limit) for every error.
#pragma once

#include <nfex/nfex.hpp>

#include <iostream>
#include <map>
#include <set>
#include <stdexcept>
#include <string>

namespace cli {

struct Usage : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

/// --name value pairs; anything else, or a name not in `known`, is a Usage error.
inline std::map<std::string, std::string> parse(int argc, char** argv, const std::set<std::string>& known) {
    std::map<std::string, std::string> out;
    for (int i = 1; i < argc; i += 2) {
        std::string name = argv[i];
        if (name.rfind("--", 0) != 0 || known.count(name.substr(2)) == 0) throw Usage("unknown argument " + name);
        if (i + 1 >= argc) throw Usage(name + " needs a value");
        out[name.substr(2)] = argv[i + 1];
    }
    return out;
}

inline nfex::Options options(const std::map<std::string, std::string>& args) {
    nfex::Options o;
    if (args.count("timeout")) o.timeout = std::chrono::milliseconds(static_cast<long long>(std::stod(args.at("timeout")) * 1000));
    if (args.count("retries")) o.retries = std::stoi(args.at("retries"));
    return o;
}

/// The exit code for a problem, by its type (as the nfex CLI exits for the same error).
inline int exit_code(const nfex::ProblemError& e) {
    static const std::map<std::string, int> by_slug = {
        {"no-candidate", 1},      {"shacl-violation", 1},    {"not-found", 4},          {"http-404", 4},
        {"data-missing", 4},      {"version-conflict", 5},   {"precondition-failed", 5}, {"store-unavailable", 6},
        {"query-limit", 7}};
    auto it = by_slug.find(e.slug());
    if (it != by_slug.end()) return it->second;
    return e.status() < 500 ? 2 : 3;
}

/// Runs `body`; every error becomes "<program>: <detail>" on stderr and its exit code.
template <class Body>
int run(const char* program, const char* usage, Body body) {
    try {
        return body();
    } catch (const Usage& e) {
        std::cerr << program << ": " << e.what() << "\nusage: " << program << " " << usage << "\n";
        return 2;
    } catch (const nfex::ProblemError& e) {
        std::cerr << program << ": " << e.detail() << " [" << e.status() << " " << e.slug() << "]\n";
        return exit_code(e);
    } catch (const nfex::TransportError& e) {
        std::cerr << program << ": " << e.what() << "\n";
        return 6;
    } catch (const std::invalid_argument& e) {
        std::cerr << program << ": " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << program << ": " << e.what() << "\n";
        return 3;
    }
}

}  // namespace cli
