/*
 * pose_solve and pose_process: recovery of known poses from ideal blobs and from
 * rendered frames, wrong-match rejection, status rules, configuration checks,
 * and the 700 mm goal scenario on a short run.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "camera/camera.h"
#include "pose/pose.h"

static struct pose_pipeline pipe;
static struct camera_frame frame;
static struct pose_result res;
static struct camera_scene scene;

static void init_default(void) {
    struct pose_config cfg;
    pose_config_default(&cfg);
    struct pose_camera cam;
    pose_camera_paper(&cam);
    assert_int_equal(pose_init(&pipe, &cfg, &cam, pose_paper_target, POSE_PAPER_TARGET_COUNT),
                     POSE_OK);
}

static double pos_error(const struct camera_pose *truth, const struct pose_result *r) {
    double dx = (double)r->t_mm[0] - truth->t[0];
    double dy = (double)r->t_mm[1] - truth->t[1];
    double dz = (double)r->t_mm[2] - truth->t[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

/*
 * Ideal blobs: centroids at the exact image-ellipse centres (what an unbiased
 * extraction finds), ranges exact to the disc centres.
 */
static size_t ideal_blobs(const struct camera_pose *pose, struct pose_blob *blobs,
                          const bool *skip) {
    struct camera_intrinsics k;
    camera_paper_intrinsics(&k);
    size_t n = 0;
    for (size_t m = 0; m < POSE_PAPER_TARGET_COUNT; ++m) {
        if (skip != NULL && skip[m]) {
            continue;
        }
        const float *p = pose_paper_target[m].position_mm;
        double c[3];
        for (int i = 0; i < 3; ++i) {
            c[i] = pose->r[i][0] * (double)p[0] + pose->r[i][1] * (double)p[1] +
                   pose->r[i][2] * (double)p[2] + pose->t[i];
        }
        double r = 0.5 * (double)pose_paper_target[m].diameter_mm;
        double nrm[3] = {pose->r[0][2], pose->r[1][2], pose->r[2][2]};
        double vx = c[2] * c[0] + r * r * nrm[2] * nrm[0];
        double vy = c[2] * c[1] + r * r * nrm[2] * nrm[1];
        double vz = c[2] * c[2] - r * r * (1.0 - nrm[2] * nrm[2]);
        memset(&blobs[n], 0, sizeof blobs[n]);
        blobs[n].u_px = (float)(k.fx * vx / vz + k.cx);
        blobs[n].v_px = (float)(k.fy * vy / vz + k.cy);
        blobs[n].range_mm = (float)sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        blobs[n].range_mean_mm = blobs[n].range_mm;
        blobs[n].range_se_mm = 0.2f;
        blobs[n].pixels = 500;
        blobs[n].centroid_sigma_px = 0.02f;
        ++n;
    }
    return n;
}

static void test_solve_recovers_pose_from_ideal_blobs(void **state) {
    (void)state;
    init_default();
    struct camera_rng rng;
    camera_rng_seed(&rng, 99);
    for (int trial = 0; trial < 50; ++trial) {
        double t[3] = {camera_rng_uniform(&rng, -80, 80), camera_rng_uniform(&rng, -60, 60),
                       camera_rng_uniform(&rng, 700, 3000)};
        struct camera_pose pose;
        camera_pose_from_angles(camera_rng_uniform(&rng, -20, 20),
                                camera_rng_uniform(&rng, -20, 20),
                                camera_rng_uniform(&rng, -20, 20), t, &pose);
        struct pose_blob blobs[POSE_MAX_OBS];
        size_t n = ideal_blobs(&pose, blobs, NULL);
        uint8_t bi[8], mi[8];
        for (size_t i = 0; i < n; ++i) {
            bi[i] = (uint8_t)i;
            mi[i] = (uint8_t)i;
        }
        memset(&res, 0, sizeof res);
        assert_int_equal(pose_solve(&pipe, blobs, bi, mi, n, &res), POSE_OK);
        assert_int_equal(res.status, POSE_STATUS_OK);
        assert_int_equal(res.n_matches, 8);
        double rot = camera_rotation_error_deg(pose.r, res.r);
        double pos = pos_error(&pose, &res);
        /* float arithmetic: 1e-7 relative of a 3 m range is 0.3 um; allow far more */
        assert_true(rot < 0.003);
        assert_true(pos < 0.05);
        assert_true(res.reproj_rms_px < 0.01f);
    }
}

