// SPDX-License-Identifier: Apache-2.0
/* A host that uses relief through its C ABI only: lists the operations and
 * runs one on a binary PPM (8 or 16 bits per channel), writing a PFM.
 *
 * Linked (cc plugin_host.c $(pkg-config --cflags --libs relief)):
 *     plugin_host --list
 *     plugin_host OPERATION MODIFIERS IN.ppm OUT.pfm
 * Loading the module by path, as a plugin host does (cc -DRELIEF_DLOPEN
 * plugin_host.c -I<prefix>/include -ldl):
 *     plugin_host /usr/lib/x86_64-linux-gnu/librelief.so.1 height normal=opengl in.ppm out.pfm
 *
 * PFM holds 1 or 3 channels: a 2-channel result (slopes, offsets) is
 * written with a zero third channel. Exit status: 0 done, 1 relief refused
 * or failed (its message on stderr), 2 bad usage or file. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "relief/relief_c.h"

#ifdef RELIEF_DLOPEN
#include <dlfcn.h>
#endif

static int read_token(FILE* f, char* buf, int size)
{
    int c, n = 0;
    for (;;) { /* skip blanks and # comments */
        c = fgetc(f);
        if (c == '#')
            while (c != '\n' && c != EOF)
                c = fgetc(f);
        if (c == EOF)
            return 0;
        if (c != ' ' && c != '\t' && c != '\n' && c != '\r')
            break;
    }
    while (c != EOF && c != ' ' && c != '\t' && c != '\n' && c != '\r' && n + 1 < size) {
        buf[n++] = (char)c;
        c = fgetc(f);
    }
    buf[n] = 0;
    return n > 0; /* the one blank after maxval has been consumed */
}

/* Reads a binary PPM (P6) or PGM (P5) into `image` (UINT8 or UINT16). */
static int read_pnm(const char* path, relief_image* image)
{
    char magic[8], w[16], h[16], maxval[16];
    FILE* f = fopen(path, "rb");
    if (!f)
        return 0;
    memset(image, 0, sizeof *image);
    if (!read_token(f, magic, sizeof magic) || !read_token(f, w, sizeof w) || !read_token(f, h, sizeof h) ||
        !read_token(f, maxval, sizeof maxval) || (strcmp(magic, "P6") != 0 && strcmp(magic, "P5") != 0)) {
        fclose(f);
        return 0;
    }
    image->width = atoi(w);
    image->height = atoi(h);
    image->channels = magic[1] == '6' ? 3 : 1;
    image->type = atoi(maxval) > 255 ? RELIEF_UINT16 : RELIEF_UINT8;
    size_t bytes = image->type == RELIEF_UINT16 ? 2 : 1;
    size_t n = (size_t)image->width * image->height * image->channels;
    unsigned char* px = malloc(n * bytes);
    if (image->width <= 0 || image->height <= 0 || !px || fread(px, bytes, n, f) != n) {
        free(px);
        fclose(f);
        return 0;
    }
    fclose(f);
    if (bytes == 2) /* PNM is big-endian; relief takes native uint16 */
        for (size_t i = 0; i < n; ++i) {
            unsigned short v = (unsigned short)(px[2 * i] << 8 | px[2 * i + 1]);
            memcpy(px + 2 * i, &v, 2);
        }
    image->pixels = px;
    return 1;
}

/* Writes a float image as little-endian PFM (bottom row first). */
static int write_pfm(const char* path, const relief_image* image)
{
    const int out_channels = image->channels == 1 ? 1 : 3;
    FILE* f = fopen(path, "wb");
    if (!f)
        return 0;
    fprintf(f, "%s\n%d %d\n-1.0\n", out_channels == 1 ? "Pf" : "PF", image->width, image->height);
    const float* px = image->pixels;
    for (int y = image->height - 1; y >= 0; --y)
        for (int x = 0; x < image->width; ++x)
            for (int c = 0; c < out_channels; ++c) {
                float v =
                    c < image->channels ? px[((size_t)y * image->width + x) * image->channels + c] : 0.0f;
                fwrite(&v, sizeof v, 1, f);
            }
    return fclose(f) == 0;
}

int main(int argc, char** argv)
{
    const relief_plugin* relief;
#ifdef RELIEF_DLOPEN
    if (argc < 2) {
        fprintf(stderr, "usage: %s LIBRARY --list | LIBRARY OPERATION MODIFIERS IN.ppm OUT.pfm\n", argv[0]);
        return 2;
    }
    void* module = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!module) {
        fprintf(stderr, "plugin_host: %s\n", dlerror());
        return 2;
    }
    const relief_plugin* (*entry)(void) =
        (const relief_plugin* (*)(void))dlsym(module, "relief_plugin_entry");
    if (!entry) {
        fprintf(stderr, "plugin_host: %s has no relief_plugin_entry\n", argv[1]);
        return 2;
    }
    relief = entry();
    ++argv;
    --argc;
#else
    relief = relief_plugin_entry();
#endif
    if (relief->abi_version() != RELIEF_ABI_VERSION) {
        fprintf(stderr, "plugin_host: relief's ABI is %d, this host was built for %d\n",
                relief->abi_version(), RELIEF_ABI_VERSION);
        return 2;
    }
    if (argc == 2 && strcmp(argv[1], "--list") == 0) {
        fputs(relief->operations_json(), stdout);
        return 0;
    }
    if (argc != 5) {
        fprintf(stderr, "usage: plugin_host OPERATION MODIFIERS IN.ppm OUT.pfm | --list\n");
        return 2;
    }
    relief_image in, out;
    if (!read_pnm(argv[3], &in)) {
        fprintf(stderr, "plugin_host: %s: not a binary PPM/PGM\n", argv[3]);
        return 2;
    }
    int status = relief->run(argv[1], argv[2], &in, 1, &out);
    free(in.pixels);
    if (status != RELIEF_OK) {
        fprintf(stderr, "plugin_host: %s\n", relief->last_error());
        return 1;
    }
    int written = write_pfm(argv[4], &out);
    relief->image_free(&out);
    if (!written) {
        fprintf(stderr, "plugin_host: cannot write %s\n", argv[4]);
        return 2;
    }
    return 0;
}
