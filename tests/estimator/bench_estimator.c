/*
 * bench_estimator: the first paper's simulation protocol (Sec. IV: 100
 * positions from −5° to 5°, N = 100 readings per position, σ = 2 mm) and the
 * variations, run through the fixed-point estimator facade
 * (estimator/attitude.h) exactly as the firmware calls it, one row at a time.
 *
 * For every scenario and estimator it prints the RMS and mean absolute α and β
 * errors over the windows the estimator reported as valid, beside the
 * Cramér-Rao bound of the same windows (hostlib/scene, scene/crb.h: the linear model
 * of docs/explanation/architecture.md with the true per-sensor noise and the readings an oracle
 * would keep), and the largest difference between the fixed-point outputs and
 * a plain double implementation of the same algorithms on the same data.
 * It also reproduces the shape of the paper's Table I.
 *
 * Scenario generation is hostlib/scene (shared with `host_sim scenario`).
 * Host only; floating point is fine here.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_steps.h"
#include "estimator/attitude.h"
#include "scene/crb.h"
#include "scene/geometry.h"
#include "scene/real_noise.h"
#include "scene/scenario.h"

#define MAX_N ATTITUDE_WINDOW_MAX
#define PI    3.14159265358979323846
#define DNAN  ((double)NAN)

struct scenario {
    const char *label;
    const char *scene_name;
    uint32_t window; /* 0: the scenario's own N */
};

static const struct scenario scenarios[] = {
    {"paper Sec. IV (sigma 2 mm)", "table1", 0},
    {"one sensor sigma 6 mm", "hetero", 0},
    {"beta uniform +-4 deg", "crossaxis", 0},
    {"2% gross outliers, status 0", "outliers", 0},
    {"5% flagged", "flagged", 0},
    {"sensor missing, 20% of windows", "dropout", 0},
    {"real VL53L0X noise", "realnoise", 0},
    {"N = 10", "table1", 10},
};
#define N_SCENARIOS (sizeof scenarios / sizeof scenarios[0])

struct acc {
    uint32_t windows;     /* windows seen */
    uint32_t valid_alpha; /* windows with a reported α */
    uint32_t valid_beta;
    double se_a, ae_a, crb2_a; /* Σ err², Σ|err|, Σ bound² over valid α windows */
    double se_b, ae_b, crb2_b;
    double worst_ratio_a;    /* max |err| / bound over valid α windows */
    double product_at_worst; /* the product consensus's |err| / bound in that window */
    double max_fixdbl;       /* max |fixed − double| (deg), α and β */
    uint32_t compared;       /* windows with a double comparison */
    uint32_t reasons[ATTITUDE_REASON_COUNT]; /* reason of every window */
    uint32_t ok;                             /* windows with status ok */
    double sd2_a, sd2_b;                     /* Σ sd² over valid α / β windows */
    uint32_t within3, beyond6;               /* |err| <= 3 sd, > 6 sd, both axes counted */
};

/* Paper Table I: per-estimate window-mean errors on the table1 scenario. */
struct table1 {
    double sum_abs[7], sum[7], sum2[7], sum_abs2[7];
    uint32_t n[7];
};

/* ---------------------------------------------------------------------------- */
/* double-precision reference of the same algorithms, from the window's rows     */
/* ---------------------------------------------------------------------------- */

struct wrow {
    uint16_t r[4];
    uint8_t valid; /* present and status 0 */
    uint8_t kalman_used;
};

static int cmp_int(const void *a, const void *b) {
    const int x = *(const int *)a, y = *(const int *)b;
    return (x > y) - (x < y);
}

