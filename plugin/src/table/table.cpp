// SPDX-License-Identifier: Apache-2.0
// The operation table: the entries gathered, looked up, parsed from
// modifiers and run. Each family's entries are in entries_*.cpp, the schema
// they are written with in schema.h; the JSON listing is operations_json.cpp.
#include <algorithm>
#include <climits>
#include <map>
#include <stdexcept>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "callbacks.h"
#include "error_state.h"
#include "io/library_output.h"
#include "device/memory_budget.h"
#include "relief/operations.h"
#include "schema.h"

namespace relief::table {

const std::vector<Operation>& entries()
{
    static const std::vector<Operation> ops = [] {
        std::vector<Operation> v = {slopes_operation(), height_operation(),  correct_operation(),
                                    bake_operation(),   normals_operation(), tessellation_operation(),
                                    mesh_operation(),   preview_operation()};
        const OperationCall defaults;
        for (Operation& op : v)
            for (Modifier& m : op.modifiers) {
                m.info.default_value = m.get(defaults);
                op.info.modifiers.push_back(m.info);
            }
        return v;
    }();
    return ops;
}

const Operation* find(const std::string& name)
{
    for (const Operation& op : entries())
        if (op.info.name == name)
            return &op;
    return nullptr;
}

const Operation& find_or_throw(const std::string& name)
{
    if (const Operation* op = find(name))
        return *op;
    std::string known;
    for (const Operation& op : entries())
        known += (known.empty() ? "" : ", ") + op.info.name;
    throw std::invalid_argument("unknown operation '" + name + "' (known: " + known + ")");
}

}  // namespace relief::table

