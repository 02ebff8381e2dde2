// SPDX-License-Identifier: Apache-2.0
// Exclusive temporary files, renamed over their targets when complete.
#include "relief/output_files.h"

#include <atomic>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <system_error>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include "error_state.h"
#include "temporary_file.h"

namespace fs = std::filesystem;

namespace relief {

namespace {

constexpr char kMarker[] = ".relief-tmp-";
constexpr std::size_t kNameCut = 80;

// The files being written now, for remove_temporary_files() in a signal
// handler: fixed storage, lock-free flags, nothing allocated. A slot is
// filled before its file is created and cleared after it is renamed or
// removed, so every temporary file on disk is in a slot.
enum SlotState : int { kFree = 0, kFilling = 1, kLive = 2 };
struct Slot {
    std::atomic<int> state{kFree};
    char path[PATH_MAX];
};
constexpr int kSlots = 64;
Slot g_slots[kSlots];
static_assert(std::atomic<int>::is_always_lock_free, "signal-safe flags");

int take_slot(const std::string& path)
{
    if (path.size() >= PATH_MAX)
        return -1;
    for (int i = 0; i < kSlots; ++i) {
        int expected = kFree;
        if (g_slots[i].state.compare_exchange_strong(expected, kFilling)) {
            std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
            g_slots[i].state.store(kLive, std::memory_order_release);
            return i;
        }
    }
    return -1;  // more than kSlots at once: written as well, not removed on a signal
}

void free_slot(int slot)
{
    if (slot >= 0)
        g_slots[slot].state.store(kFree, std::memory_order_release);
}

bool in_a_slot(const std::string& path)
{
    for (Slot& s : g_slots)
        if (s.state.load(std::memory_order_acquire) == kLive && path == s.path)
            return true;
    return false;
}

// The host's name as it goes into file names: '-' separates the fields.
std::string host_field()
{
    char name[HOST_NAME_MAX + 1] = {};
    if (::gethostname(name, sizeof name - 1) != 0 || !name[0])
        return "host";
    std::string s(name);
    for (char& c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_'))
            c = '_';
    return s.substr(0, 64);
}

// The PID namespace's inode: processes in two containers may share a PID.
std::string pid_namespace_field()
{
    struct stat st {};
    if (::stat("/proc/self/ns/pid", &st) != 0)
        return "0";
    return std::to_string(static_cast<unsigned long long>(st.st_ino));
}

// The target's file name, cut to kNameCut bytes at a character boundary.
std::string name_field(const fs::path& target)
{
    std::string n = target.filename().string();
    if (n.size() > kNameCut) {
        std::size_t cut = kNameCut;
        while (cut > 0 && (static_cast<unsigned char>(n[cut]) & 0xC0) == 0x80)
            --cut;  // not inside a UTF-8 sequence
        n.resize(cut);
    }
    return n;
}

std::string random_field()
{
    static std::mutex m;
    static std::random_device device;
    static std::mt19937_64 bits(((std::uint64_t)device() << 32) ^ device());
    std::lock_guard<std::mutex> lock(m);
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(bits()));
    return hex;
}

fs::path folder_of(const fs::path& target)
{
    return target.parent_path().empty() ? fs::path(".") : target.parent_path();
}

// Once per folder and process: a batch writes thousands of files into one.
void sweep_once(const fs::path& folder)
{
    static std::mutex m;
    static std::set<std::string> swept;
    std::error_code ec;
    const std::string key = fs::weakly_canonical(folder, ec).string();
    {
        std::lock_guard<std::mutex> lock(m);
        if (!swept.insert(ec ? folder.string() : key).second)
            return;
    }
    remove_stale_temporary_files(folder.string());
}

std::string errno_text(int e)
{
    return std::strerror(e ? e : EIO);
}

}  // namespace

void remove_temporary_files() noexcept
{
    for (Slot& s : g_slots)
        if (s.state.load(std::memory_order_acquire) == kLive)
            ::unlink(s.path);
}

int remove_stale_temporary_files(const std::string& folder)
{
    static const std::string host = host_field(), pidns = pid_namespace_field();
    const long self = static_cast<long>(::getpid());
    int removed = 0;
    std::error_code ec;
    for (fs::directory_iterator it(folder.empty() ? "." : folder, ec), end; !ec && it != end;
         it.increment(ec)) {
        const std::string name = it->path().filename().string();
        const std::size_t at = name.rfind(kMarker);
        if (name.empty() || name[0] != '.' || at == std::string::npos)
            continue;
        // HOST-PIDNS-PID-RANDOM, HOST without '-'.
        const std::string tail = name.substr(at + sizeof kMarker - 1);
        std::size_t a = tail.find('-'), b = a == std::string::npos ? a : tail.find('-', a + 1),
                    c = b == std::string::npos ? b : tail.find('-', b + 1);
        if (c == std::string::npos || tail.find('-', c + 1) != std::string::npos)
            continue;
        if (tail.compare(0, a, host) != 0 || a != host.size() || tail.substr(a + 1, b - a - 1) != pidns)
            continue;
        const std::string pid_text = tail.substr(b + 1, c - b - 1);
        if (pid_text.empty() || pid_text.find_first_not_of("0123456789") != std::string::npos ||
            pid_text.size() > 9)
            continue;
        const long pid = std::stol(pid_text);
        const std::string path = it->path().string();
        // This process's own name on a file it is not writing: an earlier
        // process of the same PID (a restarted container) left it.
        const bool gone = pid == self ? !in_a_slot(path) : (::kill(pid_t(pid), 0) != 0 && errno == ESRCH);
        std::error_code rm;
        if (gone && fs::remove(it->path(), rm))
            ++removed;
    }
    return removed;
}

std::string output_name_problem(const std::string& path)
{
    if (path.empty())
        return "an empty output name";
    if (path.find('\0') != std::string::npos)
        return "'" + std::string(path.c_str()) + "...': the name holds a NUL byte";
    const fs::path target(path);
    const std::string name = target.filename().string();
    if (name.empty() || name == "." || name == "..")
        return "'" + path + "': not a file name";
    const long longest = ::pathconf(folder_of(target).c_str(), _PC_NAME_MAX);
    const std::size_t limit = longest > 0 ? std::size_t(longest) : std::size_t(NAME_MAX);
    if (name.size() > limit)
        return "'" + path + "': the file name is " + std::to_string(name.size()) +
               " bytes, longer than its file system allows (" + std::to_string(limit) + ")";
    if (path.size() >= PATH_MAX)
        return "'" + path.substr(0, 60) + "...': the path is " + std::to_string(path.size()) +
               " bytes, longer than the system allows (" + std::to_string(PATH_MAX - 1) + ")";
    // An output replaces its file (a temporary file renamed over it): over a
    // device node, a FIFO or a socket that would take the node away (run as
    // root, --report /dev/null would remove /dev/null from the machine), and
    // appending to one (--log) can block forever. Folders are their callers'
    // to refuse, with their own words. stat() follows links: a link to a
    // device is refused too.
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode)) {
        const char* kind = S_ISCHR(st.st_mode)    ? "a character device"
                           : S_ISBLK(st.st_mode)  ? "a block device"
                           : S_ISFIFO(st.st_mode) ? "a FIFO"
                           : S_ISSOCK(st.st_mode) ? "a socket"
                                                  : "not a regular file";
        return "'" + path + "': it is " + std::string(kind) +
               "; relief writes only regular files or new names (it would replace the node)";
    }
    return "";
}

