/*
 * pose_linalg: 3x3 SVD, weighted absolute orientation with the reflection guard,
 * rotation angles and the perspective image of a circle's centre.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "pose/pose.h"
#include "pose/pose_linalg.h"

static uint64_t rng_state = 0x853c49e6748fea9bull;

static double uniform(double lo, double hi) {
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return lo + (hi - lo) * (double)(rng_state >> 11) / 9007199254740992.0;
}

static void random_rotation(float r[3][3], double max_angle) {
    double ax[3] = {uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)};
    double n = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    double th = uniform(-max_angle, max_angle);
    double c = cos(th), s = sin(th), t = 1.0 - c;
    double x = ax[0] / n, y = ax[1] / n, z = ax[2] / n;
    double m[3][3] = {{t * x * x + c, t * x * y - s * z, t * x * z + s * y},
                      {t * x * y + s * z, t * y * y + c, t * y * z - s * x},
                      {t * x * z - s * y, t * y * z + s * x, t * z * z + c}};
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            r[i][j] = (float)m[i][j];
        }
    }
}

static double det3d(const float m[3][3]) {
#define D(i, j) ((double)m[i][j])
    return D(0, 0) * (D(1, 1) * D(2, 2) - D(1, 2) * D(2, 1)) -
           D(0, 1) * (D(1, 0) * D(2, 2) - D(1, 2) * D(2, 0)) +
           D(0, 2) * (D(1, 0) * D(2, 1) - D(1, 1) * D(2, 0));
#undef D
}

/* max |M^T M - I| */
static double orthonormality_error(const float m[3][3]) {
    double worst = 0.0;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            double d = 0.0;
            for (int k = 0; k < 3; ++k) {
                d += (double)m[k][i] * (double)m[k][j];
            }
            worst = fmax(worst, fabs(d - (i == j ? 1.0 : 0.0)));
        }
    }
    return worst;
}

static void check_svd(const float a[3][3], double rel_tol) {
    float u[3][3], s[3], v[3][3];
    int sweeps = pose_svd3(a, u, s, v);
    assert_true(sweeps > 0);
    assert_true(s[0] >= s[1] && s[1] >= s[2] && s[2] >= 0.0f);
    assert_true(orthonormality_error(u) < 1e-5);
    assert_true(orthonormality_error(v) < 1e-5);
    double scale = fmax((double)s[0], 1e-30);
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            double rec = 0.0;
            for (int k = 0; k < 3; ++k) {
                rec += (double)u[i][k] * (double)s[k] * (double)v[j][k];
            }
            assert_true(fabs(rec - (double)a[i][j]) <= rel_tol * scale);
        }
    }
}

static void test_svd_random_matrices_reconstruct(void **state) {
    (void)state;
    for (int trial = 0; trial < 500; ++trial) {
        float a[3][3];
        double mag = pow(10.0, uniform(-3, 6));
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                a[i][j] = (float)(mag * uniform(-1, 1));
            }
        }
        check_svd(a, 2e-6);
    }
}

static void test_svd_rank_deficient_and_zero(void **state) {
    (void)state;
    /* rank 2: third column = first + second */
    float a2[3][3] = {{1, 2, 3}, {4, 5, 9}, {-2, 7, 5}};
    check_svd(a2, 2e-6);
    float u[3][3], s[3], v[3][3];
    pose_svd3(a2, u, s, v);
    assert_true(s[2] < 1e-5f * s[0]);
    /* rank 1: outer product */
    float a1[3][3] = {{2, 4, 6}, {1, 2, 3}, {-3, -6, -9}};
    check_svd(a1, 2e-6);
    float z[3][3] = {{0}};
    assert_true(pose_svd3(z, u, s, v) > 0);
    assert_true(s[0] == 0.0f && s[1] == 0.0f && s[2] == 0.0f);
    assert_true(orthonormality_error(u) < 1e-6);
}

static void test_kabsch_recovers_exact_transform(void **state) {
    (void)state;
    for (int trial = 0; trial < 200; ++trial) {
        float r_true[3][3];
        random_rotation(r_true, 3.14159);
        float t_true[3] = {(float)uniform(-500, 500), (float)uniform(-500, 500),
                           (float)uniform(300, 15000)};
        float model[8][3], obs[8][3];
        for (int i = 0; i < 8; ++i) {
            for (int k = 0; k < 3; ++k) {
                model[i][k] = (float)uniform(-200, 200);
            }
            for (int k = 0; k < 3; ++k) {
                obs[i][k] = r_true[k][0] * model[i][0] + r_true[k][1] * model[i][1] +
                            r_true[k][2] * model[i][2] + t_true[k];
            }
        }
        float r[3][3], t[3];
        assert_int_equal(
            pose_kabsch((const float(*)[3])model, (const float(*)[3])obs, NULL, 8, r, t), POSE_OK);
        assert_true(pose_rotation_angle(r, r_true) < 2e-5f);
        for (int k = 0; k < 3; ++k) {
            /* float resolution of t at 15 m is ~1e-3 mm; allow a few ulps of the lever. */
            assert_true(fabsf(t[k] - t_true[k]) < 0.02f);
        }
    }
}

