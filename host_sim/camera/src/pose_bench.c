/*
 * pose_bench: time per frame of the pose pipeline on this machine, and the size
 * of its working memory. Frames are rendered first (not timed), then the
 * pipeline runs over them `repeats` times; the best repeat is reported (least
 * disturbed by other load), with the mean. Build with the host-release preset.
 *
 *   pose_bench [--frames N] [--range-mm R] [--repeats K]
 * Default: the goal scenario (700 mm, 1 % range noise, 2 % gray noise,
 * 2 spurious blobs, 1 hidden marker), 64 frames, 20 repeats.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera/camera.h"
#include "pose/pose.h"

static double now_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static long arg_long(int argc, char **argv, const char *name, long dflt, long lo, long hi) {
    for (int i = 1; i + 1 < argc; ++i) {
        if (strcmp(argv[i], name) == 0) {
            char *end = NULL;
            long v = strtol(argv[i + 1], &end, 10);
            if (end == argv[i + 1] || *end != '\0' || v < lo || v > hi) {
                fprintf(stderr, "pose_bench: %s: expected an integer in %ld..%ld, got '%s'\n", name,
                        lo, hi, argv[i + 1]);
                exit(2);
            }
            return v;
        }
    }
    return dflt;
}

int main(int argc, char **argv) {
    long n_frames = arg_long(argc, argv, "--frames", 64, 1, 4096);
    long range = arg_long(argc, argv, "--range-mm", 700, 300, 15000);
    long repeats = arg_long(argc, argv, "--repeats", 20, 1, 1000);
    struct camera_intrinsics k;
    camera_paper_intrinsics(&k);
    struct camera_scenario sc = {(double)range, 2, 1, 20.0, range < 650};
    struct camera_noise noise = {0.02, 0.01};
    struct camera_rng rng;
    camera_rng_seed(&rng, 12345u);
    struct camera_frame *frames = malloc((size_t)n_frames * sizeof *frames);
    static struct camera_scene scene;
    if (frames == NULL) {
        fprintf(stderr, "pose_bench: out of memory for %ld frames\n", n_frames);
        return 1;
    }
    for (long f = 0; f < n_frames; ++f) {
        if (camera_random_scene(&k, &sc, &rng, &scene) != 0) {
            fprintf(stderr, "pose_bench: no scene at %ld mm\n", range);
            return 1;
        }
        camera_render(&k, &scene, &noise, 8, &rng, &frames[f], NULL);
    }
    struct pose_camera cam;
    pose_camera_paper(&cam);
    struct pose_config cfg;
    pose_config_default(&cfg);
    static struct pose_pipeline pipe;
    if (pose_init(&pipe, &cfg, &cam, pose_paper_target, POSE_PAPER_TARGET_COUNT) != POSE_OK) {
        fprintf(stderr, "pose_bench: pose_init failed\n");
        return 1;
    }
    struct pose_result res;
    double best_full = 1e9, sum_full = 0.0, best_extract = 1e9;
    long ok = 0;
    for (long r = 0; r < repeats; ++r) {
        double t0 = now_seconds();
        for (long f = 0; f < n_frames; ++f) {
            struct pose_frame pf = {&frames[f].gray[0][0], &frames[f].range_mm[0][0], CAMERA_WIDTH,
                                    CAMERA_HEIGHT, CAMERA_WIDTH};
            if (pose_process(&pipe, &pf, &res, NULL, NULL) != POSE_OK) {
                fprintf(stderr, "pose_bench: pose_process failed on frame %ld\n", f);
                return 1;
            }
            ok += res.status == POSE_STATUS_OK || res.status == POSE_STATUS_DEGRADED;
        }
        double dt = (now_seconds() - t0) / (double)n_frames;
        sum_full += dt;
        best_full = dt < best_full ? dt : best_full;
        t0 = now_seconds();
        for (long f = 0; f < n_frames; ++f) {
            struct pose_frame pf = {&frames[f].gray[0][0], &frames[f].range_mm[0][0], CAMERA_WIDTH,
                                    CAMERA_HEIGHT, CAMERA_WIDTH};
            (void)pose_extract(&pipe, &pf, &res, NULL, NULL);
        }
        dt = (now_seconds() - t0) / (double)n_frames;
        best_extract = dt < best_extract ? dt : best_extract;
    }
    printf("pose_bench: %ld frames x %ld repeats at %ld mm (depth noise 1 %%, gray noise 2 %%, "
           "2 spurious, 1 hidden)\n",
           n_frames, repeats, range);
    printf("  valid poses            %ld / %ld\n", ok, n_frames * repeats);
    printf("  time per frame         %.1f us best, %.1f us mean (full pipeline)\n", best_full * 1e6,
           sum_full / (double)repeats * 1e6);
    printf("  of which extraction    %.1f us best\n", best_extract * 1e6);
    printf("  working memory         sizeof(struct pose_pipeline) = %zu bytes (%.1f KiB)\n",
           sizeof(struct pose_pipeline), (double)sizeof(struct pose_pipeline) / 1024.0);
    printf("    struct pose_workspace  %zu (runs %zu, components %zu, match %zu)\n",
           sizeof(struct pose_workspace), sizeof pipe.ws.runs, sizeof pipe.ws.components,
           sizeof pipe.ws.match);
    printf("    struct pose_config     %zu\n", sizeof(struct pose_config));
    printf("  result                 sizeof(struct pose_result) = %zu bytes\n",
           sizeof(struct pose_result));
    printf("  frame buffers (excluded) %zu bytes\n", sizeof(struct camera_frame));
    free(frames);
    return 0;
}
