// SPDX-License-Identifier: Apache-2.0
#pragma once
// The operation table: every operation relief offers (its inputs, outputs
// and modifiers) described once. The command line's parser and --help, the
// C ABI (relief_c.h), the Python module and the option checks of the C++
// functions all read it; the defaults are the option structs' own.
#include <OpenImageIO/imagebuf.h>

#include <string>
#include <utility>
#include <vector>

#include "relief/bake.h"
#include "relief/check.h"
#include "relief/correct.h"
#include "relief/export.h"
#include "relief/height.h"
#include "relief/mesh.h"
#include "relief/operation_types.h"
#include "relief/options.h"
#include "relief/preview.h"
#include "relief/slopes.h"

namespace relief {

// Every operation's description (relief/operation_types.h), in the order
// --help lists them.
RELIEF_API const std::vector<OperationInfo>& operations();
// nullptr when there is no such operation.
RELIEF_API const OperationInfo* find_operation(const std::string& name);
// Why an image of width x height x channels cannot be input `slot` of
// `operation` ("height: input 'normals' has 7 channel(s); height takes 2 to
// 4"), or "" when it can: its shape, the kernels' index range, and, with
// `bytes_per_channel` > 0, whether this machine has the memory to copy its
// pixels. The C ABI and Python check their images with it before they copy
// a pixel, so a size a caller cannot have is refused with the numbers.
RELIEF_API std::string input_problem(const std::string& operation, const ImageSlot& slot, long long width,
                                     long long height, long long channels, int bytes_per_channel = 0);
// Why `call` cannot run on a width x height map on `device` for want of
// memory, or "": every operation's float result, and the operation's own
// estimate where it has one before any work (the height's slopes and
// integration grids for its method and boundary). Python checks it before
// it copies an array, so a map too large is refused at once, not after a
// copy of minutes.
RELIEF_API std::string memory_problem(const OperationCall& call, const std::string& device, long long width,
                                      long long height);
// The table as a JSON document: {"abi_version": 2, "operations": [...]}.
RELIEF_API std::string operations_json();

// What a front end needs to know of a call without naming its operation:
// the files it reads besides its input images (File modifiers: mask=FILE,
// fix=FILE, env=FILE) and those it writes besides its result (Output
// modifiers: mesh's out=FILE), as its modifiers name them.
RELIEF_API std::vector<std::string> files_read(const OperationCall& call);
RELIEF_API std::vector<std::string> files_written(const OperationCall& call);
// `call` with each modifier that names a file it reads set back to its
// default: what the call does apart from those files' contents (a job's
// digest hashes their bytes instead of their names).
RELIEF_API OperationCall without_files_read(const OperationCall& call);
// Whether prepare() for the map's size (devices.h) shortens the call: what
// the command line starts on a second thread while it reads the map.
RELIEF_API bool sets_up_ahead(const OperationCall& call);
// Whether the call, run over the tiles of a UDIM set, takes them all at
// once (run_operation_on_tiles): --height with udim=joint, or udim=auto
// without a mask image.
RELIEF_API bool joins_tiles(const OperationCall& call);
// The call's choices in words, as -v prints them ("" when the operation has
// nothing to add to its modifiers).
RELIEF_API std::string describe(const OperationCall& call);

// Every modifier of call.operation as "key=value", joined by ':' in the
// table's order, defaults included: the call written out in full. Two calls
// with the same text compute the same result from the same images (file
// modifiers give the path; hash the file's bytes alongside).
RELIEF_API std::string modifier_text(const OperationCall& call);

// A digest (32 hex digits, XXH3-128) of what decides results besides the
// images and the modifiers: relief's version and the OpenCL kernel sources
// it builds (those of $RELIEF_KERNEL_DIR when that is set).
RELIEF_API std::string implementation_digest();

// Parses modifiers written as on the command line ("key=value:key=value",
// fix=height:H0:DH keeping its own colons) for `operation`, checking each
// against the table and the combinations against each other. Returns false
// and sets geterror() to a one-line message (without the operation's name).
RELIEF_API bool parse_modifiers(OperationCall& call, const std::string& operation,
                                const std::string& modifiers);
// The same from key/value pairs (Python's keywords).
RELIEF_API bool parse_modifiers(OperationCall& call, const std::string& operation,
                                const std::vector<std::pair<std::string, std::string>>& modifiers);

// Why `operation` cannot be called on `images` images ("" when it can): the
// number the table's inputs say, a one-line message naming both otherwise.
// Every front end (run_operation, the C ABI, Python) asks this before it
// converts anything.
RELIEF_API std::string call_problem(const std::string& operation, std::size_t images);
// The same for a call over the tiles of a UDIM set: an operation of one
// input that joins tiles, at least one tile, a number for each image.
RELIEF_API std::string tiles_call_problem(const std::string& operation, std::size_t numbers,
                                          std::size_t images);
// And the numbers themselves: each from 1001 to 1999, none twice (a C
// host's relief_run_tiles gets RELIEF_INVALID for them, as for the counts).
RELIEF_API std::string tiles_call_problem(const std::string& operation, const std::vector<int>& numbers,
                                          std::size_t images);

// Runs `call` on `inputs` (as many as the table's inputs, in that order),
// with `exec` (device, messages, progress, cancel). Progress is 0 first and
// 1 last, whatever steps the operation reports between. Reads
// mask_file/fix_file when given. Returns false and sets geterror() on
// failure ("<operation>: cancelled" when exec.cancel stopped it).
RELIEF_API bool run_operation(OIIO::ImageBuf& dst, const OperationCall& call,
                              const std::vector<const OIIO::ImageBuf*>& inputs, const Execution& exec = {});

// Runs `call` once over the tiles of a UDIM set (relief/udim.h): `tiles`
// their numbers, `inputs` one image per tile (operations of one input), dst
// one result per tile in the same order. Returns false and sets geterror()
// on failure (dst then empty), also for an operation that does not join tiles.
RELIEF_API bool run_operation_on_tiles(std::vector<OIIO::ImageBuf>& dst, const OperationCall& call,
                                       const std::vector<int>& tiles,
                                       const std::vector<const OIIO::ImageBuf*>& inputs,
                                       const Execution& exec = {});

}  // namespace relief
