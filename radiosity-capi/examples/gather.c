/*
 * gather.c: the radiosity C ABI end to end, written against include/radiosity.h only (C99).
 *
 *   cc -std=c99 -Iradiosity-capi/include radiosity-capi/examples/gather.c \
 *      -Ltarget/release -lradiosity_capi -Wl,-rpath,target/release -lm -o gather
 *   ./gather BAKED.rad [GARBAGE_PATH]
 *
 * Opens the bake, lights it with its own emitters (no direct light from outside: x = E),
 * gathers on every backend it can build and compares each with the reference gather, reads
 * the light at the corners of the full-detail mesh, prints the power per object, then feeds
 * bad input (missing and garbage files, NULL pointers, wrong lengths, an unknown backend) and
 * checks that each gives a non-zero code and a non-empty rad_last_error(). With GARBAGE_PATH,
 * a garbage file is written there and opened too.
 *
 * Output lines a test can read, tab-separated:
 *   scene    patches objects triangles
 *   backend  NAME GATHER-NAME max-relative-difference   (or: backend NAME unavailable MESSAGE)
 *   corners  count mean-r mean-g mean-b
 *   power    index name area r g b          (W: sum over the object's patches of area * B)
 *   probes   count r g b     (reflected irradiance at the first probe, facing +z; or: probes 0)
 * and "ok" at the end, or "FAILED: k checks" on stderr with exit status 1.
 */
#include "radiosity.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

static void fail(int line, const char *what) {
    fprintf(stderr, "gather.c:%d: check failed: %s (last error: %s)\n", line, what,
            rad_last_error());
    failures++;
}

#define CHECK(cond)                                                                            \
    do {                                                                                       \
        if (!(cond)) fail(__LINE__, #cond);                                                    \
    } while (0)

/* A call that must fail: a non-zero code and a message. */
static void expect_error(int line, int32_t code, const char *what) {
    const char *message = rad_last_error();
    if (code == RAD_OK || message == NULL || message[0] == '\0') {
        fprintf(stderr, "gather.c:%d: %s: expected an error, got code %d, message \"%s\"\n",
                line, what, (int)code, message ? message : "(NULL)");
        failures++;
    } else {
        printf("refused\t%s\t%d\t%s\n", what, (int)code, message);
    }
}

#define EXPECT_ERROR(call) expect_error(__LINE__, (call), #call)

/* A count or pointer call that must fail: 0 or NULL, and a message. */
static void expect_empty(int line, int empty, const char *what) {
    expect_error(line, empty ? RAD_ERR_POINTER : RAD_OK, what);
}

#define EXPECT_EMPTY(call) expect_empty(__LINE__, (call) == 0, #call)

/* The host's visibility test for rad_probe_irradiance: every probe in sight, counting the
 * calls in *user. A real host casts a ray from `from` to `to` through its own scene. */
static bool all_in_sight(void *user, const float *from, const float *to) {
    (void)from;
    (void)to;
    ++*(size_t *)user;
    return true;
}

static RadRgb *rgb_array(size_t n) {
    RadRgb *a = calloc(n ? n : 1, sizeof(RadRgb));
    if (!a) {
        fprintf(stderr, "out of memory\n");
        exit(2);
    }
    return a;
}

/* max_i |a_i - b_i| / max_i |b_i| over every channel: the difference relative to the brightest
 * patch, so that dark patches' summation noise does not dominate. */
static double max_relative_difference(const RadRgb *a, const RadRgb *b, size_t n) {
    double diff = 0.0, scale = 0.0;
    for (size_t i = 0; i < n; i++) {
        const float av[3] = {a[i].r, a[i].g, a[i].b}, bv[3] = {b[i].r, b[i].g, b[i].b};
        for (int k = 0; k < 3; k++) {
            double d = fabs((double)av[k] - (double)bv[k]);
            if (!(d <= diff)) diff = d; /* also catches NaN */
            if (fabs((double)bv[k]) > scale) scale = fabs((double)bv[k]);
        }
    }
    return scale > 0.0 ? diff / scale : diff;
}

static unsigned char *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    unsigned char *bytes = NULL;
    long size;
    if (!f) return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (size = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0) {
        bytes = malloc((size_t)size + 1);
        if (bytes && fread(bytes, 1, (size_t)size, f) != (size_t)size) {
            free(bytes);
            bytes = NULL;
        }
        *len = (size_t)size;
    }
    fclose(f);
    return bytes;
}

