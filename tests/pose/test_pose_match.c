/*
 * pose_match: deterministic annealing on pairwise distances under permutation,
 * spurious points, missing markers and noise; the catalog's distinct distances.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "pose/pose.h"
#include "pose/pose_match.h"

static uint64_t rng_state = 0x2545F4914F6CDD1Dull;

static double uniform(double lo, double hi) {
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return lo + (hi - lo) * (double)(rng_state >> 11) / 9007199254740992.0;
}

static double gauss(void) {
    double u1 = 1.0 - uniform(0, 1), u2 = uniform(0, 1);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * 3.141592653589793 * u2);
}

/* A target pose facing the camera with angles up to 20 deg, at `range` mm. */
static void random_pose(double r[3][3], double t[3], double range) {
    double a = uniform(-0.35, 0.35), b = uniform(-0.35, 0.35), c = uniform(-0.35, 0.35);
    double rx[3][3] = {{1, 0, 0}, {0, cos(a), -sin(a)}, {0, sin(a), cos(a)}};
    double ry[3][3] = {{cos(b), 0, sin(b)}, {0, 1, 0}, {-sin(b), 0, cos(b)}};
    double rz[3][3] = {{cos(c), -sin(c), 0}, {sin(c), cos(c), 0}, {0, 0, 1}};
    double face[3][3] = {{1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    double m1[3][3], m2[3][3];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            m1[i][j] = rz[i][0] * ry[0][j] + rz[i][1] * ry[1][j] + rz[i][2] * ry[2][j];
        }
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            m2[i][j] = m1[i][0] * rx[0][j] + m1[i][1] * rx[1][j] + m1[i][2] * rx[2][j];
        }
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            r[i][j] = m2[i][0] * face[0][j] + m2[i][1] * face[1][j] + m2[i][2] * face[2][j];
        }
    }
    t[0] = uniform(-50, 50);
    t[1] = uniform(-50, 50);
    t[2] = range;
}

/*
 * Builds observations: the visible markers (all but those in `hidden`) in a random
 * order, each with isotropic noise sigma_mm, plus n_spurious random points near
 * the target. truth[i] receives the marker index of observation i or -1.
 */
static size_t make_obs(struct pose_match_obs *obs, int *truth, const bool *hidden,
                       size_t n_spurious, double sigma_mm, double range) {
    double r[3][3], t[3];
    random_pose(r, t, range);
    size_t n = 0;
    for (size_t m = 0; m < POSE_PAPER_TARGET_COUNT; ++m) {
        if (hidden != NULL && hidden[m]) {
            continue;
        }
        const float *p = pose_paper_target[m].position_mm;
        for (int k = 0; k < 3; ++k) {
            double v = r[k][0] * (double)p[0] + r[k][1] * (double)p[1] + r[k][2] * (double)p[2] +
                       t[k] + sigma_mm * gauss();
            obs[n].point_mm[k] = (float)v;
        }
        obs[n].range_sigma_mm = (float)fmax(sigma_mm, 0.5);
        obs[n].lateral_sigma_mm = (float)fmax(sigma_mm, 0.5);
        truth[n] = (int)m;
        ++n;
    }
    for (size_t s = 0; s < n_spurious; ++s) {
        obs[n].point_mm[0] = (float)uniform(-250, 250);
        obs[n].point_mm[1] = (float)uniform(-200, 200);
        obs[n].point_mm[2] = (float)(range + uniform(-250, -60));
        obs[n].range_sigma_mm = (float)fmax(sigma_mm, 0.5);
        obs[n].lateral_sigma_mm = (float)fmax(sigma_mm, 0.5);
        truth[n] = -1;
        ++n;
    }
    /* shuffle (Fisher-Yates) so the order carries no information */
    for (size_t i = n; i-- > 1;) {
        size_t j = (size_t)uniform(0, (double)i + 1.0);
        if (j > i) {
            j = i;
        }
        struct pose_match_obs tmp = obs[i];
        obs[i] = obs[j];
        obs[j] = tmp;
        int tt = truth[i];
        truth[i] = truth[j];
        truth[j] = tt;
    }
    return n;
}

