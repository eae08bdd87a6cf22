/*
 * relight: radiosity at surface points of a baked scene, through the lrr C interface.
 *
 *   relight FILE.lrr [--scale S] [--points FILE] [--lightmap OUT.pfm] [X Y Z NX NY NZ]...
 *
 * Loads the operator, scales the baked emission by S (default 1), evaluates the radiosity of
 * every element once, then prints for each probe point (a position and a normal, from the
 * command line and/or a text file of six numbers per point; '#' starts a comment) one line:
 *
 *   ELEMENT R G B
 *
 * with 9 significant digits, enough to read back the exact float. With S = 1 the numbers are
 * those of `lrr probe FILE.lrr --points P.json` (tests/tests/e2e/capi.rs checks it).
 *
 * With --lightmap, the frame also fills the file's lightmap atlas (lrr_lightmap_*: B/pi per
 * texel) and writes it to OUT.pfm (Portable Float Map: "PF", width height, -1 for little-endian
 * floats, then RGB rows bottom to top); the texels are those of
 * `lrr export FILE.lrr -o OUT.exr --samples float` (tests/tests/e2e/capi.rs checks it).
 *
 * Build (see runtime/capi/include/lrr.h):
 *   cc relight.c -I runtime/capi/include target/release/liblrr_capi.a -lpthread -ldl -lm
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lrr.h"

/* Growable list of probe points, 6 floats each. */
typedef struct {
    float *v;
    size_t count, capacity;
} points;

static void die(const char *what) {
    fprintf(stderr, "relight: %s: %s\n", what, lrr_last_error());
    exit(1);
}

static void usage(void) {
    fprintf(stderr, "usage: relight FILE.lrr [--scale S] [--points FILE] [--lightmap OUT.pfm] "
                    "[X Y Z NX NY NZ]...\n");
    exit(2);
}

static int parse_float(const char *text, float *out) {
    char *end = NULL;
    errno = 0;
    *out = strtof(text, &end);
    return errno == 0 && end != text && *end == '\0';
}

static void push(points *p, float x) {
    if (p->count == p->capacity) {
        p->capacity = p->capacity ? 2 * p->capacity : 64;
        p->v = realloc(p->v, p->capacity * sizeof(float));
        if (!p->v) {
            perror("relight");
            exit(1);
        }
    }
    p->v[p->count++] = x;
}

/* Reads whitespace-separated numbers from `path`, skipping '#' comments. */
static void read_points(const char *path, points *p) {
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "relight: cannot open %s: %s\n", path, strerror(errno));
        exit(1);
    }
    char word[128];
    int c;
    while ((c = fgetc(f)) != EOF) {
        if (c == '#') {
            while ((c = fgetc(f)) != EOF && c != '\n') {
            }
            continue;
        }
        if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
            continue;
        }
        size_t len = 0;
        do {
            if (len + 1 < sizeof word) {
                word[len++] = (char)c;
            }
        } while ((c = fgetc(f)) != EOF && c != ' ' && c != '\t' && c != '\n' && c != '\r');
        word[len] = '\0';
        float x;
        if (!parse_float(word, &x)) {
            fprintf(stderr, "relight: %s: '%s' is not a number\n", path, word);
            exit(1);
        }
        push(p, x);
    }
    fclose(f);
}

/* Fills the lightmap of `op` from `radiosity` and writes it to `path` as a PFM. */
static void write_lightmap(const lrr_operator *op, const float *radiosity, size_t n,
                           const char *path) {
    lrr_lightmap *map = NULL;
    uint32_t w = 0, h = 0;
    if (lrr_lightmap_new(op, &map) != LRR_OK || lrr_lightmap_size(map, &w, &h) != LRR_OK) {
        die("lightmap");
    }
    size_t len = 3 * (size_t)w * h;
    float *texels = malloc(len * sizeof(float));
    if (!texels) {
        perror("relight");
        exit(1);
    }
    if (lrr_lightmap_fill(map, radiosity, 3 * n, texels, len) != LRR_OK) {
        die("lightmap fill");
    }
    FILE *f = fopen(path, "wb");
    if (!f) {
        fprintf(stderr, "relight: cannot create %s: %s\n", path, strerror(errno));
        exit(1);
    }
    /* PFM rows run bottom to top; the lightmap's top to bottom. Little-endian hosts assumed. */
    fprintf(f, "PF\n%u %u\n-1.0\n", (unsigned)w, (unsigned)h);
    for (uint32_t y = h; y-- > 0;) {
        if (fwrite(&texels[3 * (size_t)w * y], sizeof(float), 3 * (size_t)w, f) != 3 * (size_t)w) {
            fprintf(stderr, "relight: writing %s failed\n", path);
            exit(1);
        }
    }
    if (fclose(f) != 0) {
        fprintf(stderr, "relight: writing %s failed\n", path);
        exit(1);
    }
    free(texels);
    lrr_lightmap_free(map);
}

int main(int argc, char **argv) {
    if (argc < 2) {
        usage();
    }
    const char *file = argv[1];
    float scale = 1.0f;
    points p = {NULL, 0, 0};
    const char *lightmap = NULL;
    for (int i = 2; i < argc; i++) {
        if (strcmp(argv[i], "--scale") == 0 && i + 1 < argc) {
            if (!parse_float(argv[++i], &scale) || !(scale >= 0.0f)) {
                fprintf(stderr, "relight: --scale needs a non-negative number\n");
                return 2;
            }
        } else if (strcmp(argv[i], "--lightmap") == 0 && i + 1 < argc) {
            lightmap = argv[++i];
        } else if (strcmp(argv[i], "--points") == 0 && i + 1 < argc) {
            read_points(argv[++i], &p);
        } else {
            float x;
            if (!parse_float(argv[i], &x)) {
                usage();
            }
            push(&p, x);
        }
    }
    if (p.count % 6 != 0) {
        fprintf(stderr, "relight: %zu numbers given: need six per point (x y z nx ny nz)\n",
                p.count);
        return 2;
    }

    lrr_operator *op = NULL;
    if (lrr_load(file, &op) != LRR_OK) {
        die("cannot load the operator");
    }
    size_t n = lrr_element_count(op);
    float *emission = malloc(3 * n * sizeof(float));
    float *radiosity = malloc(3 * n * sizeof(float));
    if (!emission || !radiosity) {
        perror("relight");
        return 1;
    }
    if (lrr_baked_emission(op, emission, 3 * n) != LRR_OK) {
        die("baked emission");
    }
    for (size_t i = 0; i < 3 * n; i++) {
        emission[i] *= scale;
    }
    if (lrr_evaluate(op, emission, 3 * n, radiosity, 3 * n) != LRR_OK) {
        die("evaluate");
    }
    for (size_t i = 0; i < p.count; i += 6) {
        uint32_t e = 0;
        if (lrr_locate(op, &p.v[i], &p.v[i + 3], &e) != LRR_OK) {
            die("locate");
        }
        const float *b = &radiosity[3 * (size_t)e];
        printf("%u %.9g %.9g %.9g\n", (unsigned)e, b[0], b[1], b[2]);
    }
    if (lightmap) {
        write_lightmap(op, radiosity, n, lightmap);
    }
    lrr_free(op);
    free(emission);
    free(radiosity);
    free(p.v);
    return 0;
}
