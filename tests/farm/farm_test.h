// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the farm tests share: the sample maps, scratch folders, a file's lines.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <set>
#include <sstream>

#include <unistd.h>

#include "batch.h"
#include "json_text.h"
#include "command_line.h"
#include "relief/imageio.h"
#include "support/images.h"
#include "support/run_cli.h"

namespace fs = std::filesystem;

namespace relief::test::farm {

namespace fs = std::filesystem;
using relief::cli::Job;
using relief::cli::UsageError;
using relief::test::run_cli;

const std::string kData = std::string(RELIEF_TEST_DATA);
inline const std::string& kNormal = relief::test::kSampleNormal;
const std::string kDem = kData + "/dem_jacksboro/normal.png";

inline fs::path scratch(const std::string& name)
{
    return relief::test::scratch("batch/" + name);
}

inline std::vector<std::string> lines_of(const fs::path& p)
{
    std::ifstream in(p);
    std::vector<std::string> v;
    for (std::string l; std::getline(in, l);)
        v.push_back(l);
    return v;
}
// A small 8-bit PNG crop of a bundled normal map, for quick jobs.
inline void write_crop(const std::string& from, const fs::path& to, int x0, int size = 96)
{
    OIIO::ImageBuf src(from);
    OIIO::ImageBuf crop = OIIO::ImageBufAlgo::cut(src, OIIO::ROI(x0, x0 + size, 0, size));
    crop.set_write_format(OIIO::TypeDesc::UINT8);
    REQUIRE(crop.write(to.string()));
}

// Each record's string `key` (its text up to the first quote).
inline std::vector<std::string> fields(const fs::path& log, const std::string& key)
{
    std::vector<std::string> s;
    const std::string start = "\"" + key + "\":\"";
    for (const std::string& l : lines_of(log)) {
        const std::size_t at = l.find(start) + start.size();
        s.push_back(l.substr(at, l.find('"', at) - at));
    }
    return s;
}

inline std::vector<std::string> statuses(const fs::path& log)
{
    return fields(log, "status");
}

}  // namespace relief::test::farm
