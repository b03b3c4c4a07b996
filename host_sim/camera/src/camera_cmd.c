/*
 * `host_sim camera`: synthetic frames through the pose pipeline, scored against
 * the renderer's truth. See camera_cmd.h for the command line.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include "camera/camera_cmd.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera/camera.h"
#include "camera/camera_png.h"
#include "pose/pose.h"

#define EXIT_USAGE 2
#define EXIT_IO    1

struct options {
    long frames;
    double range_mm;
    long spurious;
    long missing;
    double depth_noise;
    double gray_noise;
    uint64_t seed;
    const char *report;
    const char *image;
    bool allow_partial;
    bool verbose;
    long supersample;
    bool have[7]; /* required options seen: frames range spurious missing depth gray seed */
};

static void usage(FILE *f) {
    fprintf(f,
            "usage: host_sim camera --frames K --range-mm R --spurious S --missing M\n"
            "                       --depth-noise F --gray-noise G --seed X --report FILE.json\n"
            "                       [--image FRAME.png] [--allow-partial] [--supersample N]\n"
            "                       [--verbose]\n"
            "  K 1..1000000 frames; R 100..20000 mm (target distance); S 0..8 spurious blobs;\n"
            "  M 0..5 hidden markers; F, G 0..0.5 (range sigma / range, gray sigma / full scale);\n"
            "  X seed (unsigned 64-bit); N 1..32 subsamples per axis in mixed pixels (default 8).\n"
            "  --allow-partial: do not require every marker in view (for ranges < ~0.75 m).\n"
            "  --verbose: one line per frame on stderr (status, blobs, matches, errors).\n"
            "  --help, -h: this text.\n");
}

static int bad_value(const char *opt, const char *value, const char *expect) {
    fprintf(stderr, "camera: %s: expected %s, got '%s'\n", opt, expect, value);
    return EXIT_USAGE;
}

static int parse_long(const char *opt, const char *s, long lo, long hi, long *out) {
    char *end = NULL;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || v < lo || v > hi) {
        char expect[64];
        snprintf(expect, sizeof expect, "an integer in %ld..%ld", lo, hi);
        return bad_value(opt, s, expect);
    }
    *out = v;
    return 0;
}

static int parse_double(const char *opt, const char *s, double lo, double hi, double *out) {
    char *end = NULL;
    errno = 0;
    double v = strtod(s, &end);
    if (errno != 0 || end == s || *end != '\0' || !(v >= lo && v <= hi)) {
        char expect[64];
        snprintf(expect, sizeof expect, "a number in %g..%g", lo, hi);
        return bad_value(opt, s, expect);
    }
    *out = v;
    return 0;
}

static int parse_u64(const char *opt, const char *s, uint64_t *out) {
    char *end = NULL;
    errno = 0;
    if (s[0] == '-') {
        return bad_value(opt, s, "an unsigned integer");
    }
    unsigned long long v = strtoull(s, &end, 0);
    if (errno != 0 || end == s || *end != '\0') {
        return bad_value(opt, s, "an unsigned integer");
    }
    *out = (uint64_t)v;
    return 0;
}

