/* bench_estimator --steps: rows each estimator needs to notice an instantaneous step. */
/*
 * A static plate (α = β = 0, 500 mm, a = 30 mm, σ = 2 mm white Gaussian noise
 * on each VL53 reading, rounded to 1 mm, N = 100) steps in α by 1, 3 or 10 sd of a
 * window's estimate (sd = atan(σ/√(2N)/a): y_α = (x_C − x_A)/2 over N rows, 0.27°) at a
 * row placed at random in the sixth window (after five windows of learning). The delay
 * is the rows from the step to the last row of the first answer (at or after the step)
 * that is within 3 of its own sd of the new α or is not `ok`; answers that never do so
 * within 20 windows count as 2000 rows (none did in the published table). Behaviour
 * is not changed: this only measures.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "bench_steps.h"
#include "estimator/attitude.h"

#define STEP_N      100u
#define STEP_SIGMA  2.0
#define STEP_ARM_MM 30.0
#define STEP_CAP    (20u * STEP_N)

static uint64_t rs;
static double urand(void) {
    rs ^= rs << 13;
    rs ^= rs >> 7;
    rs ^= rs << 17;
    return (double)(rs >> 11) / 9007199254740992.0;
}
static double gauss(void) {
    double u, v, s;
    do {
        u = 2 * urand() - 1;
        v = 2 * urand() - 1;
        s = u * u + v * v;
    } while (s >= 1 || s == 0);
    return u * sqrt(-2 * log(s) / s);
}

struct step_case {
    const char *name;
    enum attitude_estimator est;
    bool auto_q;
};

/* Rows from the step to the first answer within 3 sd of the new α or not ok. */
static unsigned one_run(const struct step_case *c, enum attitude_window_mode mode, double step_deg,
                        uint64_t seed) {
    static struct attitude_state st;
    struct attitude_output out;
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    cfg.calibration.calibrated =
        true; /* ideal sensors: an exact calibration (offsets 0, gains 1, sd 0) */
    cfg.window = STEP_N;
    cfg.mode = mode;
    cfg.estimators = (uint8_t)(ATTITUDE_EST_BIT(c->est) |
                               ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS)); /* Kalman's check */
    cfg.kalman_process_noise_auto = c->auto_q;
    if (attitude_init(&st, &cfg) != ATTITUDE_ERR_NONE) {
        return STEP_CAP;
    }
    rs = seed * 0x9E3779B97F4A7C15u + 0x2545F4914F6CDD1Du;
    const uint32_t step_row = 5u * STEP_N + (uint32_t)(urand() * STEP_N);
    const uint8_t ok[4] = {0, 0, 0, 0};
    const bool present[4] = {true, true, true, true};
    for (uint32_t row = 0; row < step_row + STEP_CAP; ++row) {
        const double alpha = row >= step_row ? step_deg : 0.0;
        const double t = tan(alpha * 3.14159265358979323846 / 180.0) * STEP_ARM_MM;
        const double x[4] = {500 - t, 500, 500 + t, 500};
        uint16_t r[4];
        for (unsigned k = 0; k < 4; ++k) {
            r[k] = (uint16_t)lround(x[k] + STEP_SIGMA * gauss());
        }
        if (!attitude_push_sample(&st, r, ok, present, &out) || out.last_row < step_row) {
            continue;
        }
        const struct attitude_estimate *e = &out.est[c->est];
        const double err = fabs(e->alpha_udeg / 1e6 - step_deg);
        if (e->status != ATTITUDE_OK || err <= 3.0 * e->alpha_sd_udeg / 1e6) {
            return out.last_row - step_row;
        }
    }
    return STEP_CAP;
}

int bench_steps(unsigned seeds, uint64_t first_seed) {
    static const struct step_case cases[] = {
        {"consensus", ATTITUDE_EST_CONSENSUS, false},
        {"consensus-paper", ATTITUDE_EST_PAPER, false},
        {"kalman Q=0", ATTITUDE_EST_KALMAN, false},
        {"kalman auto", ATTITUDE_EST_KALMAN, true},
        {"mean", ATTITUDE_EST_MEAN, false},
    };
    static const double sizes[3] = {1.0, 3.0, 10.0};
    const double sd_deg =
        atan(STEP_SIGMA / sqrt(2.0 * STEP_N) / STEP_ARM_MM) * 180.0 / 3.14159265358979323846;
    printf("# Step detection delay: N %u, sigma %.1f mm, a %.0f mm, step sd %.3f deg, %u seeds "
           "(%llu..%llu)\n\n",
           STEP_N, STEP_SIGMA, STEP_ARM_MM, sd_deg, seeds, (unsigned long long)first_seed,
           (unsigned long long)(first_seed + seeds - 1u));
    printf("| estimator | mode | 1 sd: mean (max) rows | 3 sd | 10 sd |\n|---|---|---|---|---|\n");
    for (unsigned c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        for (unsigned m = 0; m < 2u; ++m) {
            const enum attitude_window_mode mode = m == 0u ? ATTITUDE_TUMBLING : ATTITUDE_SLIDING;
            printf("| %s | %s |", cases[c].name, m == 0u ? "tumbling" : "sliding");
            for (unsigned s = 0; s < 3u; ++s) {
                double sum = 0;
                unsigned worst = 0;
                for (unsigned i = 0; i < seeds; ++i) {
                    const unsigned d = one_run(&cases[c], mode, sizes[s] * sd_deg, first_seed + i);
                    sum += d;
                    worst = d > worst ? d : worst;
                }
                printf(" %.1f (%u) |", sum / seeds, worst);
            }
            printf("\n");
            fflush(stdout);
        }
    }
    return 0;
}
