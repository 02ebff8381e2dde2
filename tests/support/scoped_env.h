// SPDX-License-Identifier: Apache-2.0
#pragma once
// Environment variables for a test's scope, each put back as it was at the
// scope's end (also when a REQUIRE ends it early).
#include <cstdlib>
#include <string>
#include <vector>

namespace relief::test {

class ScopedEnv {
public:
    ScopedEnv() = default;
    ScopedEnv(const char* name, const char* value) { set(name, value); }
    ~ScopedEnv()
    {
        for (auto it = saved_.rbegin(); it != saved_.rend(); ++it)
            if (it->had)
                ::setenv(it->name.c_str(), it->value.c_str(), 1);
            else
                ::unsetenv(it->name.c_str());
    }
    ScopedEnv(const ScopedEnv&) = delete;
    ScopedEnv& operator=(const ScopedEnv&) = delete;
    // Sets `name` to `value`; nullptr unsets it.
    void set(const char* name, const char* value)
    {
        const char* old = std::getenv(name);
        saved_.push_back({name, old ? old : "", old != nullptr});
        if (value)
            ::setenv(name, value, 1);
        else
            ::unsetenv(name);
    }

private:
    struct Saved {
        std::string name, value;
        bool had;
    };
    std::vector<Saved> saved_;
};

}  // namespace relief::test