static struct pose_match_work work;

/* Runs the matcher; returns how many observations were assigned wrongly. */
static int run_case(const struct pose_match_obs *obs, const int *truth, size_t n, int *n_matched) {
    struct pose_match_config cfg;
    pose_match_config_default(&cfg);
    int8_t assignment[POSE_MAX_OBS];
    uint16_t steps = 0;
    int matches = pose_match(&cfg, pose_paper_target, POSE_PAPER_TARGET_COUNT, obs, n, &work,
                             assignment, &steps);
    assert_true(matches >= 0);
    assert_true(steps > 0);
    int wrong = 0;
    int counted = 0;
    bool used[POSE_MAX_MARKERS] = {false};
    for (size_t i = 0; i < n; ++i) {
        if (assignment[i] >= 0) {
            ++counted;
            assert_false(used[assignment[i]]); /* one-to-one */
            used[assignment[i]] = true;
            if (assignment[i] != truth[i]) {
                ++wrong;
            }
        }
    }
    assert_int_equal(counted, matches);
    *n_matched = matches;
    return wrong;
}

static void test_permuted_exact_catalog(void **state) {
    (void)state;
    for (int trial = 0; trial < 100; ++trial) {
        struct pose_match_obs obs[POSE_MAX_OBS];
        int truth[POSE_MAX_OBS];
        size_t n = make_obs(obs, truth, NULL, 0, 0.0, 700.0);
        int matched = 0;
        assert_int_equal(run_case(obs, truth, n, &matched), 0);
        assert_int_equal(matched, 8);
    }
}

static void test_spurious_points_left_unassigned(void **state) {
    (void)state;
    for (int trial = 0; trial < 200; ++trial) {
        struct pose_match_obs obs[POSE_MAX_OBS];
        int truth[POSE_MAX_OBS];
        size_t spurious = 1u + (size_t)trial % 6u;
        size_t n = make_obs(obs, truth, NULL, spurious, 0.5, 700.0);
        int matched = 0;
        assert_int_equal(run_case(obs, truth, n, &matched), 0);
        assert_int_equal(matched, 8);
    }
}

static void test_missing_markers(void **state) {
    (void)state;
    for (int trial = 0; trial < 200; ++trial) {
        struct pose_match_obs obs[POSE_MAX_OBS];
        int truth[POSE_MAX_OBS];
        bool hidden[POSE_PAPER_TARGET_COUNT] = {false};
        int missing = 1 + trial % 4; /* 1..4 hidden: 7..4 left */
        for (int h = 0; h < missing;) {
            size_t m = (size_t)uniform(0, POSE_PAPER_TARGET_COUNT);
            if (m < POSE_PAPER_TARGET_COUNT && !hidden[m]) {
                hidden[m] = true;
                ++h;
            }
        }
        size_t n = make_obs(obs, truth, hidden, (size_t)(trial % 3), 0.5, 700.0);
        int matched = 0;
        int wrong = run_case(obs, truth, n, &matched);
        if (wrong != 0 || matched != 8 - missing) {
            print_message("trial %d: %d hidden, %zu observations, %d matched, %d wrong\n", trial,
                          missing, n, matched, wrong);
            for (size_t i = 0; i < n; ++i) {
                print_message("  obs %zu truth %d:", i, truth[i]);
                for (size_t a = 0; a <= 8; ++a) {
                    print_message(" %.2f", (double)work.m[i][a]);
                }
                print_message("\\n");
            }
        }

        assert_int_equal(wrong, 0);

        assert_int_equal(matched, 8 - missing);
    }
}

static void test_noisy_points_at_range(void **state) {
    (void)state;
    /* 2 mm isotropic noise per point: the matcher's tolerance is built from sigma. */
    for (int trial = 0; trial < 100; ++trial) {
        struct pose_match_obs obs[POSE_MAX_OBS];
        int truth[POSE_MAX_OBS];
        size_t n = make_obs(obs, truth, NULL, 2, 2.0, 2000.0);
        int matched = 0;
        assert_int_equal(run_case(obs, truth, n, &matched), 0);
        assert_true(matched >= 7);
    }
}

