// SPDX-License-Identifier: Apache-2.0
/* The C ABI's contract, checked from C against an installed relief: built
 * linked (pkg-config) and, with -DRELIEF_DLOPEN, loading the library by
 * path (argv[1]) through relief_plugin_entry. Exit 0 when every check holds. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "relief/relief_c.h"

#ifdef RELIEF_DLOPEN
#include <dlfcn.h>
#endif

static int failures = 0;
#define CHECK(cond, what)                                                                                    \
    do {                                                                                                     \
        if (!(cond)) {                                                                                       \
            fprintf(stderr, "c_abi_checks: FAILED: %s (%s)\n", what, #cond);                                 \
            ++failures;                                                                                      \
        }                                                                                                    \
    } while (0)

static void refused(const relief_plugin* r, const char* op, const char* mods, const relief_image* in, int n,
                    const char* needle)
{
    relief_image out;
    memset(&out, 0x5a, sizeof out);
    int status = r->run(op, mods, in, n, &out);
    const char* e = r->last_error();
    fprintf(stderr, "c_abi_checks: %s:%s refused: %s\n", op, mods ? mods : "", e);
    CHECK(status == RELIEF_INVALID, needle);
    CHECK(e && strstr(e, needle) != NULL, needle);
    CHECK(out.pixels == NULL && out.metadata == NULL && out.width == 0, "a refused run zeroes its output");
}

/* What a host hears through relief_callbacks. */
typedef struct heard {
    int messages[5];    /* per relief_severity */
    int progress_calls; /* calls of progress */
    double first, last; /* the fractions reported first and last */
    int falls;          /* reports below the one before */
    int cancel_at;      /* answer non-zero at this call (0: never) */
    int calls_after;    /* progress calls after the one that cancelled */
    char error[512];    /* the RELIEF_ERROR message */
} heard;

static void on_message(int severity, const char* text, void* user)
{
    heard* h = (heard*)user;
    if (severity >= 0 && severity <= 4)
        ++h->messages[severity];
    if (severity == RELIEF_ERROR)
        snprintf(h->error, sizeof h->error, "%s", text);
}

static int on_progress(double fraction, void* user)
{
    heard* h = (heard*)user;
    if (h->cancel_at && h->progress_calls >= h->cancel_at)
        ++h->calls_after;
    if (h->progress_calls == 0)
        h->first = fraction;
    else if (fraction < h->last)
        ++h->falls;
    h->last = fraction;
    ++h->progress_calls;
    return h->cancel_at && h->progress_calls == h->cancel_at;
}

int main(int argc, char** argv)
{
    const relief_plugin* r;
#ifdef RELIEF_DLOPEN
    if (argc != 2)
        return 2;
    void* module = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!module) {
        fprintf(stderr, "c_abi_checks: %s\n", dlerror());
        return 2;
    }
    const relief_plugin* (*entry)(void) =
        (const relief_plugin* (*)(void))dlsym(module, "relief_plugin_entry");
    CHECK(entry != NULL, "relief_plugin_entry is exported");
    if (!entry)
        return 1;
    r = entry();
#else
    (void)argc;
    (void)argv;
    r = relief_plugin_entry();
    CHECK(r->run == relief_run && r->last_error == relief_last_error, "the entry holds the C functions");
