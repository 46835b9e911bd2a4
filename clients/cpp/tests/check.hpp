// A minimal test harness (no test framework among the client's dependencies): TEST(group, name)
// registers a case, CHECK/CHECK_THROWS fail it with file:line, main runs one group.
#pragma once

#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace check {

struct Failure : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct Case {
    std::string group, name;
    std::function<void()> body;
};

inline std::vector<Case>& cases() {
    static std::vector<Case> all;
    return all;
}

struct Register {
    Register(const char* group, const char* name, std::function<void()> body) { cases().push_back({group, name, std::move(body)}); }
};

inline void fail(const char* file, int line, const std::string& what) {
    std::ostringstream out;
    out << file << ":" << line << ": " << what;
    throw Failure(out.str());
}

}  // namespace check

#define CHECK_CAT2(a, b) a##b
#define CHECK_CAT(a, b) CHECK_CAT2(a, b)
#define TEST(group, name)                                                                          \
    static void CHECK_CAT(test_, name)();                                                          \
    static check::Register CHECK_CAT(register_, name)(#group, #name, CHECK_CAT(test_, name));      \
    static void CHECK_CAT(test_, name)()
#define CHECK(cond) \
    do { if (!(cond)) check::fail(__FILE__, __LINE__, "CHECK(" #cond ") failed"); } while (0)
#define CHECK_EQ(a, b)                                                                                   \
    do {                                                                                                 \
        auto&& check_a = (a);                                                                            \
        auto&& check_b = (b);                                                                            \
        if (!(check_a == check_b)) {                                                                     \
            std::ostringstream check_out;                                                                \
            check_out << "CHECK_EQ(" #a ", " #b "): " << check_a << " != " << check_b;                   \
            check::fail(__FILE__, __LINE__, check_out.str());                                            \
        }                                                                                                \
    } while (0)
#define CHECK_THROWS(expr, type)                                                                         \
    do {                                                                                                 \
        bool check_thrown = false;                                                                       \
        try { (void)(expr); } catch (const type&) { check_thrown = true; }                               \
        if (!check_thrown) check::fail(__FILE__, __LINE__, #expr " did not throw " #type);               \
    } while (0)
