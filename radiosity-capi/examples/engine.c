/*
 * engine.c: an engine's whole loop through the radiosity C ABI (C99), against
 * include/radiosity.h only:
 *
 *   cc -std=c99 -Iradiosity-capi/include radiosity-capi/examples/engine.c \
 *      -Ltarget/release -lradiosity_capi -Wl,-rpath,target/release -lm -o engine
 *   ./engine SCENE.obj OUT.rad
 *
 * 1. Bakes SCENE.obj into OUT.rad with rad_bake ({"patches": 256, "probes": "none"}), with a
 *    progress callback that checks the fraction never decreases and reaches 1; then bakes
 *    again into OUT.rad.cancelled and cancels from the callback: RAD_ERR_CANCELLED, no file.
 * 2. Opens OUT.rad and lights it with a point light: direct light with shadow rays
 *    (rad_scene_direct), first exitance, a gather, the light at the mesh's corners.
 * 3. Asks for the total irradiance at two points (rad_scene_point_irradiance).
 * 4. Feeds bad input (NULL, wrong lengths, an unknown light kind, negative and NaN values, a
 *    bad options key) and checks each gives its code and a message.
 *
 * Output lines, tab-separated: "progress calls last", "direct patch r g b" (every patch),
 * "y patch r g b", "point i status r g b", "refused what code message"; "ok" at the end, or
 * "FAILED: k checks" on stderr with exit status 1.
 */
#include "radiosity.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