#endif
    CHECK(r->abi_version() == 2, "ABI version 2");
    const char* json = r->operations_json();
    CHECK(strstr(json, "\"name\": \"height\"") && strstr(json, "\"name\": \"correct\""),
          "the table lists height and correct");
    const char* rays = strstr(json, "\"name\": \"rays\"");
    CHECK(rays && strstr(rays, "\"type\": \"integer\"") &&
              strstr(rays, "\"type\": \"integer\"") < strstr(rays, "}"),
          "the table types rays");

    /* a 16x16 8-bit normal map with a bump */
    enum { W = 16, H = 16 };
    unsigned char px[W * H * 3];
    for (int i = 0; i < W * H; ++i) {
        int x = i % W, y = i / W;
        px[3 * i] = (unsigned char)(x > 5 && x < 10 ? 150 : 128);
        px[3 * i + 1] = (unsigned char)(y > 5 && y < 10 ? 110 : 128);
        px[3 * i + 2] = 255;
    }
    relief_image normals = {W, H, 3, RELIEF_UINT8, px, NULL};

    refused(r, "height", "rays=-3", &normals, 1, "rays=-3 must be an integer in [1, 4096]");
    refused(r, "height", "normal=sideways", &normals, 1, "normal=sideways is not one of");
    refused(r, "height", "rays", &normals, 1, "is not key=value");
    refused(r, "frobnicate", "", &normals, 1, "unknown operation 'frobnicate'");
    refused(r, "bake", "", &normals, 1, "bake takes 2 image(s), got 1");
    unsigned char seven[W * H * 7];
    memset(seven, 128, sizeof seven);
    relief_image wide = {W, H, 7, RELIEF_UINT8, seven, NULL};
    refused(r, "height", "", &wide, 1, "has 7 channel(s); height takes 2 to 4");
    relief_image bad_type = {W, H, 3, (relief_type)9, px, NULL};
    refused(r, "height", "", &bad_type, 1, "unknown pixel type 9");
    relief_image empty = {0, H, 3, RELIEF_UINT8, px, NULL};
    refused(r, "height", "", &empty, 1, "both must be > 0");
    CHECK(r->run("height", "", &normals, 1, NULL) == RELIEF_INVALID, "a NULL output is refused");
    /* Sizes are refused before a pixel is read: each image below claims far
     * more pixels than `px` holds, so a copy would read past it. */
    relief_image huge = {100000, 100000, 3, RELIEF_UINT8, px, NULL};
    refused(r, "height", "", &huge, 1, "a 100000x100000 map is larger than this version handles");
    relief_image tall = {1, 2147483647, 3, RELIEF_UINT8, px, NULL};
    refused(r, "height", "", &tall, 1, "a 1x2147483647 map is larger than this version handles");
    setenv("RELIEF_MEMORY_LIMIT", "64M", 1);
    relief_image big = {8000, 8000, 3, RELIEF_FLOAT, px, NULL};
    refused(r, "height", "", &big, 1,
            "(8000x8000x3) needs 732.4 MiB of memory, RELIEF_MEMORY_LIMIT=64M allows 64.0 MiB to copy");
    unsetenv("RELIEF_MEMORY_LIMIT");

    relief_image h;
    CHECK(r->run("height", "normal=opengl:boundary=periodic", &normals, 1, &h) == RELIEF_OK, "height runs");
    CHECK(strcmp(r->last_error(), "") == 0, "success leaves no error");
    CHECK(h.width == W && h.height == H && h.channels == 1 && h.type == RELIEF_FLOAT,
          "height is 1 float channel");
    CHECK(h.metadata && strstr(h.metadata, "relief:method=poisson\n"), "the result's metadata");
    float lo = 1e30f, hi = -1e30f;
    for (int i = 0; i < W * H; ++i) {
        float v = ((float*)h.pixels)[i];
        lo = v < lo ? v : lo;
        hi = v > hi ? v : hi;
    }
    CHECK(hi - lo > 0.5f, "the bump has relief");

    /* height -> correct (scale=auto reads the height's metadata) -> bake */
    relief_image off;
    CHECK(r->run("correct", "levels=1:iterations=2", &h, 1, &off) == RELIEF_OK,
          "correct runs on relief's height");
    if (off.pixels) {
        CHECK(off.channels == 2 && strstr(off.metadata, "relief:boundary=periodic\n"),
              "offsets say their boundary");
        relief_image both[2] = {normals, off};
        relief_image baked;
        CHECK(r->run("bake", NULL, both, 2, &baked) == RELIEF_OK, "bake runs");
        CHECK(baked.channels == 3, "bake keeps the texture's channels");
        r->image_free(&baked);
        r->image_free(&off);
    }
    relief_image plain = h;
    plain.metadata = NULL;
    CHECK(r->run("correct", "", &plain, 1, &off) == RELIEF_FAILED, "without metadata correct needs a scale");
    CHECK(strstr(r->last_error(), "scale") != NULL, "and says so");
    r->image_free(&h);
    CHECK(h.pixels == NULL && h.metadata == NULL, "image_free zeroes the image");

    /* the output may be the input: it is written only after the input is read */
    relief_image same = normals;
    same.pixels = malloc(sizeof px);
    memcpy(same.pixels, px, sizeof px);
    void* input_pixels = same.pixels;
    CHECK(r->run("height", "normal=opengl", &same, 1, &same) == RELIEF_OK, "output over its own input");
    CHECK(same.channels == 1 && same.type == RELIEF_FLOAT && same.pixels != input_pixels,
          "the result replaced it");
    free(input_pixels);
    r->image_free(&same);
    r->image_free(NULL);

    /* callbacks: messages at their severity, progress from 0 to 1 */
    heard h1;
    memset(&h1, 0, sizeof h1);
    relief_callbacks cb = {on_message, on_progress, &h1};
    relief_image told;
    CHECK(r->run_with("auto", "height", "normal=auto", &normals, 1, &told, &cb) == RELIEF_OK,
          "run_with runs");
    CHECK(h1.messages[RELIEF_NOTICE] >= 1, "the detected convention is a notice");
    CHECK(h1.messages[RELIEF_INFO] >= 1, "details are info");
    CHECK(h1.messages[RELIEF_ERROR] == 0, "no error");
    CHECK(h1.progress_calls >= 2 && h1.first == 0.0 && h1.last == 1.0 && h1.falls == 0,
          "progress rises from 0 to 1");
    r->image_free(&told);
    CHECK(r->run_with("auto", "height", NULL, &normals, 1, &told, NULL) == RELIEF_OK, "NULL callbacks: none");
    r->image_free(&told);
    relief_callbacks empty_cb = {NULL, NULL, NULL};
    CHECK(r->run_with("auto", "height", NULL, &normals, 1, &told, &empty_cb) == RELIEF_OK,
          "NULL members: none");
    r->image_free(&told);

    /* cancel: a long correction stops at the progress call that answers 1 */
    enum { CW = 96, CH = 96 };
    float* steep = malloc(sizeof(float) * CW * CH);
    for (int i = 0; i < CW * CH; ++i)
        steep[i] = (float)((i % CW) % 16 < 8 ? 1.0 : 0.0) * 0.5f + (float)((i / CW) % 24) / 48.0f;
    relief_image cliff = {CW, CH, 1, RELIEF_FLOAT, steep, NULL};
    heard h2;
    memset(&h2, 0, sizeof h2);
    h2.cancel_at = 4;
    relief_callbacks stop = {on_message, on_progress, &h2};
    relief_image never;
    memset(&never, 0x5a, sizeof never);
    CHECK(r->run_with("auto", "correct", "scale=0.2:levels=1:iterations=500", &cliff, 1, &never, &stop) ==
              RELIEF_CANCELLED,
          "a non-zero progress answer cancels");
    CHECK(never.pixels == NULL && never.metadata == NULL && never.width == 0,
          "a cancelled run leaves no image");
    CHECK(strstr(r->last_error(), "correct: cancelled") != NULL, "and says it was cancelled");
    CHECK(h2.messages[RELIEF_ERROR] == 1 && strcmp(h2.error, r->last_error()) == 0,
          "the message callback hears why, once");
    CHECK(h2.progress_calls == 4 && h2.calls_after == 0, "no progress after the cancel");
    /* cancelled at the first report: before any work */
    memset(&h2, 0, sizeof h2);
    h2.cancel_at = 1;
    CHECK(r->run_with("auto", "correct", "scale=0.2", &cliff, 1, &never, &stop) == RELIEF_CANCELLED,
          "cancelled at 0");
    CHECK(h2.progress_calls == 1 && h2.messages[RELIEF_INFO] == 0, "before any work");
    free(steep);

