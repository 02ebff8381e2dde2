// SPDX-License-Identifier: Apache-2.0
/* relief's C ABI: plain C types, no exception crosses it, stable across
 * releases: a version only adds (functions, and members at the end of
 * relief_plugin), so a host built for version N runs with any library whose
 * relief_abi_version() is N or more (the soname stays librelief.so.1). A
 * host links librelief (or
 * dlopen()s it by path and calls relief_plugin_entry()), lists the
 * operations with relief_operations_json() and runs them with relief_run().
 *
 * Every function may be called from any thread; errors are per thread.
 *
 *     relief_image in = {512, 512, 3, RELIEF_UINT8, pixels};
 *     relief_image out;
 *     if (relief_run("height", "normal=opengl:boundary=periodic", &in, 1, &out) != RELIEF_OK)
 *         fprintf(stderr, "%s\n", relief_last_error());
 *     ... out.pixels: out.width * out.height * out.channels floats ...
 *     relief_image_free(&out);
 */
#ifndef RELIEF_C_H
#define RELIEF_C_H

#include "relief/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/* 1: relief_run, relief_run_on, relief_run_tiles. 2: relief_run_with
 * (messages, progress and cancel), RELIEF_CANCELLED, relief_plugin.run_with. */
#define RELIEF_ABI_VERSION 2

/* Pixel types. Integers are UNORM (code / 255 or / 65535), decoded exactly
 * as the command line decodes a file of that type; RELIEF_HALF pixels are
 * IEEE binary16 bit patterns. */
typedef enum relief_type {
    RELIEF_UINT8 = 1,
    RELIEF_UINT16 = 2,
    RELIEF_HALF = 3,
    RELIEF_FLOAT = 4
} relief_type;

/* An image: row-major, top row first, channels interleaved. `metadata` is
 * optional: NULL (zero-initialise the struct, as `relief_image in = {w, h, c,
 * type, pixels};` does), or "key=value" lines. On output it
 * holds the result's relief:* attributes (relief:method, relief:boundary,
 * ...); on input such lines are attached to the image, so the offsets from
 * "correct" tell "bake" (wrap=auto) how they were made. */
typedef struct relief_image {
    int width, height, channels;
    relief_type type;
    void* pixels;
    char* metadata;
} relief_image;

/* Status codes of relief_run. */
enum {
    RELIEF_OK = 0,
    RELIEF_INVALID = 1,  /* the operation, a modifier or an input was refused before any work */
    RELIEF_FAILED = 2,   /* the operation refused its images (e.g. correct without a scale for a
                           height that is not relief's) or failed (device, memory, a mask file) */
    RELIEF_CANCELLED = 3 /* the host's progress callback asked to stop (relief_run_with) */
};

/* How much a message matters (relief_callbacks.message). */
typedef enum relief_severity {
    RELIEF_DEBUG = 0,   /* what the libraries relief uses said (the image library's diagnostics) */
    RELIEF_INFO = 1,    /* details: the device, what a stage chose, counts, times */
    RELIEF_NOTICE = 2,  /* a choice made for the caller that they should see (the detected
                           green convention, a boundary found by boundary=auto) */
    RELIEF_WARNING = 3, /* likely trouble: an ambiguous convention, NaNs replaced, float
                           normals that look unsigned */
    RELIEF_ERROR = 4    /* why the run failed: what relief_last_error() then returns */
} relief_severity;

/* What a host hears from relief_run_with. Any member may be NULL. Both
 * functions are called on the thread that called relief_run_with, during
 * the call; `text` is valid only during the call; `user` is passed back.
 * relief itself writes nothing to stdout or stderr: without a message
 * callback its messages go nowhere (the result's metadata keeps what the
 * operation chose).
 *   message:  one line of text, `severity` a relief_severity.
 *   progress: `fraction` done, 0 first and 1 last, never falling; while
 *             the operation works, called at least every 50 ms that a
 *             kernel or a pass is started (the last fraction again where
 *             a stage has no finer measure). Returning non-zero cancels:
 *             relief stops before the next kernel or pass, frees what it
 *             holds, writes no output and returns RELIEF_CANCELLED
 *             (bench_cancel, 1024^2, a 2-core CPU device: within half a
 *             second in every operation). The call with 1 comes once the
 *             result is complete: a non-zero answer to it cancels nothing,
 *             and the call returns RELIEF_OK.
 * A callback may not run relief itself on that thread (the running call
 * holds the device): such a call returns RELIEF_INVALID at once, saying
 * why, and the outer call goes on; another thread's call waits its turn.
 * Whatever a callback does, relief_last_error() after the outer call is
 * the outer call's. */