/* The window gate of window_stats.c in double: same rule, same integers. */
static void gate_double(const struct wrow *rows, int n, const struct attitude_config *cfg,
                        uint8_t used[MAX_N]) {
    for (int i = 0; i < n; ++i) {
        used[i] = rows[i].valid;
    }
    if (cfg->gate_sigmas_q8 == 0) {
        return;
    }
    for (int k = 0; k < 4; ++k) {
        int v[MAX_N], m = 0;
        for (int i = 0; i < n; ++i) {
            if (rows[i].valid & (1u << k)) {
                v[m++] = rows[i].r[k];
            }
        }
        if (m == 0) {
            continue;
        }
        qsort(v, (size_t)m, sizeof v[0], cmp_int);
        const int med_x2 = v[(m - 1) / 2] + v[m / 2];
        int d[MAX_N];
        for (int i = 0; i < m; ++i) {
            d[i] = abs(2 * v[i] - med_x2);
        }
        qsort(d, (size_t)m, sizeof d[0], cmp_int);
        const double mad_x2 = d[(m - 1) / 2];
        double thr = mad_x2 * (97163.0 / 65536.0) * cfg->gate_sigmas_q8 / 256.0;
        thr = floor(thr);
        if (thr < 2.0 * cfg->gate_floor_mm) {
            thr = 2.0 * cfg->gate_floor_mm;
        }
        for (int i = 0; i < n; ++i) {
            if ((rows[i].valid & (1u << k)) && abs(2 * rows[i].r[k] - med_x2) > thr) {
                used[i] = (uint8_t)(used[i] & ~(1u << k));
            }
        }
    }
}

/* 3x3 solve of the weighted least squares of Eq. 5; returns 0 if singular. */
static int wls3(const double x[4], const double var[4], const bool use[4], double arm,
                double th[3]) {
    static const double h[4][3] = {{1, -1, 0}, {1, 0, 1}, {1, 1, 0}, {1, 0, -1}};
    double m[3][4] = {{0}};
    for (int k = 0; k < 4; ++k) {
        if (!use[k]) {
            continue;
        }
        const double hk[3] = {h[k][0], h[k][1] * arm, h[k][2] * arm};
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                m[i][j] += hk[i] * hk[j] / var[k];
            }
            m[i][3] += hk[i] * x[k] / var[k];
        }
    }
    for (int c = 0; c < 3; ++c) {
        int p = c;
        for (int r = c + 1; r < 3; ++r) {
            if (fabs(m[r][c]) > fabs(m[p][c])) {
                p = r;
            }
        }
        if (fabs(m[p][c]) < 1e-12) {
            return 0;
        }
        for (int j = 0; j < 4; ++j) {
            const double t = m[c][j];
            m[c][j] = m[p][j];
            m[p][j] = t;
        }
        for (int r = 0; r < 3; ++r) {
            if (r != c) {
                const double f = m[r][c] / m[c][c];
                for (int j = 0; j < 4; ++j) {
                    m[r][j] -= f * m[c][j];
                }
            }
        }
    }
    for (int i = 0; i < 3; ++i) {
        th[i] = m[i][3] / m[i][i];
    }
    return 1;
}

static double deg(double rad) {
    return rad * 180.0 / PI;
}

/* The five α (axis 0) or β (axis 1) estimates of one row, radians. */
static void angles_double(const uint16_t r[4], double arm, int axis, double out[5]) {
    const double xa = r[0], xb = r[1], xc = r[2], xd = r[3];
    if (axis == 0) {
        out[0] = atan((xb - xa) / arm);
        out[1] = atan((xd - xa) / arm);
        out[2] = atan((xc - xb) / arm);
        out[3] = atan((xc - xd) / arm);
        out[4] = atan((xc - xa) / (2 * arm));
    } else {
        out[0] = atan((xa - xd) / arm);
        out[1] = atan((xc - xd) / arm);
        out[2] = atan((xb - xa) / arm);
        out[3] = atan((xb - xc) / arm);
        out[4] = atan((xb - xd) / (2 * arm));
    }
}

static const uint8_t angle_sensors[2][5] = {{0x3, 0x9, 0x6, 0xC, 0x5}, {0x9, 0xC, 0x3, 0x6, 0xA}};

struct dbl_out {
    bool product_ok[2];
    double product[2]; /* deg */
    double mean[2];
    bool mean_ok[2];
    bool paper_ok[2];
    double paper[2];
    bool kalman_ok;
    double kalman[2];
};

