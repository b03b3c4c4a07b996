/*
 * On-target test (QEMU, label `target`) of the estimator as the flight image builds it
 * (cmake/TofOptions.cmake: consensus and kalman; boards/mps2/CMakeLists.txt compiles the
 * estimator's sources into this image with that definition): a plate stepping from α = 0
 * to α = 3° halfway through a sliding run is followed by the Kalman filter with a fixed
 * process noise and with `auto`, and Q = 0 (the same filter) estimates a static plate. Exit
 * status 0 when every check holds; each failure is printed.
 */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "board.h"
#include "estimator/attitude.h"
#include "semihost.h"

_Static_assert(ATTITUDE_EST_BUILT == 0x05u, "compiled with the flight estimator set");

static struct attitude_state st;
static struct attitude_output out;
static int failures;

static void say(const char *s) {
    semihost_write_stdout(s, strlen(s));
}

static void check(bool ok, const char *what) {
    say(ok ? "ok   " : "FAIL ");
    say(what);
    say("\n");
    failures += ok ? 0 : 1;
}

/* 30·tan(3°) = 1.5723 mm: the A and C readings are 300 ∓ that, whole millimetres
 * dithered in proportion (the fraction 0.5723 as 5723 in 10^4) */
static uint16_t dithered(int32_t whole, int32_t frac_e4, unsigned row, unsigned k) {
    const uint32_t u = ((row * 37u + k * 11u) % 100u) * 100u + 50u;
    return (uint16_t)(whole + ((int32_t)u < frac_e4 ? 1 : 0));
}

/* The Kalman estimate's α (µdeg) at the end of a 600-row sliding run stepping at row 300;
 * *before: α at row 299. */
static int32_t run_step(uint32_t q_um2, bool automatic, int32_t *before) {
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    cfg.calibration.calibrated =
        true; /* ideal sensors: an exact calibration (offsets 0, gains 1, sd 0) */
    cfg.mode = ATTITUDE_SLIDING;
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        cfg.kalman_process_noise_um2[i] = q_um2;
    }
    cfg.kalman_process_noise_auto = automatic;
    if (attitude_init(&st, &cfg) != ATTITUDE_ERR_NONE) {
        check(false, "attitude_init");
        return 0;
    }
    const uint8_t status[4] = {0, 0, 0, 0};
    const bool present[4] = {true, true, true, true};
    int32_t alpha = 0;
    for (unsigned i = 0; i < 600u; ++i) {
        uint16_t r[4] = {300, 300, 300, 300};
        if (i >= 300u) {
            r[0] = dithered(298, 10000 - 5723, i, 0); /* 298.4277 */
            r[2] = dithered(301, 5723, i, 2);         /* 301.5723 */
        }
        if (attitude_push_sample(&st, r, status, present, &out)) {
            alpha = out.est[ATTITUDE_EST_KALMAN].alpha_udeg;
            if (i == 299u) {
                *before = alpha;
            }
        }
    }
    return alpha;
}

static bool near(int32_t v, int32_t want, int32_t tol) {
    return v - want < tol && want - v < tol;
}

int main(void) {
    int32_t before = 1;
    int32_t after = run_step(10000u, false, &before); /* 0.01 mm² per row */
    check(near(before, 0, 100000), "Q > 0: alpha 0 before the step");
    check(near(after, 3000000, 300000), "Q > 0: alpha 3 deg after the step");
    after = run_step(0u, true, &before);
    check(near(after, 3000000, 300000), "auto: alpha 3 deg after the step");
    after = run_step(0u, false, &before);
    check(near(before, 0, 100000), "Q = 0 on the tracking form: alpha 0 while static");
    say(failures == 0 ? "flight_tracking: all checks passed\n" : "flight_tracking: FAILED\n");
    return failures == 0 ? 0 : 1;
}

void board_exit(int status) {
    semihost_exit(status);
}

void board_fault(const char *what) {
    say("FAULT: ");
    say(what);
    say("\n");
    semihost_exit(128);
}