namespace relief {

using OIIO::ImageBuf;
using table::check_value;
using table::entries;
using table::find;
using table::find_or_throw;
using table::Modifier;
using table::Operation;
using table::word_prefix;

namespace {

// "key=value:key=value" -> pairs; fix=height:H0:DH keeps its colons.
std::vector<std::pair<std::string, std::string>> split(const Operation& op, const std::string& text)
{
    std::vector<std::pair<std::string, std::string>> kv;
    if (text.empty())
        return kv;
    std::size_t pos = 0;
    for (bool last = false; !last;) {
        const std::size_t next = text.find(':', pos);
        last = next == std::string::npos;
        const std::string item = text.substr(pos, last ? next : next - pos);
        pos = next + 1;
        const std::size_t eq = item.find('=');
        // A word with arguments (fix=height:H0:DH) takes the items after it.
        bool continues = false;
        if (eq == std::string::npos && !item.empty() && !kv.empty())
            for (const Modifier& m : op.modifiers)
                if (m.info.name == kv.back().first)
                    for (const auto& w : m.info.choices)
                        continues |= !word_prefix(w).empty() &&
                                     kv.back().second.rfind(w.substr(0, w.find(':')), 0) == 0;
        if (continues)
            kv.back().second += ":" + item;
        else if (item.empty() || eq == std::string::npos || eq == 0)
            throw std::invalid_argument("modifier '" + item + "' is not key=value");
        else
            kv.emplace_back(item.substr(0, eq), item.substr(eq + 1));
    }
    return kv;
}

void parse(OperationCall& call, const Operation& op,
           const std::vector<std::pair<std::string, std::string>>& modifiers)
{
    OperationCall c;
    c.operation = op.info.name;
    std::map<std::string, std::string> given;
    for (const auto& [key, value] : modifiers) {
        const Modifier* m = nullptr;
        for (const Modifier& candidate : op.modifiers)
            if (candidate.info.name == key)
                m = &candidate;
        if (!m) {
            std::string known;
            for (const Modifier& candidate : op.modifiers)
                known += (known.empty() ? "" : ", ") + candidate.info.name;
            throw std::invalid_argument("unknown modifier '" + key + "' (known: " + known + ")");
        }
        if (!given.emplace(key, value).second)
            throw std::invalid_argument("modifier '" + key + "' given twice");
        m->set(c, value, check_value(m->info, value));
    }
    if (op.finish)
        op.finish(c, given, op.modifiers);
    if (const std::string problem = op.validate(c); !problem.empty())
        throw std::invalid_argument(problem);
    call = std::move(c);
}

// The paths a call's modifiers of `type` name (Modifier::path): none for
// their words (alpha, none, sky, height:H0:DH) or an image given in memory.
std::vector<std::string> modifier_paths(const OperationCall& call, ModifierType type)
{
    std::vector<std::string> paths;
    const Operation* op = find(call.operation);
    if (!op)
        return paths;
    for (const Modifier& m : op->modifiers)
        if (m.info.type == type && m.path)
            if (std::string path = m.path(call); !path.empty())
                paths.push_back(std::move(path));
    return paths;
}

}  // namespace

std::string input_problem(const std::string& operation, const ImageSlot& slot, long long width,
                          long long height, long long channels, int bytes_per_channel)
{
    const std::string what = operation + ": input '" + slot.name + "'";
    if (width <= 0 || height <= 0)
        return what + " is " + std::to_string(width) + "x" + std::to_string(height) +
               " texels; both must be > 0";
    if (channels < slot.min_channels || channels > slot.max_channels)
        return what + " has " + std::to_string(channels) + " channel(s); " + operation + " takes " +
               std::to_string(slot.min_channels) + " to " + std::to_string(slot.max_channels);
    // (Both below hold for every operation: each indexes texels with 32-bit
    // ints, and each input is copied once before any work.)
    if (width > INT_MAX - 2 || height > INT_MAX - 2 || (width + 2) * (height + 2) > (long long)INT_MAX)
        return what + ": a " + std::to_string(width) + "x" + std::to_string(height) +
               " map is larger than this version handles ((width + 2) x (height + 2) must stay below "
               "2^31, e.g. 46338x46338)";
    if (bytes_per_channel > 0) {
        const auto bytes =
            host::Bytes(width) * host::Bytes(height) * host::Bytes(channels) * host::Bytes(bytes_per_channel);
        std::string why;
        try {
            why = host::refuse_host(bytes);
        } catch (const std::exception& e) {  // a malformed RELIEF_MEMORY_LIMIT
            why = e.what();
        }
        if (!why.empty())
            return what + " (" + std::to_string(width) + "x" + std::to_string(height) + "x" +
                   std::to_string(channels) + ") " + why + " to copy";
    }
    return "";
}

const std::vector<OperationInfo>& operations()
{
    static const std::vector<OperationInfo> infos = [] {
        std::vector<OperationInfo> v;
        for (const Operation& op : entries())
            v.push_back(op.info);
        return v;
    }();
    return infos;
}

const OperationInfo* find_operation(const std::string& name)
{
    for (const OperationInfo& op : operations())
        if (op.name == name)
            return &op;
    return nullptr;
}

bool parse_modifiers(OperationCall& call, const std::string& operation,
                     const std::vector<std::pair<std::string, std::string>>& modifiers)
{
    try {
        parse(call, find_or_throw(operation), modifiers);
        return true;
    } catch (const std::exception& e) {
        detail::set_error(e.what());
        return false;
    }
}

bool parse_modifiers(OperationCall& call, const std::string& operation, const std::string& modifiers)
{
    try {
        const Operation& op = find_or_throw(operation);
        parse(call, op, split(op, modifiers));
        return true;
    } catch (const std::exception& e) {
        detail::set_error(e.what());
        return false;
    }
}

namespace {

// The call with `exec` in every option struct (only the operation's is used).
OperationCall with_execution(const OperationCall& call, const Execution& exec)
{
    OperationCall c = call;
    c.slopes.exec = c.height.exec = c.correct.exec = c.bake.exec = exec;
    c.normals.exec = c.tessellation.exec = c.mesh.tessellation.exec = c.preview.exec = exec;
    return c;
}

// Reports 0, runs `run` with the operation's Execution (detail::paced:
// the heartbeat, a stage's own 1 held back), reports 1 when it succeeded:
// every operation reports both ends, also those too quick for steps of
// their own; a cancel asked at 0 stops it before any work, one asked at 1
// comes after it.
template <class Run>
bool with_progress_ends(const Execution& exec, Run run)
{
    if (exec.on_progress) {
        const detail::InCallback in;
        exec.on_progress(0.0);
    }
    if (!run(detail::paced(exec)))
        return false;
    if (exec.on_progress) {
        const detail::InCallback in;
        exec.on_progress(1.0);
    }
    return true;
}

}  // namespace

std::string memory_problem(const OperationCall& call, const std::string& device, long long width,
                           long long height)
{
    try {
        const Operation& op = find_or_throw(call.operation);
        if (width <= 0 || height <= 0 || width > INT_MAX - 2 || height > INT_MAX - 2)
            return "";          // (input_problem's to say)
        if (op.check_memory) {  // (the operation's own estimate says more)
            Execution exec;
            exec.device = device;
            op.check_memory(with_execution(call, exec), int(width), int(height));
        }
        if (!op.info.outputs.empty()) {
            const auto bytes = host::Bytes(width) * host::Bytes(height) *
                               host::Bytes(std::max(op.info.outputs[0].min_channels, 1)) * sizeof(float);
            if (const std::string why = host::refuse_host(bytes); !why.empty())
                return op.info.name + ": the " + std::to_string(width) + "x" + std::to_string(height) +
                       " result " + why;
        }
        return "";
    } catch (const std::exception& e) {
        return call.operation + ": " + e.what();
    }
}

std::string call_problem(const std::string& operation, std::size_t images)
{
    const Operation& op = find_or_throw(operation);
    if (images != op.info.inputs.size())
        return op.info.name + " takes " + std::to_string(op.info.inputs.size()) + " image(s), got " +
               std::to_string(images);
    return "";
}

std::string tiles_call_problem(const std::string& operation, std::size_t numbers, std::size_t images)
{
    const Operation& op = find_or_throw(operation);
    if (!op.run_tiles || op.info.inputs.size() != 1)
        return op.info.name + " does not take the tiles of a UDIM set at once";
    if (numbers < 1 || images < 1)
        return op.info.name + ": a UDIM set needs at least one tile, its number and its image";
    if (numbers != images)
        return op.info.name + ": " + std::to_string(numbers) + " tile number(s) for " +
               std::to_string(images) + " image(s)";
    return "";
}

std::string tiles_call_problem(const std::string& operation, const std::vector<int>& numbers,
                               std::size_t images)
{
    if (std::string why = tiles_call_problem(operation, numbers.size(), images); !why.empty())
        return why;
    std::set<int> seen;
    for (int n : numbers) {
        if (n < 1001 || n > 1999)
            return operation + ": UDIM tile numbers run from 1001 to 1999, got " + std::to_string(n);
        if (!seen.insert(n).second)
            return operation + ": UDIM tile " + std::to_string(n) + " is given twice";
    }
    return "";
}

bool run_operation(ImageBuf& dst, const OperationCall& call, const std::vector<const ImageBuf*>& inputs,
                   const Execution& exec)
{
    try {
        if (std::string why = detail::reentry_problem(); !why.empty())
            throw std::invalid_argument(std::move(why));
        const Operation& op = find_or_throw(call.operation);
        if (const std::string why = call_problem(op.info.name, inputs.size()); !why.empty())
            throw std::invalid_argument(why);
        // Channel counts are the operations' own to check (their messages say
        // what the channels mean); the C ABI and Python check them against the
        // table's slots before converting.
        for (std::size_t i = 0; i < inputs.size(); ++i)
            if (!inputs[i])
                throw std::invalid_argument(op.info.name + ": input '" + op.info.inputs[i].name +
                                            "' is missing (null)");
        // (The mask and fix files are read here, before the operation.)
        const detail::LibraryOutputSink library_output(detail::marked(exec.on_message));
        return with_progress_ends(
            exec, [&](const Execution& e) { return op.run(dst, with_execution(call, e), inputs); });
    } catch (const std::exception& e) {
        detail::set_error(e.what());
        return false;
    }
}

bool run_operation_on_tiles(std::vector<ImageBuf>& dst, const OperationCall& call,
                            const std::vector<int>& tiles, const std::vector<const ImageBuf*>& inputs,
                            const Execution& exec)
{
    dst.clear();
    try {
        if (std::string why = detail::reentry_problem(); !why.empty())
            throw std::invalid_argument(std::move(why));
        const Operation& op = find_or_throw(call.operation);
        if (const std::string why = tiles_call_problem(op.info.name, tiles, inputs.size()); !why.empty())
            throw std::invalid_argument(why);
        for (const ImageBuf* in : inputs)
            if (!in)
                throw std::invalid_argument(op.info.name + ": a tile's image is missing (null)");
        return with_progress_ends(exec, [&](const Execution& e) {
            return op.run_tiles(dst, with_execution(call, e), tiles, inputs);
        });
    } catch (const std::exception& e) {
        detail::set_error(e.what());
        return false;
    }
}

OperationCall without_files_read(const OperationCall& call)
{
    OperationCall c = call;
    if (const Operation* op = find(call.operation))
        for (const Modifier& m : op->modifiers)
            if (m.info.type == ModifierType::File && m.path && !m.path(c).empty())
                m.set(c, m.info.default_value, 0.0);
    return c;
}

std::vector<std::string> files_read(const OperationCall& call)
{
    return modifier_paths(call, ModifierType::File);
}

std::vector<std::string> files_written(const OperationCall& call)
{
    return modifier_paths(call, ModifierType::Output);
}

bool sets_up_ahead(const OperationCall& call)
{
    const Operation* op = find(call.operation);
    return op && op->sets_up_ahead && op->sets_up_ahead(call);
}

bool joins_tiles(const OperationCall& call)
{
    const Operation* op = find(call.operation);
    return op && op->joins_tiles && op->joins_tiles(call);
}

std::string describe(const OperationCall& call)
{
    const Operation* op = find(call.operation);
    return op && op->describe ? op->describe(call) : std::string();
}

std::string modifier_text(const OperationCall& call)
{
    std::string text;
    for (const Modifier& m : find_or_throw(call.operation).modifiers)
        text += (text.empty() ? "" : ":") + m.info.name + "=" + m.get(call);
    return text;
}

}  // namespace relief