static int parse_options(int argc, char **argv, struct options *o) {
    memset(o, 0, sizeof *o);
    o->supersample = 8;
    static const char *const required[7] = {"--frames",  "--range-mm",    "--spurious",
                                            "--missing", "--depth-noise", "--gray-noise",
                                            "--seed"};
    bool have_report = false;
    for (int i = 1; i < argc; ++i) {
        const char *opt = argv[i];
        if (strcmp(opt, "--help") == 0 || strcmp(opt, "-h") == 0) {
            usage(stdout);
            return -1;
        }
        if (strcmp(opt, "--allow-partial") == 0) {
            o->allow_partial = true;
            continue;
        }
        if (strcmp(opt, "--verbose") == 0) {
            o->verbose = true;
            continue;
        }
        if (strncmp(opt, "--", 2) != 0) {
            fprintf(stderr, "camera: unexpected argument '%s' (options start with --)\n", opt);
            return EXIT_USAGE;
        }
        if (i + 1 >= argc) {
            fprintf(stderr, "camera: %s needs a value\n", opt);
            return EXIT_USAGE;
        }
        const char *val = argv[++i];
        int rc;
        if (strcmp(opt, "--frames") == 0) {
            rc = parse_long(opt, val, 1, 1000000, &o->frames);
            o->have[0] = true;
        } else if (strcmp(opt, "--range-mm") == 0) {
            rc = parse_double(opt, val, 100.0, 20000.0, &o->range_mm);
            o->have[1] = true;
        } else if (strcmp(opt, "--spurious") == 0) {
            rc = parse_long(opt, val, 0, 8, &o->spurious);
            o->have[2] = true;
        } else if (strcmp(opt, "--missing") == 0) {
            rc = parse_long(opt, val, 0, 5, &o->missing);
            o->have[3] = true;
        } else if (strcmp(opt, "--depth-noise") == 0) {
            rc = parse_double(opt, val, 0.0, 0.5, &o->depth_noise);
            o->have[4] = true;
        } else if (strcmp(opt, "--gray-noise") == 0) {
            rc = parse_double(opt, val, 0.0, 0.5, &o->gray_noise);
            o->have[5] = true;
        } else if (strcmp(opt, "--seed") == 0) {
            rc = parse_u64(opt, val, &o->seed);
            o->have[6] = true;
        } else if (strcmp(opt, "--report") == 0) {
            o->report = val;
            have_report = true;
            rc = 0;
        } else if (strcmp(opt, "--image") == 0) {
            o->image = val;
            rc = 0;
        } else if (strcmp(opt, "--supersample") == 0) {
            rc = parse_long(opt, val, 1, 32, &o->supersample);
        } else {
            fprintf(stderr, "camera: unknown option '%s'\n", opt);
            usage(stderr);
            return EXIT_USAGE;
        }
        if (rc != 0) {
            return rc;
        }
    }
    for (int k = 0; k < 7; ++k) {
        if (!o->have[k]) {
            fprintf(stderr, "camera: missing required option %s\n", required[k]);
            usage(stderr);
            return EXIT_USAGE;
        }
    }
    if (!have_report) {
        fprintf(stderr, "camera: missing required option --report\n");
        usage(stderr);
        return EXIT_USAGE;
    }
    return 0;
}

/* ---- drawing ---------------------------------------------------------------- */

#define IMG_SCALE 3

/* 3 x 5 digit glyphs, one row per 3-bit group (ours). */
static const uint8_t digit_font[10][5] = {
    {7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7}, {5, 5, 7, 1, 1},
    {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1}, {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7},
};

struct canvas {
    int w, h;
    uint8_t *rgb;
};

static void put_px(struct canvas *c, int x, int y, const uint8_t col[3]) {
    if (x < 0 || y < 0 || x >= c->w || y >= c->h) {
        return;
    }
    memcpy(c->rgb + ((size_t)y * (size_t)c->w + (size_t)x) * 3u, col, 3);
}

static void draw_cross(struct canvas *c, double u, double v, int half, const uint8_t col[3]) {
    int x = (int)lround((u + 0.5) * IMG_SCALE - 0.5);
    int y = (int)lround((v + 0.5) * IMG_SCALE - 0.5);
    for (int d = -half; d <= half; ++d) {
        put_px(c, x + d, y, col);
        put_px(c, x, y + d, col);
    }
}

static void draw_circle(struct canvas *c, double u, double v, double r_px, const uint8_t col[3]) {
    double x0 = (u + 0.5) * IMG_SCALE - 0.5;
    double y0 = (v + 0.5) * IMG_SCALE - 0.5;
    double r = r_px * IMG_SCALE;
    int steps = (int)(2.0 * 3.14159 * r) + 8;
    for (int s = 0; s < steps; ++s) {
        double a = 2.0 * 3.14159265358979 * s / steps;
        put_px(c, (int)lround(x0 + r * cos(a)), (int)lround(y0 + r * sin(a)), col);
    }
}

static void draw_number(struct canvas *c, int x, int y, int number, const uint8_t col[3]) {
    char text[8];
    snprintf(text, sizeof text, "%d", number);
    for (size_t k = 0; text[k] != '\0'; ++k) {
        const uint8_t *g = digit_font[text[k] - '0'];
        for (int row = 0; row < 5; ++row) {
            for (int bit = 0; bit < 3; ++bit) {
                if (g[row] & (4u >> bit)) {
                    for (int dy = 0; dy < 2; ++dy) {
                        for (int dx = 0; dx < 2; ++dx) {
                            put_px(c, x + (int)k * 8 + bit * 2 + dx, y + row * 2 + dy, col);
                        }
                    }
                }
            }
        }
    }
}