static void reference(const struct wrow *rows, int n, const struct attitude_config *cfg,
                      const double r_mm2[4], struct dbl_out *o) {
    memset(o, 0, sizeof *o);
    const double arm = cfg->arm_um / 1000.0;
    uint8_t used[MAX_N];
    gate_double(rows, n, cfg, used);

    /* product: BLUE on the per-sensor means */
    double mean[4] = {0}, var[4] = {0};
    bool use[4];
    for (int k = 0; k < 4; ++k) {
        double s = 0, s2 = 0;
        int m = 0;
        for (int i = 0; i < n; ++i) {
            if (used[i] & (1u << k)) {
                s += rows[i].r[k];
                s2 += (double)rows[i].r[k] * rows[i].r[k];
                m++;
            }
        }
        use[k] = m > 0;
        if (m > 0) {
            mean[k] = s / m;
            double v = m > 1 ? (s2 - s * s / m) / (m - 1) : 0;
            if (v < 1.0 / 12) {
                v = 1.0 / 12;
            }
            var[k] = v / m;
        }
    }
    double th[3];
    if (wls3(mean, var, use, arm, th)) {
        o->product_ok[0] = o->product_ok[1] = true;
        o->product[0] = deg(atan(th[1]));
        o->product[1] = deg(atan(th[2]));
    } else {
        /* one axis may still be observable: A and C alone give α, B and D β */
        if (use[0] && use[2]) {
            o->product_ok[0] = true;
            o->product[0] = deg(atan((mean[2] - mean[0]) / (2 * arm)));
        }
        if (use[1] && use[3]) {
            o->product_ok[1] = true;
            o->product[1] = deg(atan((mean[1] - mean[3]) / (2 * arm)));
        }
    }

    for (int axis = 0; axis < 2; ++axis) {
        /* mean of the five: per-angle means over their own rows */
        double sum[5] = {0};
        int cnt[5] = {0};
        double cs[5] = {0}, cp[5][5] = {{0}};
        int complete = 0;
        for (int i = 0; i < n; ++i) {
            double a[5];
            angles_double(rows[i].r, arm, axis, a);
            for (int j = 0; j < 5; ++j) {
                if ((used[i] & angle_sensors[axis][j]) == angle_sensors[axis][j]) {
                    sum[j] += a[j];
                    cnt[j]++;
                }
            }
            if (used[i] == 0x0F) {
                complete++;
                for (int j = 0; j < 5; ++j) {
                    cs[j] += a[j];
                    for (int l = 0; l < 5; ++l) {
                        cp[j][l] += a[j] * a[l];
                    }
                }
            }
        }
        double msum = 0;
        int mn = 0;
        for (int j = 0; j < 5; ++j) {
            if (cnt[j] > 0) {
                msum += sum[j] / cnt[j];
                mn++;
            }
        }
        o->mean_ok[axis] = mn > 0;
        o->mean[axis] = mn > 0 ? deg(msum / mn) : 0;

        /* paper: Alg. 1 in double, udeg units as the fixed point */
        if (complete >= 2) {
            double v[5], c[5][5], p[5][5];
            bool ok = true;
            for (int j = 0; j < 5; ++j) {
                v[j] = deg(cs[j] / complete) * 1e6;
            }
            for (int j = 0; j < 5 && ok; ++j) {
                double rs = 0;
                for (int l = 0; l < 5; ++l) {
                    c[j][l] = (cp[j][l] - cs[j] * cs[l] / complete) / (complete - 1) *
                              (180e6 / PI) * (180e6 / PI);
                    if (c[j][l] == 0.0) {
                        ok = false;
                    }
                    rs += 1.0 / c[j][l];
                }
                if (!(rs > 0)) {
                    ok = false;
                }
                for (int l = 0; l < 5 && ok; ++l) {
                    p[j][l] = (1.0 / c[j][l]) / rs;
                }
            }
            const double tol = cfg->consensus_tolerance_udeg;
            for (int it = 0; ok && it <= cfg->paper_max_iterations; ++it) {
                double lo = 1e300, hi = -1e300;
                for (int j = 0; j < 5; ++j) {
                    lo = fmin(lo, v[j]);
                    hi = fmax(hi, v[j]);
                }
                if (hi - lo <= tol) {
                    o->paper_ok[axis] = true;
                    o->paper[axis] = (v[0] + v[1] + v[2] + v[3] + v[4]) / 5 / 1e6;
                    break;
                }
                double nv[5];
                for (int j = 0; j < 5; ++j) {
                    nv[j] = 0;
                    for (int l = 0; l < 5; ++l) {
                        nv[j] += p[j][l] * v[l];
                    }
                    if (fabs(nv[j]) > 360e6) {
                        ok = false;
                    }
                }
                memcpy(v, nv, sizeof v);
            }
        }
    }

    /* Kalman: the same accepted readings, the same R, diffuse prior, Joseph-free
     * textbook update in double (Alg. 2 with scalar measurements) */
    static const double h[4][3] = {{1, -1, 0}, {1, 0, 1}, {1, 1, 0}, {1, 0, -1}};
    double x[3] = {0, 0, 0};
    double P[3][3] = {{0}};
    for (int i = 0; i < 3; ++i) {
        P[i][i] = 16777216.0;
    }
    for (int i = 0; i < n; ++i) {
        for (int k = 0; k < 4; ++k) {
            if (!(rows[i].kalman_used & (1u << k))) {
                continue;
            }
            double g[3], s = r_mm2[k], pred = 0;
            for (int a = 0; a < 3; ++a) {
                g[a] = 0;
                for (int b = 0; b < 3; ++b) {
                    g[a] += P[a][b] * h[k][b];
                }
            }
            for (int a = 0; a < 3; ++a) {
                s += h[k][a] * g[a];
                pred += h[k][a] * x[a];
            }
            const double e = rows[i].r[k] - pred;
            for (int a = 0; a < 3; ++a) {
                x[a] += g[a] / s * e;
            }
            for (int a = 0; a < 3; ++a) {
                for (int b = 0; b < 3; ++b) {
                    P[a][b] -= g[a] * g[b] / s;
                }
            }
        }
    }
    o->kalman_ok = true;
    o->kalman[0] = deg(atan(x[1] / arm));
    o->kalman[1] = deg(atan(x[2] / arm));
}

