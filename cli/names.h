// SPDX-License-Identifier: Apache-2.0
#pragma once
// oiiotool-style names: the UDIM tiles and frames one command line stands
// for, expanded into one argument list each.
#include <string>
#include <vector>

namespace relief::cli {

// One argument list of expand_names(), with where it came from.
struct Expansion {
    std::vector<std::string> args;
    int tile = 0;                      // its UDIM tile (0: none)
    std::vector<std::string> pattern;  // the words before the tile was put in (frames are)
};

// oiiotool-style names. In every argument, a tile token stands for each
// UDIM tile (1001-1999) that exists for the first input argument holding
// one, as OpenImageIO's texture system writes them: <UDIM> (1001), <UVTILE>
// (u1_v1), <u> <v> (from 0), <U> <V> (from 1). With --frames A-B[,C-D...]
// (removed from the result; A-BxS every S-th frame from A, A-ByS the
// others, as oiiotool), # alone stands for a 4-digit frame number, a run of
// # or @ for one digit each (#### and @@@@ = 4), %0Nd or %d as in printf,
// %% for a literal %. Returns one argument list per frame and tile (frames
// outer; each frame's tiles are those that exist for it), or `args` alone
// when nothing is to expand. Without --frames, # @ and % are literal.
// Throws UsageError (a malformed or repeated --frames, --frames without a
// frame token, a tile token with no existing tile, an output (-o, --report)
// that several of the lists would write).
std::vector<std::vector<std::string>> expand_names(const std::vector<std::string>& args);
std::vector<Expansion> expand_names_with_tiles(const std::vector<std::string>& args);

}  // namespace relief::cli
