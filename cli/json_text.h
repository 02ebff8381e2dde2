// SPDX-License-Identifier: Apache-2.0
#pragma once
// JSON that carries file names. relief's JSON goes through nlohmann::json,
// which takes UTF-8 only; a file name is bytes. So a string is written as
// JSON text that stays valid and gives the bytes back exactly: valid UTF-8
// as it is, and every other byte B as the escape \udcXX (XX = B), the
// convention of Python's "surrogateescape" (what Python itself does with
// such names): json.loads(line) and then os.fsencode(name) give back the
// bytes; relief-slurm reads the lines so.
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace relief::cli {

using Json = nlohmann::ordered_json;

// A JSON string value of `bytes` (what json_text() turns into \udcXX).
Json json_bytes(const std::string& bytes);
Json json_bytes(const std::vector<std::string>& list);

// The text of `value` on one line (indent < 0) or indented, every string
// made by json_bytes() as above.
std::string json_text(const Json& value, int indent = -1);

}  // namespace relief::cli
