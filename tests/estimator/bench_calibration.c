/*
 * The calibration benchmark (docs/explanation/accuracy.md "Calibration"):
 * simulated heads with offsets uniform in ±20 mm and gains in 1 ± 3 % at 60, 100, 150 and
 * 200 mm, α and β uniform in ±5°, σ = 2 mm white noise, whole-mm readings, N = 100
 * tumbling, through the estimator API with four calibrations of the same head:
 *
 *   exact      the truth, stated exact (sd 0): the reference
 *   stated     the truth, with a stated sd (offsets 0.05 mm, gains 2e-4 by default)
 *   drawn      the truth plus an error drawn per head from the stated sd, which it states
 *   uncal      none (calibrated false): the parts' spread
 *
 * and for each the answered rows, ok rows, RMS error and RMS sd over both axes, the share
 * within 3 sd and beyond 6 sd, RMS error / RMS sd, and RMS error / the exact one's.
 * Usage: bench_calibration [--seed S] [--heads H] [--offset-sd-um U] [--gain-sd-ppm P]
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimator/attitude.h"

#define PI_D    3.14159265358979323846
#define ARM_MM  30.0
#define N_ROWS  100u
#define WINDOWS 2u
#define MODES   4u

static uint64_t rng_state = 1;

static double urand(void) {
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

static double gauss(void) {
    for (;;) {
        const double u = 2 * urand() - 1;
        const double v = 2 * urand() - 1;
        const double s = u * u + v * v;
        if (s > 0 && s < 1) {
            return u * sqrt(-2 * log(s) / s);
        }
    }
}

struct tally {
    unsigned windows;
    unsigned answers;
    unsigned ok;
    double err2;
    double sd2;
    unsigned axes;
    unsigned within3;
    unsigned beyond6;
};

static void count(struct tally *t, const struct attitude_estimate *e, double alpha, double beta) {
    t->windows++;
    if (!e->alpha_valid || !e->beta_valid) {
        return;
    }
    t->answers++;
    t->ok += e->status == ATTITUDE_OK ? 1u : 0u;
    const double err[2] = {e->alpha_udeg / 1e6 - alpha, e->beta_udeg / 1e6 - beta};
    const double sd[2] = {e->alpha_sd_udeg / 1e6, e->beta_sd_udeg / 1e6};
    for (unsigned i = 0; i < 2u; ++i) {
        t->err2 += err[i] * err[i];
        t->sd2 += sd[i] * sd[i];
        t->axes++;
        t->within3 += fabs(err[i]) <= 3 * sd[i] ? 1u : 0u;
        t->beyond6 += fabs(err[i]) > 6 * sd[i] ? 1u : 0u;
    }
}

static struct attitude_state st[MODES];
static struct attitude_output out[MODES];

/* The calibration mode m tells of a head (offsets mm, gains), errors drawn per head. */
static void calibration_of(unsigned m, const double off[4], const double gain[4],
                           const double eo[4], const double eg[4], uint32_t osd, uint32_t gsd,
                           struct calibration_head *c) {
    memset(c, 0, sizeof *c);
    c->calibrated = m != 3u;
    for (unsigned k = 0; k < 4u && c->calibrated; ++k) {
        const double e_o = m == 2u ? eo[k] : 0;
        const double e_g = m == 2u ? eg[k] : 0;
        c->offset_um[k] = (int32_t)lround((off[k] + e_o) * 1000);
        c->gain_ppm[k] = (int32_t)lround((gain[k] - 1 + e_g) * 1e6);
        c->offset_sd_um[k] = m == 0u ? 0u : osd;
        c->gain_sd_ppm[k] = m == 0u ? 0u : gsd;
    }
}