/* ---------------------------------------------------------------------------- */

static double udeg_to_deg(int32_t u) {
    return u / 1e6;
}

static void account(struct acc *a, const struct attitude_estimate *e, double ta, double tb,
                    double crb_a, double crb_b) {
    a->windows++;
    a->reasons[e->reason]++;
    if (e->alpha_valid) {
        const double err = udeg_to_deg(e->alpha_udeg) - ta;
        a->valid_alpha++;
        a->se_a += err * err;
        a->ae_a += fabs(err);
        a->crb2_a += crb_a * crb_a;
        const double sd = udeg_to_deg(e->alpha_sd_udeg);
        a->sd2_a += sd * sd;
        a->within3 += fabs(err) <= 3.0 * sd;
        a->beyond6 += fabs(err) > 6.0 * sd;
        if (fabs(err) / crb_a > a->worst_ratio_a) {
            a->worst_ratio_a = fabs(err) / crb_a;
        }
    }
    if (e->beta_valid) {
        const double err = udeg_to_deg(e->beta_udeg) - tb;
        a->valid_beta++;
        a->se_b += err * err;
        a->ae_b += fabs(err);
        a->crb2_b += crb_b * crb_b;
        const double sd = udeg_to_deg(e->beta_sd_udeg);
        a->sd2_b += sd * sd;
        a->within3 += fabs(err) <= 3.0 * sd;
        a->beyond6 += fabs(err) > 6.0 * sd;
    }
    a->ok += e->status == ATTITUDE_OK;
}

static void fixdbl(struct acc *a, const struct attitude_estimate *e, const bool ok[2],
                   const double v[2]) {
    bool any = false;
    if (e->alpha_valid && ok[0]) {
        a->max_fixdbl = fmax(a->max_fixdbl, fabs(udeg_to_deg(e->alpha_udeg) - v[0]));
        any = true;
    }
    if (e->beta_valid && ok[1]) {
        a->max_fixdbl = fmax(a->max_fixdbl, fabs(udeg_to_deg(e->beta_udeg) - v[1]));
        any = true;
    }
    a->compared += any ? 1u : 0u;
}

/* Offset-stability prior of the runs (-1: the default configuration's). */
static int offset_prior_um = -1;