static void test_too_few_or_bad_arguments(void **state) {
    (void)state;
    struct pose_match_config cfg;
    pose_match_config_default(&cfg);
    struct pose_match_obs obs[POSE_MAX_OBS + 1] = {{{0, 0, 700}, 1, 1}};
    int8_t assignment[POSE_MAX_OBS + 1];
    assert_int_equal(pose_match(&cfg, pose_paper_target, 8, obs, 1, &work, assignment, NULL), 0);
    assert_int_equal(assignment[0], -1);
    assert_int_equal(
        pose_match(&cfg, pose_paper_target, 8, obs, POSE_MAX_OBS + 1, &work, assignment, NULL),
        POSE_ERR_INVALID);
    assert_int_equal(pose_match(&cfg, pose_paper_target, 1, obs, 2, &work, assignment, NULL),
                     POSE_ERR_INVALID);
    struct pose_match_config bad = cfg;
    bad.beta_rate = 1.0f; /* no cooling: the schedule would never end */
    assert_int_equal(pose_match(&bad, pose_paper_target, 8, obs, 2, &work, assignment, NULL),
                     POSE_ERR_INVALID);
    bad = cfg;
    bad.sinkhorn_iterations = 0;
    assert_int_equal(pose_match(&bad, pose_paper_target, 8, obs, 2, &work, assignment, NULL),
                     POSE_ERR_INVALID);
    assert_int_equal(pose_match(NULL, pose_paper_target, 8, obs, 2, &work, assignment, NULL),
                     POSE_ERR_INVALID);
}

static void test_pair_index_is_a_bijection(void **state) {
    (void)state;
    for (size_t n = 2; n <= POSE_MAX_OBS; ++n) {
        bool seen[POSE_MAX_OBS_PAIRS] = {false};
        for (size_t i = 0; i < n; ++i) {
            for (size_t j = i + 1; j < n; ++j) {
                size_t k = pose_pair_index(i, j, n);
                assert_true(k < n * (n - 1) / 2);
                assert_false(seen[k]);
                seen[k] = true;
                assert_int_equal(pose_pair_index(j, i, n), k);
            }
        }
    }
}

/* The layout promise of pose_target.c: 28 distinct distances, >= 2 mm apart. */
static void test_catalog_distances_are_distinct(void **state) {
    (void)state;
    double d[28];
    size_t n = 0;
    for (size_t a = 0; a < 8; ++a) {
        for (size_t b = a + 1; b < 8; ++b) {
            double s = 0.0;
            for (int k = 0; k < 3; ++k) {
                double x = (double)pose_paper_target[a].position_mm[k] -
                           (double)pose_paper_target[b].position_mm[k];
                s += x * x;
            }
            d[n++] = sqrt(s);
        }
    }
    for (size_t i = 0; i < n; ++i) {
        for (size_t j = i + 1; j < n; ++j) {
            assert_true(fabs(d[i] - d[j]) >= 2.0);
        }
    }
    /* sizes and heights as the paper gives them */
    static const double heights[8] = {100, 150, 100, 100, 150, 150, 100, 150};
    for (size_t m = 0; m < 8; ++m) {
        assert_true(fabs((double)pose_paper_target[m].position_mm[2] - heights[m]) < 1e-6);
        assert_true(fabs((double)pose_paper_target[m].diameter_mm - (m < 4 ? 35.0 : 80.0)) < 1e-6);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_permuted_exact_catalog),
        cmocka_unit_test(test_spurious_points_left_unassigned),
        cmocka_unit_test(test_missing_markers),
        cmocka_unit_test(test_noisy_points_at_range),
        cmocka_unit_test(test_too_few_or_bad_arguments),
        cmocka_unit_test(test_pair_index_is_a_bijection),
        cmocka_unit_test(test_catalog_distances_are_distinct),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