static int run(uint64_t seed, unsigned heads, uint32_t osd, uint32_t gsd) {
    static const char *const names[MODES] = {"exact", "stated", "drawn", "uncal"};
    static const double dists[4] = {60, 100, 150, 200};
    static const enum attitude_estimator ests[2] = {ATTITUDE_EST_CONSENSUS, ATTITUDE_EST_KALMAN};
    struct tally t[4][MODES][2];
    memset(t, 0, sizeof t);
    rng_state = seed ? seed : 1;
    const uint8_t status[4] = {0, 0, 0, 0};
    const bool present[4] = {true, true, true, true};
    for (unsigned h = 0; h < heads; ++h) {
        const unsigned di = h % 4u;
        double off[4];
        double gain[4];
        double eo[4];
        double eg[4];
        for (unsigned k = 0; k < 4u; ++k) {
            off[k] = 40 * urand() - 20;
            gain[k] = 1 + 0.06 * urand() - 0.03;
            eo[k] = osd / 1000.0 * gauss();
            eg[k] = gsd / 1e6 * gauss();
        }
        const double alpha = 10 * urand() - 5;
        const double beta = 10 * urand() - 5;
        const double ta = tan(alpha * PI_D / 180);
        const double tb = tan(beta * PI_D / 180);
        const double xbar = dists[di];
        const double x[4] = {xbar - ARM_MM * ta, xbar + ARM_MM * tb, xbar + ARM_MM * ta,
                             xbar - ARM_MM * tb};
        for (unsigned m = 0; m < MODES; ++m) {
            struct attitude_config cfg;
            attitude_config_default(&cfg);
            calibration_of(m, off, gain, eo, eg, osd, gsd, &cfg.calibration);
            if (attitude_init(&st[m], &cfg) != ATTITUDE_ERR_NONE) {
                fprintf(stderr, "bench_calibration: attitude_init refused head %u\n", h);
                return 1;
            }
        }
        for (unsigned r = 0; r < WINDOWS * N_ROWS; ++r) {
            uint16_t raw[4];
            for (unsigned k = 0; k < 4u; ++k) {
                const double v = gain[k] * x[k] + off[k] + 2.0 * gauss();
                raw[k] = (uint16_t)lround(v < 1 ? 1 : v);
            }
            for (unsigned m = 0; m < MODES; ++m) { /* the same readings for every mode */
                if (attitude_push_sample(&st[m], raw, status, present, &out[m])) {
                    for (unsigned e = 0; e < 2u; ++e) {
                        count(&t[di][m][e], &out[m].est[ests[e]], alpha, beta);
                    }
                }
            }
        }
    }
    printf("seed %llu, %u heads (offsets ±20 mm, gains ±3 %%, ±5°, σ 2 mm, N %u, %u windows "
           "each), stated sd %u µm, %u ppm\n\n",
           (unsigned long long)seed, heads, N_ROWS, WINDOWS, (unsigned)osd, (unsigned)gsd);
    printf("| estimator | calibration | x̄ mm | answered | ok | RMS err ° | RMS sd ° | within 3 sd "
           "| beyond 6 sd | RMS err / RMS sd | RMS err / exact's |\n");
    printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for (unsigned e = 0; e < 2u; ++e) {
        for (unsigned m = 0; m < MODES; ++m) {
            for (unsigned d = 0; d <= 4u; ++d) { /* d = 4: all distances */
                struct tally a;
                struct tally x0;
                memset(&a, 0, sizeof a);
                memset(&x0, 0, sizeof x0);
                for (unsigned i = 0; i < 4u; ++i) {
                    if (d == 4u || d == i) {
                        const struct tally *s = &t[i][m][e];
                        a.windows += s->windows;
                        a.answers += s->answers;
                        a.ok += s->ok;
                        a.err2 += s->err2;
                        a.sd2 += s->sd2;
                        a.axes += s->axes;
                        a.within3 += s->within3;
                        a.beyond6 += s->beyond6;
                        x0.err2 += t[i][0][e].err2;
                        x0.axes += t[i][0][e].axes;
                    }
                }
                const double rms = sqrt(a.err2 / (a.axes ? a.axes : 1));
                const double rsd = sqrt(a.sd2 / (a.axes ? a.axes : 1));
                const double rms0 = sqrt(x0.err2 / (x0.axes ? x0.axes : 1));
                char dist[16];
                (void)snprintf(dist, sizeof dist, d == 4u ? "all" : "%.0f", d == 4u ? 0 : dists[d]);
                printf("| %s | %s | %s | %.1f %% | %.1f %% | %.3f | %.3f | %.2f %% | %.3f %% | "
                       "%.2f | %.3f |\n",
                       attitude_estimator_name(ests[e]), names[m], dist,
                       100.0 * a.answers / (a.windows ? a.windows : 1),
                       100.0 * a.ok / (a.windows ? a.windows : 1), rms, rsd,
                       100.0 * a.within3 / (a.axes ? a.axes : 1),
                       100.0 * a.beyond6 / (a.axes ? a.axes : 1), rsd > 0 ? rms / rsd : 0,
                       rms0 > 0 ? rms / rms0 : 0);
            }
        }
    }
    return 0;
}

int main(int argc, char **argv) {
    uint64_t seed = 1;
    unsigned heads = 800;
    uint32_t osd = 50;
    uint32_t gsd = 200;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (strcmp(argv[i], "--seed") == 0) {
            seed = strtoull(argv[i + 1], NULL, 10);
        } else if (strcmp(argv[i], "--heads") == 0) {
            heads = (unsigned)strtoul(argv[i + 1], NULL, 10);
        } else if (strcmp(argv[i], "--offset-sd-um") == 0) {
            osd = (uint32_t)strtoul(argv[i + 1], NULL, 10);
        } else if (strcmp(argv[i], "--gain-sd-ppm") == 0) {
            gsd = (uint32_t)strtoul(argv[i + 1], NULL, 10);
        } else {
            fprintf(stderr, "usage: bench_calibration [--seed S] [--heads H] [--offset-sd-um U] "
                            "[--gain-sd-ppm P]\n");
            return 2;
        }
    }
    if (heads == 0u) {
        fprintf(stderr, "bench_calibration: --heads must be at least 1\n");
        return 2;
    }
    return run(seed, heads, osd, gsd);
}