static void test_solve_drops_wrong_matches(void **state) {
    (void)state;
    init_default();
    struct camera_pose pose;
    camera_pose_from_angles(8.0, -12.0, 5.0, (const double[3]){20.0, -15.0, 900.0}, &pose);
    struct pose_blob blobs[POSE_MAX_OBS];
    size_t n = ideal_blobs(&pose, blobs, NULL);
    uint8_t bi[8], mi[8];
    for (size_t i = 0; i < n; ++i) {
        bi[i] = (uint8_t)i;
        mi[i] = (uint8_t)i;
    }
    mi[2] = 4; /* two blobs swapped: both matches wrong */
    mi[4] = 2;
    memset(&res, 0, sizeof res);
    assert_int_equal(pose_solve(&pipe, blobs, bi, mi, n, &res), POSE_OK);
    assert_int_equal(res.status, POSE_STATUS_OK);
    assert_true(res.dropped_matches >= 2);
    for (size_t j = 0; j < res.n_matches; ++j) {
        assert_int_equal(res.matches[j].blob, res.matches[j].marker); /* survivors correct */
    }
    assert_true(camera_rotation_error_deg(pose.r, res.r) < 0.01);
    assert_true(pos_error(&pose, &res) < 0.1);
}

static void test_three_matches_are_degraded(void **state) {
    (void)state;
    init_default();
    struct camera_pose pose;
    camera_pose_from_angles(0.0, 10.0, 0.0, (const double[3]){0.0, 0.0, 800.0}, &pose);
    bool skip[8] = {false, true, false, true, true, false, true, true}; /* keep 1, 3, 6 */
    struct pose_blob blobs[POSE_MAX_OBS];
    size_t n = ideal_blobs(&pose, blobs, skip);
    assert_int_equal(n, 3);
    uint8_t bi[3] = {0, 1, 2}, mi[3] = {0, 2, 5};
    memset(&res, 0, sizeof res);
    assert_int_equal(pose_solve(&pipe, blobs, bi, mi, n, &res), POSE_OK);
    assert_int_equal(res.status, POSE_STATUS_DEGRADED);
    assert_true(camera_rotation_error_deg(pose.r, res.r) < 0.05);
    memset(&res, 0, sizeof res);
    assert_int_equal(pose_solve(&pipe, blobs, bi, mi, 2, &res), POSE_OK);
    assert_int_equal(res.status, POSE_STATUS_NO_MATCH);
}

static void test_init_rejects_bad_configuration(void **state) {
    (void)state;
    struct pose_config cfg;
    pose_config_default(&cfg);
    struct pose_camera cam;
    pose_camera_paper(&cam);
    assert_int_equal(pose_init(NULL, &cfg, &cam, pose_paper_target, 8), POSE_ERR_INVALID);
    assert_int_equal(pose_init(&pipe, &cfg, &cam, pose_paper_target, 1), POSE_ERR_INVALID);
    assert_int_equal(pose_init(&pipe, &cfg, &cam, pose_paper_target, POSE_MAX_MARKERS + 1),
                     POSE_ERR_INVALID);
    struct pose_config bad = cfg;
    bad.nlog_sigma_px = 2.0f; /* 3 sigma beyond the largest kernel */
    assert_int_equal(pose_init(&pipe, &bad, &cam, pose_paper_target, 8), POSE_ERR_INVALID);
    bad = cfg;
    bad.gray_threshold = 5000;
    assert_int_equal(pose_init(&pipe, &bad, &cam, pose_paper_target, 8), POSE_ERR_INVALID);
    bad = cfg;
    bad.match.beta_rate = 0.9f;
    assert_int_equal(pose_init(&pipe, &bad, &cam, pose_paper_target, 8), POSE_ERR_INVALID);
    struct pose_camera badcam = cam;
    badcam.width = 2000;
    assert_int_equal(pose_init(&pipe, &cfg, &badcam, pose_paper_target, 8), POSE_ERR_INVALID);
    struct pose_marker zero[2] = {{{0, 0, 0}, 0.0f}, {{100, 0, 0}, 10.0f}};
    assert_int_equal(pose_init(&pipe, &cfg, &cam, zero, 2), POSE_ERR_INVALID);
    assert_int_equal(pose_init(&pipe, &cfg, &cam, pose_paper_target, 8), POSE_OK);
}