static int write_image(const char *path, const struct camera_intrinsics *k,
                       const struct camera_frame *frame, const struct camera_scene *scene,
                       const struct camera_truth *truth, const struct pose_result *res) {
    struct canvas c = {CAMERA_WIDTH * IMG_SCALE, CAMERA_HEIGHT * IMG_SCALE, NULL};
    c.rgb = malloc((size_t)c.w * (size_t)c.h * 3u);
    if (c.rgb == NULL) {
        return -1;
    }
    for (int y = 0; y < c.h; ++y) {
        for (int x = 0; x < c.w; ++x) {
            /* Square-root tone curve so the 6 % plate is visible beside the reflectors. */
            double g = frame->gray[y / IMG_SCALE][x / IMG_SCALE] / (double)CAMERA_FULL_SCALE;
            uint8_t v = (uint8_t)lround(255.0 * sqrt(fmin(fmax(g, 0.0), 1.0)) * 0.8);
            uint8_t col[3] = {v, v, v};
            put_px(&c, x, y, col);
        }
    }
    static const uint8_t blue[3] = {60, 140, 255};
    static const uint8_t green[3] = {40, 230, 60};
    static const uint8_t red[3] = {255, 40, 40};
    static const uint8_t cyan[3] = {0, 230, 230};
    static const uint8_t yellow[3] = {255, 220, 0};
    /* Estimated pose: every catalog marker reprojected, as a cyan circle of its size. */
    bool valid = res->status == POSE_STATUS_OK || res->status == POSE_STATUS_DEGRADED;
    if (valid) {
        for (size_t m = 0; m < scene->n_markers; ++m) {
            const float *p = scene->markers[m].position_mm;
            double cam[3];
            for (int i = 0; i < 3; ++i) {
                cam[i] = (double)res->r[i][0] * (double)p[0] + (double)res->r[i][1] * (double)p[1] +
                         (double)res->r[i][2] * (double)p[2] + (double)res->t_mm[i];
            }
            double u = k->fx * cam[0] / cam[2] + k->cx;
            double v = k->fy * cam[1] / cam[2] + k->cy;
            draw_circle(&c, u, v, 0.5 * (double)scene->markers[m].diameter_mm * k->fx / cam[2],
                        cyan);
        }
    }
    for (size_t m = 0; m < scene->n_markers; ++m) {
        if (truth->markers[m].in_scene) {
            draw_cross(&c, truth->markers[m].u, truth->markers[m].v, 2, blue);
        }
    }
    for (size_t i = 0; i < res->n_blobs; ++i) {
        int marker = -1;
        for (size_t j = 0; j < res->n_matches; ++j) {
            if (res->matches[j].blob == i) {
                marker = res->matches[j].marker;
            }
        }
        const struct pose_blob *b = &res->blobs[i];
        draw_cross(&c, (double)b->u_px, (double)b->v_px, 5, marker >= 0 ? green : red);
        if (marker >= 0) {
            int x = (int)lround(((double)b->u_px + 0.5) * IMG_SCALE) + 8;
            int y = (int)lround(((double)b->v_px + 0.5) * IMG_SCALE) + 4;
            draw_number(&c, x, y, marker + 1, yellow); /* paper numbering 1..8 */
        }
    }
    int rc = camera_png_write(path, c.rgb, c.w, c.h);
    free(c.rgb);
    return rc;
}

/* ---- main ------------------------------------------------------------------- */