static void test_kabsch_reflection_guard(void **state) {
    (void)state;
    /* Observations are a mirror image of the model: no rotation fits, and the
     * unguarded V U^T would be that mirror (det -1). The guard must return a rotation. */
    float model[6][3] = {{100, 0, 0},    {0, 80, 0},     {0, 0, 60},
                         {-50, -40, 10}, {30, -70, -20}, {-20, 50, -45}};
    float obs[6][3];
    for (int i = 0; i < 6; ++i) {
        obs[i][0] = model[i][0];
        obs[i][1] = model[i][1];
        obs[i][2] = -model[i][2] + 1000.0f;
    }
    float r[3][3], t[3];
    assert_int_equal(pose_kabsch((const float(*)[3])model, (const float(*)[3])obs, NULL, 6, r, t),
                     POSE_OK);
    assert_true(fabs(det3d(r) - 1.0) < 1e-5);
    assert_true(orthonormality_error(r) < 1e-5);
}

static void test_kabsch_weights_exclude_outlier(void **state) {
    (void)state;
    float r_true[3][3];
    random_rotation(r_true, 0.5);
    float t_true[3] = {10, -20, 700};
    float model[6][3] = {{-170, -105, 100}, {-65, -105, 150}, {35, -105, 100},
                         {150, 85, 150},    {30, 85, 150},    {-135, 85, 100}};
    float obs[6][3];
    for (int i = 0; i < 6; ++i) {
        for (int k = 0; k < 3; ++k) {
            obs[i][k] = r_true[k][0] * model[i][0] + r_true[k][1] * model[i][1] +
                        r_true[k][2] * model[i][2] + t_true[k];
        }
    }
    obs[2][0] += 300.0f; /* gross outlier */
    float w[6] = {1, 1, 0, 1, 1, 1};
    float r[3][3], t[3];
    assert_int_equal(pose_kabsch((const float(*)[3])model, (const float(*)[3])obs, w, 6, r, t),
                     POSE_OK);
    assert_true(pose_rotation_angle(r, r_true) < 2e-5f);
    /* and unweighted, the outlier does pull the solution away */
    assert_int_equal(pose_kabsch((const float(*)[3])model, (const float(*)[3])obs, NULL, 6, r, t),
                     POSE_OK);
    assert_true(pose_rotation_angle(r, r_true) > 1e-2f);
}

static void test_kabsch_rejects_bad_input(void **state) {
    (void)state;
    float model[4][3] = {{0, 0, 0}, {100, 0, 0}, {200, 0, 0}, {300, 0, 0}}; /* collinear */
    float obs[4][3] = {{0, 0, 500}, {100, 0, 500}, {200, 0, 500}, {300, 0, 500}};
    float r[3][3], t[3];
    assert_int_equal(pose_kabsch((const float(*)[3])model, (const float(*)[3])obs, NULL, 4, r, t),
                     POSE_ERR_DEGENERATE);
    assert_int_equal(pose_kabsch((const float(*)[3])model, (const float(*)[3])obs, NULL, 2, r, t),
                     POSE_ERR_INVALID);
    float neg[4] = {1, 1, -1, 1};
    model[1][1] = 50.0f;
    assert_int_equal(pose_kabsch((const float(*)[3])model, (const float(*)[3])obs, neg, 4, r, t),
                     POSE_ERR_INVALID);
    float zero[4] = {0, 0, 0, 0};
    assert_int_equal(pose_kabsch((const float(*)[3])model, (const float(*)[3])obs, zero, 4, r, t),
                     POSE_ERR_INVALID);
}