static int run_scenario(const struct scenario *sc, uint64_t first_seed, unsigned seeds,
                        const struct scene_real_noise *real, struct acc acc[ATTITUDE_EST_COUNT],
                        struct table1 *t1, double *crb_rms_a) {
    static struct attitude_state st; /* ~5 KiB, as on the MCU */
    static struct wrow rows[MAX_N];
    struct scene_config cfg;
    if (scene_config_named(sc->scene_name, &cfg) != 0) {
        fprintf(stderr, "bench_estimator: unknown scenario %s\n", sc->scene_name);
        return -1;
    }
    if (sc->window != 0u) {
        cfg.samples_per_position = sc->window;
    }
    double crb_sum = 0;
    uint32_t crb_n = 0;
    for (unsigned s = 0; s < seeds; ++s) {
        struct scene_gen gen;
        char err[512];
        if (scene_gen_init_with(&gen, &cfg, first_seed + s, real, err, sizeof err) != 0) {
            fprintf(stderr, "bench_estimator: %s\n", err);
            return -1;
        }
        struct attitude_config acfg;
        attitude_config_default(&acfg);
        acfg.calibration.calibrated = true; /* ideal sensors: an exact calibration */
        acfg.arm_um = (int32_t)lround(cfg.arm_mm * 1000.0);
        acfg.window = (uint16_t)cfg.samples_per_position;
        if (offset_prior_um >= 0) { /* the sd table's second pass: another prior */
            acfg.offset_stability_um = (uint16_t)offset_prior_um;
        }
        const int rc = attitude_init(&st, &acfg);
        if (rc != ATTITUDE_ERR_NONE) {
            fprintf(stderr, "bench_estimator: %s\n", attitude_error_message(rc));
            return -1;
        }
        const int n = (int)cfg.samples_per_position;
        int in_window = 0;
        uint32_t n_oracle[4] = {0};
        double sigma[4] = {0}, offset[4] = {0}, truth_a = 0, truth_b = 0;
        double r_at_start[4] = {0};
        struct scene_row row;
        struct scene_row_info info;
        int g;
        while ((g = scene_gen_next(&gen, &row, &info, err, sizeof err)) == 0) {
            if (in_window == 0) {
                memset(n_oracle, 0, sizeof n_oracle);
                for (int k = 0; k < 4; ++k) {
                    r_at_start[k] = (double)st.kalman.r[k] / 4294967296.0;
                }
            }
            for (int k = 0; k < 4; ++k) {
                if (scene_row_valid(&row, (unsigned)k) && !info.outlier[k]) {
                    n_oracle[k]++;
                }
                sigma[k] = info.sigma_mm[k];
                offset[k] = info.offset_sd_mm[k];
            }
            truth_a = row.alpha_deg;
            truth_b = row.beta_deg;
            memcpy(rows[in_window].r, row.range_mm, sizeof rows[in_window].r);
            rows[in_window].valid = 0;
            for (int k = 0; k < 4; ++k) {
                if (scene_row_valid(&row, (unsigned)k)) {
                    rows[in_window].valid = (uint8_t)(rows[in_window].valid | (1u << k));
                }
            }
            in_window++;
            struct attitude_output out;
            if (!attitude_push_sample(&st, row.range_mm, row.status, row.present, &out)) {
                continue;
            }
            /* the Kalman filter's own accepted readings, from the window's rows */
            for (int i = 0; i < n; ++i) {
                const struct window_row *wr = window_row_at(&st.window, (uint16_t)(n - 1 - i));
                rows[i].kalman_used = (uint8_t)(wr->aux & 0x0Fu);
            }
            struct scene_crb crb;
            if (scene_crb_with_offset(cfg.arm_mm, sigma, offset, n_oracle, truth_a, truth_b,
                                      &crb) != 0) {
                crb.sd_alpha_deg = crb.sd_beta_deg = DNAN;
            }
            if (isfinite(crb.sd_alpha_deg)) {
                crb_sum += crb.sd_alpha_deg * crb.sd_alpha_deg;
                crb_n++;
            }
            struct dbl_out ref;
            reference(rows, n, &acfg, r_at_start, &ref);
            const double worst_before = acc[ATTITUDE_EST_PAPER].worst_ratio_a;
            for (int e = 0; e < ATTITUDE_EST_COUNT; ++e) {
                account(&acc[e], &out.est[e], truth_a, truth_b, crb.sd_alpha_deg, crb.sd_beta_deg);
            }
            if (acc[ATTITUDE_EST_PAPER].worst_ratio_a > worst_before) {
                const struct attitude_estimate *c = &out.est[ATTITUDE_EST_CONSENSUS];
                acc[ATTITUDE_EST_PAPER].product_at_worst =
                    fabs(udeg_to_deg(c->alpha_udeg) - truth_a) / crb.sd_alpha_deg;
            }
            fixdbl(&acc[ATTITUDE_EST_CONSENSUS], &out.est[ATTITUDE_EST_CONSENSUS], ref.product_ok,
                   ref.product);
            fixdbl(&acc[ATTITUDE_EST_MEAN], &out.est[ATTITUDE_EST_MEAN], ref.mean_ok, ref.mean);
            fixdbl(&acc[ATTITUDE_EST_PAPER], &out.est[ATTITUDE_EST_PAPER], ref.paper_ok, ref.paper);
            const bool kok[2] = {ref.kalman_ok, ref.kalman_ok};
            fixdbl(&acc[ATTITUDE_EST_KALMAN], &out.est[ATTITUDE_EST_KALMAN], kok, ref.kalman);
            if (t1 != NULL) {
                for (int i = 0; i < 5; ++i) {
                    if (st.stats.alpha.count[i] > 0) {
                        const double m = (double)st.stats.alpha.mean[i] / 65536.0 / 1e6;
                        const double d = m - truth_a;
                        t1->sum_abs[i] += fabs(d);
                        t1->sum_abs2[i] += d * d;
                        t1->sum[i] += d;
                        t1->sum2[i] += d * d;
                        t1->n[i]++;
                    }
                }
                const int which[2] = {ATTITUDE_EST_PAPER, ATTITUDE_EST_CONSENSUS};
                for (int j = 0; j < 2; ++j) {
                    const struct attitude_estimate *e = &out.est[which[j]];
                    if (e->alpha_valid) {
                        const double d = udeg_to_deg(e->alpha_udeg) - truth_a;
                        t1->sum_abs[5 + j] += fabs(d);
                        t1->sum_abs2[5 + j] += d * d;
                        t1->sum[5 + j] += d;
                        t1->sum2[5 + j] += d * d;
                        t1->n[5 + j]++;
                    }
                }
            }
            in_window = 0;
        }
        if (g < 0) {
            fprintf(stderr, "bench_estimator: %s\n", err);
            scene_gen_free(&gen);
            return -1;
        }
        scene_gen_free(&gen);
    }
    *crb_rms_a = crb_n > 0 ? sqrt(crb_sum / crb_n) : DNAN;
    return 0;
}