typedef struct relief_callbacks {
    void (*message)(int severity, const char* text, void* user);
    int (*progress)(double fraction, void* user);
    void* user;
} relief_callbacks;

/* RELIEF_ABI_VERSION of the library actually loaded. */
RELIEF_API int relief_abi_version(void);

/* The operation table as JSON: {"abi_version": 2, "operations": [{"name",
 * "summary", "inputs", "outputs", "modifiers": [{"name", "type" (choice,
 * integer, number, file), "choices", "min", "max", "min_open", "max_open",
 * "unit", "default", "applies_to", "meaning"}]}]}. Owned by the library. */
RELIEF_API const char* relief_operations_json(void);

/* Runs `operation` ("slopes", "height", "correct", "bake") on the default
 * OpenCL device (a GPU if there is one, else the CPU) with `modifiers`
 * written as on the command line ("key=value:key=value"; NULL or "" for the
 * defaults) on `n_inputs` images (as many as the operation takes, in its
 * order: bake takes the texture, then the offsets; `output` may point at
 * one of them, it is only written after they are read). On RELIEF_OK `output`
 * holds a new RELIEF_FLOAT image (free it with relief_image_free); otherwise
 * `output` is zeroed and relief_last_error() says why. */
RELIEF_API int relief_run(const char* operation, const char* modifiers, const relief_image* inputs,
                          int n_inputs, relief_image* output);

/* relief_run on a chosen OpenCL device: "auto" (what relief_run uses: a GPU
 * if there is one, else the CPU; NULL or "" mean "auto" too), "gpu", "cpu",
 * or "<platform>:<device>" as `relief --list-devices` numbers them. A device
 * that does not exist fails the run (RELIEF_FAILED) with a message naming
 * it. */
RELIEF_API int relief_run_on(const char* device, const char* operation, const char* modifiers,
                             const relief_image* inputs, int n_inputs, relief_image* output);

/* relief_run_on with a host's callbacks (NULL: none, as relief_run_on).
 * `device` as relief_run_on. Added in ABI version 2. */
RELIEF_API int relief_run_with(const char* device, const char* operation, const char* modifiers,
                               const relief_image* inputs, int n_inputs, relief_image* output,
                               const relief_callbacks* callbacks);

/* Runs `operation` once over the `n_tiles` tiles of a UDIM set
 * ("height": udim=auto|joint|each, see relief/udim.h): tiles[i] is the number
 * of inputs[i] (1001 + u + 10 v, v up: 1011 sits above 1001), and on RELIEF_OK
 * outputs[i] (an array of n_tiles images) holds its result, each freed with
 * relief_image_free. `device` as relief_run_on. On failure every output is
 * zeroed and relief_last_error() says why. Added within ABI version 1 (the
 * library's soname): a host that dlopen()s a library that may predate it
 * looks it up with dlsym(). */
RELIEF_API int relief_run_tiles(const char* device, const char* operation, const char* modifiers,
                                const int* tiles, const relief_image* inputs, int n_tiles,
                                relief_image* outputs);

/* Frees the pixels and metadata of an image relief_run made; zeroes it. */
RELIEF_API void relief_image_free(relief_image* image);

/* The message of this thread's last failed call ("" if none), as the
 * command line would print it. Valid until the thread's next relief call. */
RELIEF_API const char* relief_last_error(void);

/* The same functions, for hosts that dlopen() the library by path. */
typedef struct relief_plugin {
    int (*abi_version)(void);
    const char* (*operations_json)(void);
    int (*run)(const char*, const char*, const relief_image*, int, relief_image*);
    void (*image_free)(relief_image*);
    const char* (*last_error)(void);
    /* ABI version 2 on: read only when abi_version() >= 2 */
    int (*run_with)(const char*, const char*, const char*, const relief_image*, int, relief_image*,
                    const relief_callbacks*);
} relief_plugin;

RELIEF_API const relief_plugin* relief_plugin_entry(void);

#ifdef __cplusplus
}
#endif

#endif /* RELIEF_C_H */