#define CHECK(cond)                                                                            \
    do {                                                                                       \
        if (!(cond)) {                                                                         \
            fprintf(stderr, "engine.c:%d: check failed: %s (last error: %s)\n", __LINE__,     \
                    #cond, rad_last_error());                                                  \
            failures++;                                                                        \
        }                                                                                      \
    } while (0)

static void expect_code(int line, int32_t got, int32_t want, const char *what) {
    const char *message = rad_last_error();
    if (got != want || message == NULL || message[0] == '\0') {
        fprintf(stderr, "engine.c:%d: %s: expected code %d, got %d (\"%s\")\n", line, what,
                (int)want, (int)got, message ? message : "(NULL)");
        failures++;
    } else {
        printf("refused\t%s\t%d\t%s\n", what, (int)got, message);
    }
}
#define EXPECT(call, code) expect_code(__LINE__, (call), (code), #call)

typedef struct Progress {
    int calls;
    double last;
    int monotone;
    int cancel_after; /* cancel at this call (0: never) */
} Progress;

static int32_t on_progress(void *user, const char *stage, double fraction) {
    Progress *p = (Progress *)user;
    p->calls++;
    if (fraction < p->last || fraction < 0.0 || fraction > 1.0 || stage == NULL) p->monotone = 0;
    p->last = fraction;
    return p->cancel_after != 0 && p->calls >= p->cancel_after;
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: engine SCENE.obj OUT.rad\n");
        return 2;
    }
    const char *scene_path = argv[1], *rad_path = argv[2];
    const char *options = "{\"patches\": 256, \"probes\": \"none\"}";

    /* 1. Bake, with progress; then a bake cancelled from its callback. */
    Progress p = {0, 0.0, 1, 0};
    CHECK(rad_bake(scene_path, rad_path, options, on_progress, &p) == RAD_OK);
    CHECK(p.calls >= 1 && p.monotone && p.last == 1.0);
    printf("progress\t%d\t%.3f\n", p.calls, p.last);
    char cancelled[4096];
    snprintf(cancelled, sizeof cancelled, "%s.cancelled", rad_path);
    Progress q = {0, 0.0, 1, 1};
    EXPECT(rad_bake(scene_path, cancelled, options, on_progress, &q), RAD_ERR_CANCELLED);
    FILE *f = fopen(cancelled, "rb");
    CHECK(f == NULL);
    if (f) fclose(f);

    /* 2. A frame: a point light, direct light with shadows, exitance, gather, corners. */
    RadScene *scene = NULL;
    CHECK(rad_scene_open(rad_path, &scene) == RAD_OK);
    if (!scene) return 1;
    size_t n = rad_scene_patch_count(scene);
    RadLight light;
    memset(&light, 0, sizeof light);
    light.kind = RAD_LIGHT_POINT;
    light.position[0] = 0.0f; light.position[1] = 1.0f; light.position[2] = 0.0f;
    light.value.r = 2.0f; light.value.g = 2.0f; light.value.b = 2.0f;
    RadRgb *direct = calloc(n, sizeof *direct), *x = calloc(n, sizeof *x), *y = calloc(n, sizeof *y);
    CHECK(rad_scene_direct(scene, &light, 1, direct, n) == RAD_OK);
    CHECK(rad_first_exitance(scene, direct, x, n) == RAD_OK);
    RadGather *gather = NULL;
    CHECK(rad_gather_new(scene, "cpu", &gather) == RAD_OK);
    CHECK(gather && rad_gather_run(gather, x, y, n) == RAD_OK);
    for (size_t i = 0; i < n; i++) {
        printf("direct\t%zu\t%.9g\t%.9g\t%.9g\n", i, direct[i].r, direct[i].g, direct[i].b);
        printf("y\t%zu\t%.9g\t%.9g\t%.9g\n", i, y[i].r, y[i].g, y[i].b);
    }
    size_t corners = 3 * rad_scene_triangle_count(scene);
    RadRgb *at_corners = calloc(corners, sizeof *at_corners);
    CHECK(rad_scene_corner_indirect(scene, y, n, at_corners, corners) == RAD_OK);

    /* 3. Two points: one in the room facing up, one far outside. */
    float points[6] = {0.0f, 0.5f, 0.0f, 100.0f, 100.0f, 100.0f};
    float normals[6] = {0.0f, 1.0f, 0.0f, 0.0f, 1.0f, 0.0f};
    RadRgb out[2];
    int32_t status[2];
    CHECK(rad_scene_point_irradiance(scene, &light, 1, y, n, points, normals, 2, out, status) == RAD_OK);
    for (int i = 0; i < 2; i++)
        printf("point\t%d\t%d\t%.9g\t%.9g\t%.9g\n", i, (int)status[i], out[i].r, out[i].g, out[i].b);
    CHECK(status[1] == RAD_POINT_OUTSIDE);

    /* 4. Bad input. */
    RadLight bad = light;
    EXPECT(rad_scene_direct(NULL, &light, 1, direct, n), RAD_ERR_POINTER);
    EXPECT(rad_scene_direct(scene, NULL, 1, direct, n), RAD_ERR_POINTER);
    EXPECT(rad_scene_direct(scene, &light, 1, direct, n + 1), RAD_ERR_LENGTH);
    bad.kind = 7;
    EXPECT(rad_scene_direct(scene, &bad, 1, direct, n), RAD_ERR_VALUE);
    bad = light;
    bad.value.g = -1.0f;
    EXPECT(rad_scene_direct(scene, &bad, 1, direct, n), RAD_ERR_VALUE);
    bad.value.g = NAN;
    EXPECT(rad_scene_direct(scene, &bad, 1, direct, n), RAD_ERR_VALUE);
    bad = light;
    bad.kind = RAD_LIGHT_SPOT;
    bad.cone_deg = 200.0f;
    bad.direction[1] = -1.0f;
    EXPECT(rad_scene_direct(scene, &bad, 1, direct, n), RAD_ERR_VALUE);
    direct[0].r = -5.0f;
    EXPECT(rad_first_exitance(scene, direct, x, n), RAD_ERR_VALUE);
    x[0].g = -5.0f;
    EXPECT(rad_gather_run(gather, x, y, n), RAD_ERR_VALUE);
    x[0].g = NAN;
    EXPECT(rad_gather_run(gather, x, y, n), RAD_ERR_VALUE);
    EXPECT(rad_scene_point_irradiance(scene, &light, 1, y, n, NULL, normals, 2, out, status), RAD_ERR_POINTER);
    EXPECT(rad_scene_point_irradiance(scene, &light, 1, y, n - 1, points, normals, 2, out, status), RAD_ERR_LENGTH);
    normals[1] = 0.0f;
    EXPECT(rad_scene_point_irradiance(scene, &light, 1, y, n, points, normals, 2, out, status), RAD_ERR_VALUE);
    EXPECT(rad_bake(scene_path, cancelled, "{\"patchez\": 5}", NULL, NULL), RAD_ERR_VALUE);
    EXPECT(rad_bake(NULL, cancelled, NULL, NULL, NULL), RAD_ERR_POINTER);
    EXPECT(rad_bake(scene_path, cancelled, "{\"patches\": -3}", NULL, NULL), RAD_ERR_VALUE);

    free(direct); free(x); free(y); free(at_corners);
    rad_gather_free(gather);
    rad_scene_free(scene);
    if (failures) {
        fprintf(stderr, "FAILED: %d checks\n", failures);
        return 1;
    }
    printf("ok\n");
    return 0;
}