static void bad_files(const char *path, const char *garbage_path) {
    RadScene *s = (RadScene *)&s; /* not NULL: a failed open must write NULL */
    size_t len = 0;
    unsigned char *bytes;
    static const unsigned char junk[] = "this is not a .rad file, only some text";

    EXPECT_ERROR(rad_scene_open("/nonexistent/radiosity/missing.rad", &s));
    CHECK(s == NULL);
    EXPECT_ERROR(rad_scene_from_bytes(junk, sizeof junk, &s));
    CHECK(s == NULL);
    if (garbage_path) {
        FILE *f = fopen(garbage_path, "wb");
        CHECK(f != NULL);
        if (f) {
            fwrite(junk, 1, sizeof junk, f);
            fclose(f);
            EXPECT_ERROR(rad_scene_open(garbage_path, &s));
            CHECK(s == NULL);
        }
    }
    bytes = read_file(path, &len);
    CHECK(bytes != NULL && len > 64);
    if (bytes && len > 64) {
        /* The whole file parses from memory; a truncated or altered copy does not. */
        CHECK(rad_scene_from_bytes(bytes, len, &s) == RAD_OK && s != NULL);
        rad_scene_free(s);
        EXPECT_ERROR(rad_scene_from_bytes(bytes, len / 2, &s));
        bytes[len - 5] ^= 0x5a; /* inside the last section: its checksum no longer matches */
        EXPECT_ERROR(rad_scene_from_bytes(bytes, len, &s));
        CHECK(s == NULL);
    }
    free(bytes);
    EXPECT_ERROR(rad_scene_open(NULL, &s));
    EXPECT_ERROR(rad_scene_open(path, NULL));
    EXPECT_ERROR(rad_scene_from_bytes(NULL, 10, &s));
    EXPECT_ERROR(rad_scene_from_bytes(junk, sizeof junk, NULL));
}

static void bad_calls(RadScene *scene, RadGather *gather, size_t n, size_t corners) {
    RadRgb *x = rgb_array(n + 1), *y = rgb_array(n + 1), *c = rgb_array(corners + 1);
    RadGather *g = (RadGather *)&g;

    /* NULL pointers. */
    EXPECT_EMPTY(rad_scene_patch_count(NULL));
    EXPECT_EMPTY(rad_scene_patches(NULL));
    EXPECT_EMPTY(rad_scene_object_count(NULL));
    EXPECT_EMPTY(rad_scene_object_name(NULL, 0));
    EXPECT_EMPTY(rad_gather_name(NULL));
    EXPECT_ERROR(rad_gather_new(NULL, "cpu", &g));
    CHECK(g == NULL);
    EXPECT_ERROR(rad_gather_new(scene, NULL, &g));
    EXPECT_ERROR(rad_gather_new(scene, "cpu", NULL));
    EXPECT_ERROR(rad_gather_run(NULL, x, y, n));
    EXPECT_ERROR(rad_gather_run(gather, NULL, y, n));
    EXPECT_ERROR(rad_gather_run(gather, x, NULL, n));
    EXPECT_ERROR(rad_first_exitance(NULL, x, y, n));
    EXPECT_ERROR(rad_first_exitance(scene, NULL, y, n));
    EXPECT_ERROR(rad_first_exitance(scene, x, NULL, n));
    EXPECT_ERROR(rad_scene_corner_indirect(NULL, y, n, c, corners));
    EXPECT_ERROR(rad_scene_corner_indirect(scene, NULL, n, c, corners));
    EXPECT_ERROR(rad_scene_corner_indirect(scene, y, n, NULL, corners));

    /* Wrong lengths, an index past the end, an unknown backend, a non-finite input. */
    EXPECT_ERROR(rad_gather_run(gather, x, y, n - 1));
    EXPECT_ERROR(rad_gather_run(gather, x, y, n + 1));
    EXPECT_ERROR(rad_gather_run(gather, x, y, 0));
    EXPECT_ERROR(rad_first_exitance(scene, x, y, n + 1));
    EXPECT_ERROR(rad_scene_corner_indirect(scene, y, n - 1, c, corners));
    EXPECT_ERROR(rad_scene_corner_indirect(scene, y, n, c, corners + 3));
    if (corners > 0) EXPECT_ERROR(rad_scene_corner_indirect(scene, y, n, c, corners - 1));
    EXPECT_EMPTY(rad_scene_object_name(scene, rad_scene_object_count(scene)));
    EXPECT_ERROR(rad_gather_new(scene, "vulkan-please", &g));
    CHECK(g == NULL);
    EXPECT_ERROR(rad_gather_new(scene, "", &g));
    x[n / 2].g = NAN;
    EXPECT_ERROR(rad_gather_run(gather, x, y, n));
    x[n / 2].g = INFINITY;
    EXPECT_ERROR(rad_first_exitance(scene, x, y, n));

    /* Freeing NULL is a no-op. */
    rad_scene_free(NULL);
    rad_gather_free(NULL);
    free(x);
    free(y);
    free(c);
}

