// SPDX-License-Identifier: Apache-2.0
#pragma once
// Another writer's temporary files, on demand: the test executable
// interposes open(2) (taken_names.cpp), and while take_temporary_names(n)
// has names left to take, an exclusive create of one of relief's temporary
// names (".NAME.relief-tmp-...") finds the file already made, as if another
// process had drawn the same name first, and fails with EEXIST.
#include <string>
#include <vector>

namespace relief::test {

// The next `n` exclusive creates of temporary names in this process are
// taken first; clears the names taken before.
void take_temporary_names(int n);
// The names taken since, in order (the files are left behind, another's).
std::vector<std::string> temporary_names_taken();

}  // namespace relief::test
