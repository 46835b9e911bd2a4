// nfex_client_tests GROUP: runs the cases of one group ("offline", or "service", which needs
// NFEX_TEST_URL — the base URL of a running nFEX service — and exits 77, ctest's skip, without it).
#include "check.hpp"

#include <cstdlib>
#include <exception>
#include <iostream>

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: nfex_client_tests offline|service\n";
        return 2;
    }
    std::string group = argv[1];
    if (group == "service" && std::getenv("NFEX_TEST_URL") == nullptr) {
        std::cout << "skipped: NFEX_TEST_URL is not set (tests/clients/test_cpp_client.py sets it)\n";
        return 77;
    }
    int passed = 0, failed = 0;
    for (const auto& c : check::cases()) {
        if (c.group != group) continue;
        try {
            c.body();
            ++passed;
            std::cout << "ok   " << c.name << "\n";
        } catch (const std::exception& e) {
            ++failed;
            std::cout << "FAIL " << c.name << ": " << e.what() << "\n";
        }
    }
    std::cout << passed << " passed, " << failed << " failed\n";
    return failed == 0 && passed > 0 ? 0 : 1;
}