int main(int argc, char **argv) {
    /* The backends other than the reference, and how close each must come to it (relative to
     * the brightest patch): the CPU gathers in f32 where the reference sums in f64, so 1e-4
     * leaves room for f32 summation over thousands of patches. The GPU decodes in its shader
     * exactly as the CPU does, or on a hardware texture unit that may round BC palettes one
     * code off (a few per cent on single entries, averaging out over a row): 2e-2. */
    static const char *const backends[] = {"cpu", "gpu", "auto"};
    static const double tolerance[] = {1e-4, 2e-2, 2e-2};
    RadScene *scene = NULL;
    RadGather *reference = NULL;
    size_t n, objects, triangles, corners;
    RadRgb *direct, *x, *y_ref, *y, *corner;
    const RadPatch *patches;

    if (argc < 2) {
        fprintf(stderr, "usage: %s BAKED.rad [GARBAGE_PATH]\n", argv[0]);
        return 2;
    }
    printf("radiosity %s\n", rad_version());
    if (rad_scene_open(argv[1], &scene) != RAD_OK) {
        fprintf(stderr, "cannot open %s: %s\n", argv[1], rad_last_error());
        return 1;
    }
    n = rad_scene_patch_count(scene);
    objects = rad_scene_object_count(scene);
    triangles = rad_scene_triangle_count(scene);
    corners = 3 * triangles;
    patches = rad_scene_patches(scene);
    printf("scene\t%zu\t%zu\t%zu\n", n, objects, triangles);
    CHECK(n > 1 && patches != NULL && objects > 0);

    /* The scene's own emitters only: direct irradiance zero, so x = E. */
    direct = rgb_array(n);
    x = rgb_array(n);
    y_ref = rgb_array(n);
    y = rgb_array(n);
    CHECK(rad_first_exitance(scene, direct, x, n) == RAD_OK);
    for (size_t i = 0; i < n; i++) CHECK(x[i].r == patches[i].emission.r);

    CHECK(rad_gather_new(scene, "reference", &reference) == RAD_OK);
    CHECK(reference != NULL && strcmp(rad_gather_name(reference), "reference") == 0);
    CHECK(rad_gather_run(reference, x, y_ref, n) == RAD_OK);

    for (size_t b = 0; b < sizeof backends / sizeof backends[0]; b++) {
        RadGather *g = NULL;
        int32_t code = rad_gather_new(scene, backends[b], &g);
        double d;
        if (code != RAD_OK) {
            /* Only the GPU may be missing; the CPU and auto (which falls back to it) never. */
            CHECK(code == RAD_ERR_UNAVAILABLE && strcmp(backends[b], "gpu") == 0);
            CHECK(g == NULL && rad_last_error()[0] != '\0');
            printf("backend\t%s\tunavailable\t%s\n", backends[b], rad_last_error());
            continue;
        }
        CHECK(rad_gather_run(g, x, y, n) == RAD_OK);
        d = max_relative_difference(y, y_ref, n);
        printf("backend\t%s\t%s\t%s\t%.3g\n", backends[b], rad_gather_backend(g),
               rad_gather_name(g), d);
        CHECK(d <= tolerance[b]);
        /* In place: x and y the same array. */
        memcpy(y, x, n * sizeof *y);
        CHECK(rad_gather_run(g, y, y, n) == RAD_OK);
        CHECK(max_relative_difference(y, y_ref, n) <= tolerance[b]);
        rad_gather_free(g);
    }

    /* Light at the corners of the full-detail mesh: each corner is a weighted mean of patch
     * irradiances (weights summing to 1, or none), so it lies within their range. */
    corner = rgb_array(corners);
    if (triangles == 0) {
        EXPECT_ERROR(rad_scene_corner_indirect(scene, y_ref, n, corner, 0));
    } else {
        double sum[3] = {0, 0, 0}, top = 0;
        CHECK(rad_scene_corner_indirect(scene, y_ref, n, corner, corners) == RAD_OK);
        for (size_t i = 0; i < n; i++) {
            const float v[3] = {y_ref[i].r, y_ref[i].g, y_ref[i].b};
            for (int k = 0; k < 3; k++)
                if (v[k] > top) top = v[k];
        }
        for (size_t c = 0; c < corners; c++) {
            const float v[3] = {corner[c].r, corner[c].g, corner[c].b};
            for (int k = 0; k < 3; k++) {
                CHECK(v[k] >= 0.0f && v[k] <= top * (1.0 + 1e-5));
                sum[k] += v[k];
            }
        }
        printf("corners\t%zu\t%.9g\t%.9g\t%.9g\n", corners, sum[0] / (double)corners,
               sum[1] / (double)corners, sum[2] / (double)corners);
        CHECK(rad_scene_triangles(scene) != NULL && rad_scene_vertices(scene) != NULL);
        CHECK(rad_scene_vertex_count(scene) > 0);
        CHECK(rad_scene_triangles(scene)[0].vertices[0] < rad_scene_vertex_count(scene));
    }

    /* Power per object (W): radiosity B = E + rho * (direct + y), times area, summed. */
    for (size_t o = 0; o < objects; o++) {
        double area = 0, p[3] = {0, 0, 0};
        const char *name = rad_scene_object_name(scene, o);
        CHECK(name != NULL);
        for (size_t i = 0; i < n; i++) {
            const RadPatch *q = &patches[i];
            if (q->object != o) continue;
            area += q->area;
            p[0] += q->area * (q->emission.r + q->reflectance.r * (direct[i].r + y_ref[i].r));
            p[1] += q->area * (q->emission.g + q->reflectance.g * (direct[i].g + y_ref[i].g));
            p[2] += q->area * (q->emission.b + q->reflectance.b * (direct[i].b + y_ref[i].b));
        }
        printf("power\t%zu\t%s\t%.9g\t%.9g\t%.9g\t%.9g\n", o, name ? name : "", area, p[0], p[1],
               p[2]);
    }

    /* Light probes: the frame's SH from the patches' total irradiance (direct + y), then the
     * reflected irradiance at the first probe facing +z, with and without the host's
     * visibility callback (all in sight: the same answer). */
    {
        size_t probes = rad_scene_probe_count(scene);
        if (probes == 0) {
            RadRgb one;
            CHECK(rad_scene_probe_positions(scene) == NULL);
            EXPECT_ERROR(rad_scene_probes_frame(scene, y_ref, n, &one, 0));
            printf("probes\t0\n");
        } else {
            RadRgb *total = rgb_array(n), *sh = rgb_array(9 * probes), e, e_seen;
            const float *at = rad_scene_probe_positions(scene), up[3] = {0.0f, 0.0f, 1.0f};
            size_t calls = 0;
            for (size_t i = 0; i < n; i++) {
                total[i].r = direct[i].r + y_ref[i].r;
                total[i].g = direct[i].g + y_ref[i].g;
                total[i].b = direct[i].b + y_ref[i].b;
            }
            CHECK(at != NULL);
            CHECK(rad_scene_probes_frame(scene, total, n, sh, 9 * probes) == RAD_OK);
            CHECK(rad_probe_irradiance(scene, sh, 9 * probes, at, up, NULL, NULL, &e) == RAD_OK);
            CHECK(rad_probe_irradiance(scene, sh, 9 * probes, at, up, all_in_sight, &calls,
                                       &e_seen) == RAD_OK);
            CHECK(e.r == e_seen.r && e.g == e_seen.g && e.b == e_seen.b);
            printf("probes\t%zu\t%.9g\t%.9g\t%.9g\n", probes, e.r, e.g, e.b);
            /* Bad probe calls: NULL pointers, a wrong length, a normal not of unit length. */
            EXPECT_ERROR(rad_scene_probes_frame(NULL, total, n, sh, 9 * probes));
            EXPECT_ERROR(rad_scene_probes_frame(scene, total, n, NULL, 9 * probes));
            EXPECT_ERROR(rad_scene_probes_frame(scene, total, n, sh, 9 * probes - 1));
            EXPECT_ERROR(rad_probe_irradiance(scene, sh, 9 * probes, at, at, NULL, NULL, &e));
            EXPECT_ERROR(rad_probe_irradiance(scene, sh, 9 * probes, NULL, up, NULL, NULL, &e));
            EXPECT_ERROR(rad_probe_irradiance(scene, sh, 9 * probes, at, up, NULL, NULL, NULL));
            free(total);
            free(sh);
        }
    }

    bad_calls(scene, reference, n, corners);
    bad_files(argv[1], argc > 2 ? argv[2] : NULL);

    rad_gather_free(reference);
    rad_scene_free(scene);
    free(direct);
    free(x);
    free(y_ref);
    free(y);
    free(corner);
    if (failures) {
        fprintf(stderr, "FAILED: %d checks\n", failures);
        return 1;
    }
    printf("ok\n");
    return 0;
}