#ifndef RELIEF_DLOPEN
    /* the device, chosen: one that does not exist fails naming it; the CPU runs */
    relief_image on;
    CHECK(relief_run_on("9:9", "height", "normal=opengl", &normals, 1, &on) == RELIEF_FAILED,
          "no device 9:9");
    CHECK(strstr(relief_last_error(), "9:9") != NULL, "the message names the device");
    CHECK(on.pixels == NULL, "a failed run leaves no image");
    /* NULL or "" is "auto", as relief_run: the same bits */
    relief_image automatic, null_device, empty_device;
    CHECK(relief_run("height", "normal=opengl", &normals, 1, &automatic) == RELIEF_OK, "auto runs");
    CHECK(relief_run_on(NULL, "height", "normal=opengl", &normals, 1, &null_device) == RELIEF_OK,
          "a NULL device is auto");
    CHECK(relief_run_with("", "height", "normal=opengl", &normals, 1, &empty_device, NULL) == RELIEF_OK,
          "an empty device is auto");
    CHECK(null_device.pixels && empty_device.pixels && automatic.pixels &&
              memcmp(null_device.pixels, automatic.pixels, sizeof(float) * W * H) == 0 &&
              memcmp(empty_device.pixels, automatic.pixels, sizeof(float) * W * H) == 0,
          "the same height as auto's");
    relief_image_free(&automatic);
    relief_image_free(&null_device);
    relief_image_free(&empty_device);
    CHECK(relief_run_on("cpu", "height", "normal=opengl", &normals, 1, &on) == RELIEF_OK, "the CPU runs");
    relief_image_free(&on);
#endif
    if (failures == 0)
        printf("c_abi_checks: all checks hold\n");
    return failures == 0 ? 0 : 1;
}