struct run_stats {
    int frames, valid, correct;
    double rot_sq, pos_sq;
};

static void run_frames(double range, int spurious, int missing, double depth_noise,
                       double gray_noise, int frames, uint64_t seed, struct run_stats *st) {
    init_default();
    struct camera_intrinsics k;
    camera_paper_intrinsics(&k);
    struct camera_scenario sc = {range, spurious, missing, 20.0, false};
    struct camera_noise noise = {gray_noise, depth_noise};
    struct camera_rng rng;
    camera_rng_seed(&rng, seed);
    memset(st, 0, sizeof *st);
    for (int f = 0; f < frames; ++f) {
        assert_int_equal(camera_random_scene(&k, &sc, &rng, &scene), 0);
        struct camera_truth truth;
        camera_render(&k, &scene, &noise, 8, &rng, &frame, &truth);
        struct pose_frame pf = {&frame.gray[0][0], &frame.range_mm[0][0], CAMERA_WIDTH,
                                CAMERA_HEIGHT, CAMERA_WIDTH};
        assert_int_equal(pose_process(&pipe, &pf, &res, NULL, NULL), POSE_OK);
        struct camera_eval ev;
        camera_evaluate(&scene, &truth, &res, &ev);
        ++st->frames;
        if (ev.valid) {
            ++st->valid;
            st->correct += ev.correct;
            st->rot_sq += ev.rot_err_deg * ev.rot_err_deg;
            st->pos_sq += ev.pos_err_mm * ev.pos_err_mm;
        }
    }
}

static void test_process_recovers_rendered_poses(void **state) {
    (void)state;
    struct run_stats st;
    run_frames(700.0, 0, 0, 0.0, 0.0, 20, 11, &st);
    assert_int_equal(st.valid, 20);
    assert_int_equal(st.correct, 20);
    assert_true(sqrt(st.rot_sq / st.valid) < 0.04);
    assert_true(sqrt(st.pos_sq / st.valid) < 0.3);
    run_frames(1500.0, 0, 0, 0.0, 0.0, 20, 12, &st);
    assert_int_equal(st.correct, 20);
    assert_true(sqrt(st.rot_sq / st.valid) < 0.1);
    assert_true(sqrt(st.pos_sq / st.valid) < 1.0);
}

/* The goal scenario, on a short run (host_sim camera measures it on thousands). */
static void test_goal_scenario_700mm(void **state) {
    (void)state;
    struct run_stats st;
    run_frames(700.0, 2, 1, 0.01, 0.02, 40, 2024, &st);
    double rot = sqrt(st.rot_sq / st.valid);
    double pos = sqrt(st.pos_sq / st.valid);
    print_message("goal scenario, 40 frames: valid %d, correct %d, rot %.4f deg, pos %.3f mm\n",
                  st.valid, st.correct, rot, pos);
    assert_int_equal(st.valid, 40);
    assert_int_equal(st.correct, 40);
    assert_true(rot <= 0.08);
    assert_true(pos <= 1.5);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_solve_recovers_pose_from_ideal_blobs),
        cmocka_unit_test(test_solve_drops_wrong_matches),
        cmocka_unit_test(test_three_matches_are_degraded),
        cmocka_unit_test(test_init_rejects_bad_configuration),
        cmocka_unit_test(test_process_recovers_rendered_poses),
        cmocka_unit_test(test_goal_scenario_700mm),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