static double now_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int host_sim_camera_main(int argc, char **argv) {
    struct options o;
    int rc = parse_options(argc, argv, &o);
    if (rc != 0) {
        return rc < 0 ? 0 : rc;
    }
    struct camera_intrinsics k;
    camera_paper_intrinsics(&k);
    struct pose_camera cam;
    pose_camera_paper(&cam);
    struct pose_config cfg;
    pose_config_default(&cfg);
    static struct pose_pipeline pipe;
    if (pose_init(&pipe, &cfg, &cam, pose_paper_target, POSE_PAPER_TARGET_COUNT) != POSE_OK) {
        fprintf(stderr, "camera: pose_init rejected the default configuration\n");
        return EXIT_IO;
    }
    /* Open the report first: a bad path fails before minutes of rendering. */
    FILE *out = fopen(o.report, "w");
    if (out == NULL) {
        fprintf(stderr, "camera: --report %s: %s\n", o.report, strerror(errno));
        return EXIT_IO;
    }
    struct camera_scenario sc = {o.range_mm, (int)o.spurious, (int)o.missing, 20.0,
                                 o.allow_partial};
    struct camera_noise noise = {o.gray_noise, o.depth_noise};
    struct camera_rng rng;
    camera_rng_seed(&rng, o.seed);
    static struct camera_frame frame;
    static struct camera_scene scene;
    struct camera_truth truth;
    struct pose_result res;
    struct camera_eval ev;

    long valid = 0, correct = 0, complete = 0, status_count[POSE_STATUS_COUNT] = {0};
    long visible_sum = 0, detected_sum = 0, matched_sum = 0, wrong_sum = 0;
    double rot_sq = 0, pos_sq = 0, rot_max = 0, pos_max = 0;
    long ok_frames = 0, ok_wrong = 0;
    double ok_rot_sq = 0, ok_pos_sq = 0;
    double extract_sq = 0, raw_sq = 0, final_sq = 0;
    long n_extract = 0, n_final = 0, refine_iter_sum = 0, pose_draws = 0;
    double pipeline_seconds = 0.0;
    for (long f = 0; f < o.frames; ++f) {
        if (camera_random_scene(&k, &sc, &rng, &scene) != 0) {
            fprintf(stderr,
                    "camera: frame %ld: no pose keeps all markers in view at --range-mm %g "
                    "(or no room for %ld spurious blobs); use a longer range or "
                    "--allow-partial\n",
                    f, o.range_mm, o.spurious);
            fclose(out);
            remove(o.report); /* no half-written report */
            return EXIT_USAGE;
        }
        pose_draws += scene.pose_draws;
        camera_render(&k, &scene, &noise, (int)o.supersample, &rng, &frame, &truth);
        struct pose_frame pf = {&frame.gray[0][0], &frame.range_mm[0][0], CAMERA_WIDTH,
                                CAMERA_HEIGHT, CAMERA_WIDTH};
        uint16_t bx = 0, by = 0;
        double t0 = now_seconds();
        int err = pose_process(&pipe, &pf, &res, &bx, &by);
        pipeline_seconds += now_seconds() - t0;
        if (err != POSE_OK) {
            fprintf(stderr, "camera: frame %ld: pose_process failed: %s (pixel %u,%u)\n", f,
                    pose_err_name(err), bx, by);
            fclose(out);
            remove(o.report);
            return EXIT_IO;
        }
        camera_evaluate(&scene, &truth, &res, &ev);
        if (o.verbose) {
            fprintf(stderr,
                    "frame %ld: %s blobs %u visible %d detected %d matches %u wrong %d "
                    "rot %.4f deg pos %.3f mm iter %u anneal %u active %u cut %u comps %u "
                    "rejected size %u dim %u ecc %u notell %u\n",
                    f, pose_status_name(res.status), res.n_blobs, ev.visible, ev.detected,
                    res.n_matches, ev.wrong, ev.rot_err_deg, ev.pos_err_mm, res.refine_iterations,
                    res.anneal_steps, res.active_pixels, res.cut_level, res.components,
                    res.rejected[POSE_REJECT_SIZE], res.rejected[POSE_REJECT_DIM],
                    res.rejected[POSE_REJECT_ECCENTRIC], res.rejected[POSE_REJECT_NOT_ELLIPSE]);
            for (size_t i = 0; i < res.n_blobs; ++i) {
                const struct pose_blob *b = &res.blobs[i];
                fprintf(stderr,
                        "  blob %zu: (%.3f, %.3f) range %.1f se %.2f px %u ratio %.3f peak %.0f "
                        "ellipse %d/%d truth %d anneal %d\n",
                        i, (double)b->u_px, (double)b->v_px, (double)b->range_mm,
                        (double)b->range_se_mm, b->pixels, (double)b->axis_ratio,
                        (double)b->peak_response, b->ellipse_checked, b->ellipse_ok,
                        ev.blob_marker[i], pipe.ws.assignment[i]);
            }
        }
        ++status_count[res.status];
        visible_sum += ev.visible;
        detected_sum += ev.detected;
        extract_sq += ev.extract_sq;
        raw_sq += ev.raw_sq;
        n_extract += ev.n_extract;
        if (ev.valid) {
            ++valid;
            matched_sum += ev.matched_ok;
            wrong_sum += ev.wrong;
            final_sq += ev.final_sq;
            n_final += ev.n_final;
            rot_sq += ev.rot_err_deg * ev.rot_err_deg;
            pos_sq += ev.pos_err_mm * ev.pos_err_mm;
            rot_max = fmax(rot_max, ev.rot_err_deg);
            pos_max = fmax(pos_max, ev.pos_err_mm);
            refine_iter_sum += res.refine_iterations;
            if (ev.correct) {
                ++correct;
            }
            if (res.status == POSE_STATUS_OK) {
                ++ok_frames;
                ok_wrong += !ev.correct;
                ok_rot_sq += ev.rot_err_deg * ev.rot_err_deg;
                ok_pos_sq += ev.pos_err_mm * ev.pos_err_mm;
            }
            if (ev.complete) {
                ++complete;
            }
        }
        if (f == 0 && o.image != NULL) {
            if (write_image(o.image, &k, &frame, &scene, &truth, &res) != 0) {
                fprintf(stderr, "camera: --image %s: %s\n", o.image, strerror(errno));
                fclose(out);
                remove(o.report);
                return EXIT_IO;
            }
        }
    }
    double nf = (double)o.frames;
    double nv = valid > 0 ? (double)valid : 1.0;
    fprintf(out, "{\n");
    fprintf(out,
            "  \"frames\": %ld, \"range_mm\": %g, \"spurious\": %ld, \"missing\": %ld,\n"
            "  \"depth_noise\": %g, \"gray_noise\": %g, \"seed\": %" PRIu64
            ", \"allow_partial\": %s, \"supersample\": %ld,\n",
            o.frames, o.range_mm, o.spurious, o.missing, o.depth_noise, o.gray_noise, o.seed,
            o.allow_partial ? "true" : "false", o.supersample);
    fprintf(out, "  \"valid_rate\": %.6f,\n", (double)valid / nf);
    fprintf(out, "  \"match_rate\": %.6f,\n", (double)correct / nf);
    fprintf(out, "  \"complete_match_rate\": %.6f,\n", (double)complete / nf);
    /* The same restricted to status OK (>= 4 matches, converged): DEGRADED = 3 matches. */
    double nok = ok_frames > 0 ? (double)ok_frames : 1.0;
    fprintf(out, "  \"ok_rate\": %.6f,\n", (double)ok_frames / nf);
    fprintf(out, "  \"ok_wrong_frames\": %ld,\n", ok_wrong);
    fprintf(out, "  \"rot_err_deg_rms_ok\": %.6f,\n", ok_frames ? sqrt(ok_rot_sq / nok) : -1.0);
    fprintf(out, "  \"pos_err_mm_rms_ok\": %.6f,\n", ok_frames ? sqrt(ok_pos_sq / nok) : -1.0);
    fprintf(out, "  \"rot_err_deg_rms\": %.6f,\n", valid ? sqrt(rot_sq / nv) : -1.0);
    fprintf(out, "  \"rot_err_deg_max\": %.6f,\n", valid ? rot_max : -1.0);
    fprintf(out, "  \"pos_err_mm_rms\": %.6f,\n", valid ? sqrt(pos_sq / nv) : -1.0);
    fprintf(out, "  \"pos_err_mm_max\": %.6f,\n", valid ? pos_max : -1.0);
    fprintf(out, "  \"centroid_err_px_rms\": %.6f,\n",
            n_final ? sqrt(final_sq / (double)n_final) : -1.0);
    fprintf(out, "  \"centroid_extract_err_px_rms\": %.6f,\n",
            n_extract ? sqrt(extract_sq / (double)n_extract) : -1.0);
    fprintf(out, "  \"centroid_raw_err_px_rms\": %.6f,\n",
            n_extract ? sqrt(raw_sq / (double)n_extract) : -1.0);
    fprintf(out, "  \"markers_visible_mean\": %.4f,\n", (double)visible_sum / nf);
    fprintf(out, "  \"markers_detected_mean\": %.4f,\n", (double)detected_sum / nf);
    fprintf(out, "  \"markers_matched_mean\": %.4f,\n", (double)matched_sum / nv);
    fprintf(out, "  \"wrong_matches\": %ld,\n", wrong_sum);
    fprintf(out, "  \"refine_iterations_mean\": %.2f,\n", (double)refine_iter_sum / nv);
    fprintf(out, "  \"pipeline_ms_mean\": %.4f,\n", 1e3 * pipeline_seconds / nf);
    /* > 1: some drawn rotations could not keep all markers in view and were redrawn. */
    fprintf(out, "  \"pose_draws_per_frame\": %.4f,\n", (double)pose_draws / nf);
    fprintf(out, "  \"status\": {");
    for (int s = 0; s < POSE_STATUS_COUNT; ++s) {
        fprintf(out, "%s\"%s\": %ld", s ? ", " : "", pose_status_name((enum pose_status)s),
                status_count[s]);
    }
    fprintf(out, "}\n}\n");
    if (fclose(out) != 0) {
        fprintf(stderr, "camera: --report %s: %s\n", o.report, strerror(errno));
        return EXIT_IO;
    }
    printf("camera: %ld frames at %g mm: valid %.4f, match %.4f, rot %.4f deg rms, pos %.3f mm "
           "rms, centroid %.4f px rms\n",
           o.frames, o.range_mm, (double)valid / nf, (double)correct / nf,
           valid ? sqrt(rot_sq / nv) : -1.0, valid ? sqrt(pos_sq / nv) : -1.0,
           n_final ? sqrt(final_sq / (double)n_final) : -1.0);
    return 0;
}