bool write_text_file(const std::string& path, const std::string& text)
{
    try {
        if (const std::string why = output_name_problem(path); !why.empty())
            throw std::runtime_error(why);
        detail::TemporaryFile tmp(path);
        std::FILE* f = tmp.stream();
        if (std::fwrite(text.data(), 1, text.size(), f) != text.size())
            throw std::runtime_error(errno_text(errno));
        tmp.close();
        tmp.commit();
        return true;
    } catch (const std::exception& e) {
        detail::set_error("cannot write '" + path + "': " + e.what());
        return false;
    }
}

namespace detail {

TemporaryFile::TemporaryFile(const fs::path& target) : target_(target)
{
    static const std::string host = host_field(), pidns = pid_namespace_field();
    const fs::path folder = folder_of(target);
    sweep_once(folder);
    for (int attempt = 0; attempt < 8; ++attempt) {
        path_ = folder / ("." + name_field(target) + kMarker + host + "-" + pidns + "-" +
                          std::to_string(::getpid()) + "-" + random_field());
        slot_ = take_slot(path_.string());
        fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd_ >= 0)
            return;
        const int e = errno;
        free_slot(slot_);  // the name may be another's: never remove it
        slot_ = -1;
        if (e != EEXIST)
            throw std::runtime_error(errno_text(e));
    }
    throw std::runtime_error("no free temporary name in '" + folder.string() + "'");
}

TemporaryFile::~TemporaryFile()
{
    if (stream_)
        std::fclose(stream_);
    else if (fd_ >= 0)
        ::close(fd_);
    if (!committed_)
        ::unlink(path_.c_str());
    free_slot(slot_);
}

std::FILE* TemporaryFile::stream()
{
    if (!stream_ && fd_ >= 0) {
        stream_ = ::fdopen(fd_, "wb");
        if (!stream_)
            throw std::runtime_error(errno_text(errno));
        fd_ = -1;
    }
    return stream_;
}

void TemporaryFile::close()
{
    int err = 0;
    if (stream_) {
        if (std::ferror(stream_) || std::fflush(stream_) != 0)
            err = errno ? errno : EIO;
        if (::fsync(::fileno(stream_)) != 0 && !err)
            err = errno;
        if (std::fclose(stream_) != 0 && !err)
            err = errno;
        stream_ = nullptr;
    } else if (fd_ >= 0) {
        if (::fsync(fd_) != 0)
            err = errno;
        if (::close(fd_) != 0 && !err)
            err = errno;
        fd_ = -1;
    }
    if (err)
        throw std::runtime_error(errno_text(err));
}

void TemporaryFile::commit()
{
    close();
    if (::rename(path_.c_str(), target_.c_str()) != 0)
        throw std::runtime_error("rename to '" + target_.string() + "' failed: " + errno_text(errno));
    committed_ = true;
    free_slot(slot_);
    slot_ = -1;
}

}  // namespace detail

}  // namespace relief
