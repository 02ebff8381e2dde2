// SPDX-License-Identifier: Apache-2.0
// open(2) and open64 interposed in the test executable (see taken_names.h).
// Linked into the executable, these definitions come before the C
// library's for every shared object of the process, librelief's calls
// included; anything but a taken temporary name goes on to the next
// definition (the C library's, or a sanitizer's interceptor).
#undef _FORTIFY_SOURCE
#include "support/taken_names.h"

#include <dlfcn.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdarg>
#include <cstring>
#include <mutex>

namespace relief::test {
namespace {

std::mutex taken_mutex;
int names_left = 0;
std::vector<std::string> names_taken;

// Whether this exclusive create of `path` is to find its name taken.
bool take(const char* path, int flags)
{
    if (!(flags & O_CREAT) || !(flags & O_EXCL) || !std::strstr(path, ".relief-tmp-"))
        return false;
    std::lock_guard<std::mutex> lock(taken_mutex);
    if (names_left <= 0)
        return false;
    --names_left;
    names_taken.push_back(path);
    return true;
}

using Open = int (*)(const char*, int, ...);

int open_next(const char* name, const char* path, int flags, mode_t mode)
{
    static const Open next_open = reinterpret_cast<Open>(dlsym(RTLD_NEXT, "open"));
    static const Open next_open64 = reinterpret_cast<Open>(dlsym(RTLD_NEXT, "open64"));
    const Open next = name[4] == '6' ? next_open64 : next_open;
    if (take(path, flags)) {
        // Made by "the other writer": left behind, this process's create fails.
        const int fd = next(path, flags, mode);
        if (fd >= 0)
            ::close(fd);
        errno = EEXIST;
        return -1;
    }
    return next(path, flags, mode);
}

}  // namespace

void take_temporary_names(int n)
{
    std::lock_guard<std::mutex> lock(taken_mutex);
    names_left = n;
    names_taken.clear();
}

std::vector<std::string> temporary_names_taken()
{
    std::lock_guard<std::mutex> lock(taken_mutex);
    return names_taken;
}

}  // namespace relief::test

// The mode argument of open(2): there only when the flags create a file.
#define RELIEF_OPEN_MODE(flags, mode)                                                                        \
    mode_t mode = 0;                                                                                         \
    if (((flags)&O_CREAT) || ((flags)&O_TMPFILE) == O_TMPFILE) {                                             \
        va_list ap;                                                                                          \
        va_start(ap, flags);                                                                                 \
        mode = mode_t(va_arg(ap, int));                                                                      \
        va_end(ap);                                                                                          \
    }

extern "C" {

int open(const char* path, int flags, ...)
{
    RELIEF_OPEN_MODE(flags, mode)
    return relief::test::open_next("open", path, flags, mode);
}

int open64(const char* path, int flags, ...)
{
    RELIEF_OPEN_MODE(flags, mode)
    return relief::test::open_next("open64", path, flags, mode);
}

}  // extern "C"