static void test_rotation_angle_small_and_large(void **state) {
    (void)state;
    float id[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    double angles[] = {1e-5, 1e-4, 1e-3, 0.1, 1.0, 3.0};
    for (size_t k = 0; k < sizeof angles / sizeof angles[0]; ++k) {
        double a = angles[k];
        float rz[3][3] = {
            {(float)cos(a), (float)-sin(a), 0}, {(float)sin(a), (float)cos(a), 0}, {0, 0, 1}};
        double got = (double)pose_rotation_angle(id, rz);
        assert_true(fabs(got - a) <= 0.01 * a + 1e-7);
    }
}

/* The ellipse centre: midway between the extreme image points in u and in v. */
static void test_circle_image_centre_matches_projected_outline(void **state) {
    (void)state;
    for (int trial = 0; trial < 50; ++trial) {
        double c[3] = {uniform(-300, 300), uniform(-200, 200), uniform(150, 2000)};
        double n[3] = {uniform(-0.6, 0.6), uniform(-0.6, 0.6), -1.0};
        double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int k = 0; k < 3; ++k) {
            n[k] /= nn;
        }
        double radius = uniform(10, 45);
        /* orthonormal basis of the disc plane */
        double e1[3] = {1.0 - n[0] * n[0], -n[0] * n[1], -n[0] * n[2]};
        double l1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
        for (int k = 0; k < 3; ++k) {
            e1[k] /= l1;
        }
        double e2[3] = {n[1] * e1[2] - n[2] * e1[1], n[2] * e1[0] - n[0] * e1[2],
                        n[0] * e1[1] - n[1] * e1[0]};
        double umin = 1e9, umax = -1e9, vmin = 1e9, vmax = -1e9;
        for (int s = 0; s < 200000; ++s) {
            double a = 2.0 * 3.141592653589793 * s / 200000.0;
            double p[3];
            for (int k = 0; k < 3; ++k) {
                p[k] = c[k] + radius * (cos(a) * e1[k] + sin(a) * e2[k]);
            }
            umin = fmin(umin, p[0] / p[2]);
            umax = fmax(umax, p[0] / p[2]);
            vmin = fmin(vmin, p[1] / p[2]);
            vmax = fmax(vmax, p[1] / p[2]);
        }
        float cf[3] = {(float)c[0], (float)c[1], (float)c[2]};
        float nf[3] = {(float)n[0], (float)n[1], (float)n[2]};
        float out[2];
        assert_int_equal(pose_circle_image_centre(cf, nf, (float)radius, out), POSE_OK);
        /* 1e-6 in normalised units is 3e-4 px for the paper's camera */
        assert_true(fabs((double)out[0] - 0.5 * (umin + umax)) < 1e-6);
        assert_true(fabs((double)out[1] - 0.5 * (vmin + vmax)) < 1e-6);
        /* and the offset from the projected centre is real (not a no-op) when tilted */
        double offset = hypot((double)out[0] - c[0] / c[2], (double)out[1] - c[1] / c[2]);
        if (fabs(n[2]) < 0.95 && c[2] < 600 && radius > 30) {
            assert_true(offset > 1e-5);
        }
    }
    float behind[3] = {0, 0, -100};
    float n[3] = {0, 0, 1};
    float out[2];
    assert_int_equal(pose_circle_image_centre(behind, n, 10.0f, out), POSE_ERR_DEGENERATE);
}

static void test_error_and_status_names(void **state) {
    (void)state;
    /* Every code of the enum (pose's block, docs/reference/errors.md) has a name of its own, and
     * the numbers just outside it have none. */
    static const int codes[] = {POSE_OK, POSE_ERR_INVALID, POSE_ERR_FRAME, POSE_ERR_DEGENERATE,
                                POSE_ERR_NO_CONVERGE};
    const size_t n_codes = sizeof codes / sizeof codes[0];
    for (size_t i = 0; i < n_codes; ++i) {
        assert_string_not_equal(pose_err_name(codes[i]), "UNKNOWN");
        assert_true(codes[i] == POSE_OK || (codes[i] <= -80 && codes[i] >= -95));
        for (size_t j = 0; j < i; ++j) {
            assert_string_not_equal(pose_err_name(codes[i]), pose_err_name(codes[j]));
        }
    }
    assert_string_equal(pose_err_name(POSE_ERR_NO_CONVERGE - 1), "UNKNOWN");
    assert_string_equal(pose_err_name(-1), "UNKNOWN");
    assert_string_equal(pose_err_name(-99), "UNKNOWN");
    for (int s = 0; s < POSE_STATUS_COUNT; ++s) {
        assert_string_not_equal(pose_status_name((enum pose_status)s), "UNKNOWN");
        for (int q = 0; q < s; ++q) {
            assert_string_not_equal(pose_status_name((enum pose_status)s),
                                    pose_status_name((enum pose_status)q));
        }
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_svd_random_matrices_reconstruct),
        cmocka_unit_test(test_svd_rank_deficient_and_zero),
        cmocka_unit_test(test_kabsch_recovers_exact_transform),
        cmocka_unit_test(test_kabsch_reflection_guard),
        cmocka_unit_test(test_kabsch_weights_exclude_outlier),
        cmocka_unit_test(test_kabsch_rejects_bad_input),
        cmocka_unit_test(test_rotation_angle_small_and_large),
        cmocka_unit_test(test_circle_image_centre_matches_projected_outline),
        cmocka_unit_test(test_error_and_status_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