static void usage(FILE *to) {
    fprintf(to, "usage: bench_estimator [--seeds S] [--first-seed F] [--steps]\n"
                "  runs every scenario S times (default 20) from seed F (default 1) and prints\n"
                "  the tables of docs/explanation/accuracy.md; exit status 0, 1 on a missing\n"
                "  real-noise log, 2 on a bad argument; --steps: only the step-detection\n"
                "  delays\n");
}

int main(int argc, char **argv) {
    unsigned seeds = 20;
    uint64_t first_seed = 1;
    bool steps = false;
    for (int i = 1; i < argc; ++i) {
        char *end = NULL;
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            usage(stdout);
            return 0;
        }
        if (strcmp(argv[i], "--seeds") == 0 && i + 1 < argc) {
            const unsigned long v = strtoul(argv[++i], &end, 10);
            if (*end != '\0' || v == 0 || v > 100000) {
                fprintf(stderr, "bench_estimator: --seeds: '%s' is not a count in 1..100000\n",
                        argv[i]);
                return 2;
            }
            seeds = (unsigned)v;
        } else if (strcmp(argv[i], "--first-seed") == 0 && i + 1 < argc) {
            first_seed = strtoull(argv[++i], &end, 10);
            if (*end != '\0') {
                fprintf(stderr, "bench_estimator: --first-seed: '%s' is not a number\n", argv[i]);
                return 2;
            }
        } else if (strcmp(argv[i], "--steps") == 0) {
            steps = true;
        } else {
            fprintf(stderr, "bench_estimator: unknown argument '%s'\n", argv[i]);
            usage(stderr);
            return 2;
        }
    }
    if (steps) {
        return bench_steps(seeds, first_seed);
    }
    static struct scene_real_noise real;
    char path[1200], err[512];
    if (scene_real_noise_default_path(path, sizeof path) != 0 ||
        scene_real_noise_load(path, &real, err, sizeof err) != 0) {
        fprintf(stderr, "bench_estimator: real noise: %s\n", err);
        return 1;
    }

    printf("# Estimator benchmark: %u seeds x 100 windows per scenario (seeds %llu..%llu)\n\n",
           seeds, (unsigned long long)first_seed, (unsigned long long)(first_seed + seeds - 1));
    printf(
        "Errors in degrees over the windows each estimator reported (valid%%). CRB: the\n"
        "Cramer-Rao bound of the same windows (RMS over them). ratio = RMS alpha / CRB.\n"
        "worst = max |alpha error| / per-window bound. fix-dbl: max |fixed - double| (deg).\n\n");
    printf("| scenario | estimator | valid%% | RMS a | MAE a | RMS b | MAE b | CRB a | CRB b | "
           "ratio | worst | fix-dbl |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    static const int order[ATTITUDE_EST_COUNT] = {ATTITUDE_EST_CONSENSUS, ATTITUDE_EST_KALMAN,
                                                  ATTITUDE_EST_PAPER, ATTITUDE_EST_MEAN};
    struct table1 t1;
    memset(&t1, 0, sizeof t1);
    static uint32_t paper_reasons[N_SCENARIOS][ATTITUDE_REASON_COUNT];
    static struct acc sd_rows[N_SCENARIOS][ATTITUDE_EST_COUNT];
    double paper_worst[N_SCENARIOS][2];
    uint32_t paper_seen[ATTITUDE_REASON_COUNT] = {0};
    int status = 0;
    for (size_t s = 0; s < N_SCENARIOS; ++s) {
        struct acc acc[ATTITUDE_EST_COUNT];
        memset(acc, 0, sizeof acc);
        double crb_rms = DNAN;
        if (run_scenario(&scenarios[s], first_seed, seeds, &real, acc, s == 0 ? &t1 : NULL,
                         &crb_rms) != 0) {
            status = 1;
            continue;
        }
        for (int o = 0; o < ATTITUDE_EST_COUNT; ++o) {
            const struct acc *a = &acc[order[o]];
            const double va = a->valid_alpha, vb = a->valid_beta;
            const double rms_a = va > 0 ? sqrt(a->se_a / va) : DNAN;
            const double crb_a = va > 0 ? sqrt(a->crb2_a / va) : DNAN;
            printf("| %s | %s | %.1f | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f | %.3f | %.2f | "
                   "%.6f |\n",
                   o == 0 ? scenarios[s].label : "", attitude_estimator_name(order[o]),
                   100.0 * va / (a->windows ? a->windows : 1), rms_a, va > 0 ? a->ae_a / va : DNAN,
                   vb > 0 ? sqrt(a->se_b / vb) : DNAN, vb > 0 ? a->ae_b / vb : DNAN, crb_a,
                   vb > 0 ? sqrt(a->crb2_b / vb) : DNAN, rms_a / crb_a, a->worst_ratio_a,
                   a->max_fixdbl);
        }
        (void)crb_rms;
        for (int o = 0; o < ATTITUDE_EST_COUNT; ++o) {
            sd_rows[s][o] = acc[order[o]];
        }
        paper_worst[s][0] = acc[ATTITUDE_EST_PAPER].worst_ratio_a;
        paper_worst[s][1] = acc[ATTITUDE_EST_PAPER].product_at_worst;
        for (int r = 0; r < ATTITUDE_REASON_COUNT; ++r) {
            paper_reasons[s][r] = acc[ATTITUDE_EST_PAPER].reasons[r];
            paper_seen[r] += paper_reasons[s][r];
        }
    }
    printf("\n## Paper consensus outcomes (windows per reason, all scenarios above)\n\n");
    printf("| scenario |");
    for (int r = 0; r < ATTITUDE_REASON_COUNT; ++r) {
        if (paper_seen[r] > 0) {
            printf(" %s |", attitude_reason_name((enum attitude_reason)r));
        }
    }
    printf("\n|---|");
    for (int r = 0; r < ATTITUDE_REASON_COUNT; ++r) {
        if (paper_seen[r] > 0) {
            printf("---|");
        }
    }
    printf("\n");
    for (size_t s = 0; s < N_SCENARIOS; ++s) {
        printf("| %s |", scenarios[s].label);
        for (int r = 0; r < ATTITUDE_REASON_COUNT; ++r) {
            if (paper_seen[r] > 0) {
                printf(" %u |", paper_reasons[s][r]);
            }
        }
        printf("\n");
    }

    printf("\nThe paper consensus's worst reported alpha (|error| / per-window bound) and the\n"
           "product consensus's own error in that same window:\n\n");
    printf("| scenario | paper worst | product in that window |\n|---|---|---|\n");
    for (size_t s = 0; s < N_SCENARIOS; ++s) {
        printf("| %s | %.2f | %.2f |\n", scenarios[s].label, paper_worst[s][0], paper_worst[s][1]);
    }

    printf("\n## Standard deviations against the Cramer-Rao bound\n\n");
    printf("sd/CRB = RMS of each estimate's alpha_sd over RMS of the window's bound (the sd\n"
           "includes the default offset-stability prior, which the bound does not; 'no prior':\n"
           "the same windows with offset_stability_um = 0); err/sd =\n"
           "RMS alpha error / RMS alpha_sd; <=3sd, >6sd: shares of the answered angles (alpha\n"
           "and beta) within 3 sd and beyond 6 sd; ok%%: windows with status ok.\n\n");
    /* the same windows once more with no offset prior: what the learnt terms and the
     * window's own noise give (the estimates are the same; only sd and status differ) */
    static struct acc sd_rows0[N_SCENARIOS][ATTITUDE_EST_COUNT];
    offset_prior_um = 0;
    for (size_t s = 0; s < N_SCENARIOS; ++s) {
        struct acc acc0[ATTITUDE_EST_COUNT];
        memset(acc0, 0, sizeof acc0);
        double crb_rms0 = DNAN;
        if (run_scenario(&scenarios[s], first_seed, seeds, &real, acc0, NULL, &crb_rms0) != 0) {
            status = 1;
            continue;
        }
        for (int o = 0; o < ATTITUDE_EST_COUNT; ++o) {
            sd_rows0[s][o] = acc0[order[o]];
        }
    }
    offset_prior_um = -1;
    printf("| scenario | estimator | ok%% | sd/CRB a | sd/CRB b | sd/CRB a, no prior | err/sd a | "
           "err/sd b | <=3sd%% | >6sd%% |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for (size_t s = 0; s < N_SCENARIOS; ++s) {
        for (int o = 0; o < ATTITUDE_EST_COUNT; ++o) {
            const struct acc *a = &sd_rows[s][o];
            const struct acc *a0 = &sd_rows0[s][o];
            const double n = (double)a->valid_alpha + a->valid_beta;
            printf("| %s | %s | %.1f | %.3f | %.3f | %.3f | %.3f | %.3f | %.2f | %.3f |\n",
                   o == 0 ? scenarios[s].label : "", attitude_estimator_name(order[o]),
                   100.0 * a->ok / (a->windows ? a->windows : 1), sqrt(a->sd2_a / a->crb2_a),
                   sqrt(a->sd2_b / a->crb2_b), sqrt(a0->sd2_a / a0->crb2_a),
                   sqrt(a->se_a / a->sd2_a), sqrt(a->se_b / a->sd2_b),
                   n > 0 ? 100.0 * a->within3 / n : DNAN, n > 0 ? 100.0 * a->beyond6 / n : DNAN);
        }
    }

    printf("\n## Shape of the paper's Table I (scenario 1, a = 30 mm)\n\n");
    printf("Window means of each estimate against the true alpha, degrees: mean |error| and\n"
           "the standard deviation of |error| (what the paper's 'average' and 'std' match:\n"
           "for Gaussian errors std|e|/mean|e| = 0.755), and the RMS error.\n\n");
    printf("| estimate | windows | average [deg] | std [deg] | RMS [deg] | paper average | "
           "paper std |\n");
    printf("|---|---|---|---|---|---|---|\n");
    static const char *const names[7] = {
        "alpha1",           "alpha2", "alpha3", "alpha4", "alpha5", "paper consensus (valid only)",
        "product consensus"};
    static const double paper_avg[7] = {0.39, 0.37, 0.42, 0.39, 0.25, 0.24, DNAN};
    static const double paper_std[7] = {0.29, 0.30, 0.32, 0.27, 0.20, 0.18, DNAN};
    for (int i = 0; i < 7; ++i) {
        const double n = t1.n[i];
        const double mae = n > 0 ? t1.sum_abs[i] / n : DNAN;
        const double sd_abs = n > 1 ? sqrt((t1.sum_abs2[i] - n * mae * mae) / (n - 1)) : DNAN;
        printf("| %s | %u | %.3f | %.3f | %.3f | ", names[i], t1.n[i], mae, sd_abs,
               n > 0 ? sqrt(t1.sum2[i] / n) : DNAN);
        if (isnan(paper_avg[i])) {
            printf("- | - |\n");
        } else {
            printf("%.2f | %.2f |\n", paper_avg[i], paper_std[i]);
        }
    }
    scene_real_noise_free(&real);
    return status;
}
